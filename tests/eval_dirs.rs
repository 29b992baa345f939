//! The `qean-eval` command line through its library entry point: .npy loading, beats JSON, the JSON
//! report, and the clear errors for inputs this build does not read yet.

#[path = "../eval/tests/common/mod.rs"]
mod common;

use std::path::Path;

use clap::Parser;
use common::{aist_name, synthetic_motion};
use qean::eval_cli::Args;
use qean_eval::dirs::EvaluationFile;

/// Directory mode as `qean eval --generated A --reference B` runs it.
fn run(args: &Args) -> anyhow::Result<(EvaluationFile, String)> {
    Ok(qean_eval::dirs::evaluate_dirs(&args.dir_request()?)?)
}
use qean_eval::{Frame, MetricsMode, MetricsReport};

fn write_npy(path: &Path, joints: &[Frame], f32_dtype: bool, flat: bool) {
    let shape = if flat {
        format!("({}, 72)", joints.len())
    } else {
        format!("({}, 24, 3)", joints.len())
    };
    let descr = if f32_dtype { "<f4" } else { "<f8" };
    let mut bytes = Vec::new();
    for f in joints {
        for p in f {
            for &x in p {
                if f32_dtype {
                    bytes.extend_from_slice(&(x as f32).to_le_bytes());
                } else {
                    bytes.extend_from_slice(&x.to_le_bytes());
                }
            }
        }
    }
    std::fs::write(path, qean_io::testdata::npy_bytes(descr, &shape, &bytes)).unwrap();
}

fn fixture(dir: &Path) {
    fixture_of(dir, 180, 240);
}

/// Four generated motions of `gen_frames` and seven reference motions of `ref_frames` (60 fps).
fn fixture_of(dir: &Path, gen_frames: usize, ref_frames: usize) {
    std::fs::create_dir_all(dir.join("gen")).unwrap();
    std::fs::create_dir_all(dir.join("ref")).unwrap();
    for i in 0..4 {
        let name = aist_name("LO", i, i, i);
        write_npy(
            &dir.join(format!("gen/{name}.npy")),
            &synthetic_motion(i as u64, gen_frames),
            i % 2 == 0,
            i == 1,
        );
    }
    for i in 0..7 {
        let name = aist_name("LO", i % 6, i, i);
        write_npy(
            &dir.join(format!("ref/{name}.npy")),
            &synthetic_motion(50 + i as u64, ref_frames),
            false,
            false,
        );
    }
    let beats: std::collections::BTreeMap<String, Vec<usize>> = (0..6)
        .map(|k| {
            (
                format!("mLO{k}"),
                (0..20).map(|b| 11 + 24 * b + k).collect(),
            )
        })
        .collect();
    std::fs::write(
        dir.join("beats.json"),
        serde_json::to_string(&beats).unwrap(),
    )
    .unwrap();
}

#[test]
fn evaluates_npy_directories_and_writes_json() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    fixture(d);
    let out = d.join("report.json");
    let args = Args::parse_from([
        "qean-eval",
        "--generated",
        d.join("gen").to_str().unwrap(),
        "--reference",
        d.join("ref").to_str().unwrap(),
        "--beats",
        d.join("beats.json").to_str().unwrap(),
        "--seed-frames",
        "30",
        "--ba-variant",
        "mint",
        "--metrics-mode",
        "corrected",
        "--json",
        out.to_str().unwrap(),
    ]);
    let (file, table) = run(&args).unwrap();
    assert_eq!(file.reports.len(), 1);
    let report = &file.reports[0];
    assert_eq!((report.n_generated, report.n_reference), (4, 7));
    assert!(report.sequences.iter().all(|s| s.frames == 150));
    assert!(report.beat_align.is_some());
    assert!(table.contains("| generated |"));
    assert!(table.contains("metrics_mode=corrected") && table.contains("BeatAlign = mint variant"));
    let back: EvaluationFile =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    let back: MetricsReport = back.reports.into_iter().next().unwrap();
    // serde_json's default float parsing may differ in the last bit: compare to 1e-12.
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * a.abs().max(1.0);
    assert!(close(back.fid_k, report.fid_k) && close(back.fid_g, report.fid_g));
    assert!(close(back.beat_align.unwrap(), report.beat_align.unwrap()));
    assert_eq!(back.config, report.config);
    assert_eq!(back.sequences.len(), 4);
    assert_eq!(back.sequences[3].name, report.sequences[3].name);
}

#[test]
fn f32_and_f64_npy_give_the_same_features_to_f32_precision() {
    let tmp = tempfile::tempdir().unwrap();
    let j = synthetic_motion(3, 50);
    write_npy(&tmp.path().join("a.npy"), &j, true, false);
    write_npy(&tmp.path().join("b.npy"), &j, false, true);
    let root = qean_motion::FkRoot::Smpl;
    let a = qean_eval::io::read_joints(&tmp.path().join("a.npy"), root).unwrap();
    let b = qean_eval::io::read_joints(&tmp.path().join("b.npy"), root).unwrap();
    assert_eq!(b, j);
    assert_eq!(a.len(), 50);
    assert!((a[10][5][1] - j[10][5][1]).abs() < 1e-6);
}

#[test]
fn clear_errors_for_unsupported_inputs() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    fixture(d);
    let base = |extra: &[&str]| {
        let mut v = vec![
            "qean-eval".to_string(),
            "--generated".into(),
            d.join("gen").display().to_string(),
            "--reference".into(),
            d.join("ref").display().to_string(),
        ];
        v.extend(extra.iter().map(|s| s.to_string()));
        Args::parse_from(v)
    };
    let err = run(&base(&["--music", "/nowhere"])).unwrap_err();
    assert!(
        format!("{err:#}").contains("/nowhere: music directory does not exist"),
        "{err:#}"
    );
    std::fs::write(d.join("gen/x.pkl"), b"not a pickle").unwrap();
    let err = run(&base(&[])).unwrap_err();
    assert!(
        format!("{err:#}").contains("x.pkl: not a readable pickle"),
        "{err:#}"
    );
    std::fs::remove_file(d.join("gen/x.pkl")).unwrap();
    std::fs::write(d.join("gen/bad.npy"), b"\x93NUMPY\x01\x00garbage").unwrap();
    let err = run(&base(&[])).unwrap_err();
    assert!(format!("{err:#}").contains("bad.npy"), "{err:#}");
    std::fs::remove_file(d.join("gen/bad.npy")).unwrap();
    let err = run(&base(&[
        "--beats",
        d.join("missing.json").to_str().unwrap(),
    ]))
    .unwrap_err();
    assert!(format!("{err:#}").contains("missing.json"), "{err:#}");
    std::fs::write(d.join("few.json"), "{\"mLO0\": [1, 2]}").unwrap();
    let err = run(&base(&["--beats", d.join("few.json").to_str().unwrap()])).unwrap_err();
    assert!(
        format!("{err:#}").contains("no beats for music ID 'mLO1'"),
        "{err:#}"
    );
}

#[test]
fn both_metrics_modes_by_default() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    fixture(d);
    let args = Args::parse_from([
        "qean-eval",
        "--generated",
        d.join("gen").to_str().unwrap(),
        "--reference",
        d.join("ref").to_str().unwrap(),
        "--seed-frames",
        "30",
        "--label",
        "ours",
    ]);
    let (file, table) = run(&args).unwrap();
    let modes: Vec<_> = file.reports.iter().map(|r| r.config.metrics_mode).collect();
    assert_eq!(modes, [MetricsMode::Reference, MetricsMode::Corrected]);
    // The acceleration bug changes the kinetic features, and τ the geometric ones.
    assert_ne!(file.reports[0].fid_k, file.reports[1].fid_k);
    assert!(
        table.contains("| ours (reference) |") && table.contains("| ours (corrected) |"),
        "{table}"
    );
    assert_eq!(file.reports[0].beat_align, None);
}

/// Generated files named freely (another system's outputs on other music), paired by a CSV or by
/// `.music` sidecars, score BeatAlign against the music they name; the same files without a pairing
/// are refused as before (the AIST++ name rule stays the default).
#[test]
fn generated_files_with_any_names_are_scored_through_an_explicit_pairing() {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    fixture(d);
    let free = d.join("free");
    std::fs::create_dir_all(&free).unwrap();
    for (i, name) in ["take one", "take-two", "x3"].iter().enumerate() {
        write_npy(
            &free.join(format!("{name}.joints.npy")),
            &synthetic_motion(20 + i as u64, 180),
            false,
            false,
        );
    }
    let args = |extra: &[&str]| {
        let mut v = vec![
            "qean-eval".to_string(),
            "--generated".into(),
            free.to_string_lossy().into_owned(),
            "--reference".into(),
            d.join("ref").to_string_lossy().into_owned(),
            "--beats".into(),
            d.join("beats.json").to_string_lossy().into_owned(),
            "--seed-frames".into(),
            "30".into(),
            "--metrics-mode".into(),
            "reference".into(),
        ];
        v.extend(extra.iter().map(|s| s.to_string()));
        Args::parse_from(v)
    };
    // No pairing: the name rule refuses the files, naming one and the ways out.
    let e = format!("{:#}", run(&args(&[])).unwrap_err());
    assert!(
        e.contains("no AIST++ music ID") && e.contains("--pairing"),
        "{e}"
    );

    let csv = d.join("pairs.csv");
    std::fs::write(
        &csv,
        "generated,music\ntake one.joints.npy,mLO1\ntake-two,mLO2\nx3.npy,mLO2\n",
    )
    .unwrap();
    let (file, _) = run(&args(&["--pairing", csv.to_str().unwrap()])).unwrap();
    let r = &file.reports[0];
    assert_eq!((r.n_generated, r.n_beat_align), (3, 3));
    let ids: Vec<_> = r.sequences.iter().map(|s| s.music_id.clone()).collect();
    assert_eq!(
        ids,
        [
            Some("mLO1".into()),
            Some("mLO2".into()),
            Some("mLO2".into())
        ]
    );

    // Sidecars do the same, file by file.
    for (name, key) in [("take one", "mLO1"), ("take-two", "mLO2"), ("x3", "mLO2")] {
        std::fs::write(free.join(format!("{name}.music")), format!("{key}\n")).unwrap();
    }
    let (side, _) = run(&args(&[])).unwrap();
    assert_eq!(side.reports[0].beat_align, r.beat_align);

    // A malformed pairing file or a row naming no generated file: one line naming the file.
    std::fs::write(&csv, "generated,music\ntake one,mLO1,extra\n").unwrap();
    let e = format!(
        "{:#}",
        run(&args(&["--pairing", csv.to_str().unwrap()])).unwrap_err()
    );
    assert!(e.contains("pairs.csv line 2: expected two columns"), "{e}");
    std::fs::write(&csv, "nobody.npy,mLO1\n").unwrap();
    let e = format!(
        "{:#}",
        run(&args(&["--pairing", csv.to_str().unwrap()])).unwrap_err()
    );
    assert!(
        e.contains("\"nobody\", which is not among the generated motions"),
        "{e}"
    );
}

/// The same dances under two protocol presets: two reports, each naming its preset, in two tables
/// (their numbers never share a column); Bailando's preset is our default protocol.
#[test]
fn the_same_dances_under_two_presets_give_two_labelled_reports() {
    use qean_eval::preset::{JointSet, ProtocolPreset};
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    // 30 seed + 660 dance frames: 330 at 30 fps, EDGE's 150-frame slices at 0, 75 and 150.
    fixture_of(d, 690, 700);
    let out = d.join("report.json");
    let argv = |extra: &[&str]| {
        let mut v: Vec<String> = [
            "qean-eval",
            "--generated",
            d.join("gen").to_str().unwrap(),
            "--reference",
            d.join("ref").to_str().unwrap(),
            "--beats",
            d.join("beats.json").to_str().unwrap(),
            "--seed-frames",
            "30",
            "--metrics-mode",
            "reference",
            "--label",
            "ours",
        ]
        .iter()
        .map(|x| x.to_string())
        .collect();
        v.extend(extra.iter().map(|x| x.to_string()));
        Args::parse_from(v)
    };
    let (file, table) = run(&argv(&[
        "--protocol-preset",
        "bailando,edge",
        "--json",
        out.to_str().unwrap(),
    ]))
    .unwrap();
    let presets: Vec<_> = file.reports.iter().map(|r| r.config.preset).collect();
    assert_eq!(
        presets,
        [Some(ProtocolPreset::Bailando), Some(ProtocolPreset::Edge)]
    );
    let (bailando, edge) = (&file.reports[0], &file.reports[1]);
    assert_eq!((edge.n_generated, edge.n_reference), (12, 21));
    assert!(edge.sequences.iter().all(|s| s.frames == 150));
    assert_eq!(
        edge.sequences[1].name,
        format!("{}@001", aist_name("LO", 0, 0, 0))
    );
    assert!(edge.pfc.is_some() && edge.beat_align.is_some());
    assert_ne!(bailando.fid_k, edge.fid_k);
    for needle in [
        "**Protocol preset `bailando`**",
        "**Protocol preset `edge`**",
        "| ours (bailando) |",
        "| ours (edge) |",
        "| Methods | PFC ↓ | BeatAlign ↑ | Dist_k ↑ | Dist_g ↑ |",
        "| evaluated clips | 5 s (150 frames) every 2.5 s (75 frames) of each dance | inferred |",
        "protocol preset edge: ",
    ] {
        assert!(table.contains(needle), "{needle} missing from\n{table}");
    }
    // Two tables: the Bailando block ends before the EDGE block begins.
    let (b, e) = (
        table.find("| ours (bailando) |").unwrap(),
        table.find("**Protocol preset `edge`**").unwrap(),
    );
    assert!(b < e && !table[e..].contains("| ours (bailando) |"));
    let back: EvaluationFile =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(back.reports[1].config, edge.config);

    // Bailando's preset is our default protocol: the same numbers as no preset.
    let (plain, _) = run(&argv(&[])).unwrap();
    assert_eq!(plain.reports[0].fid_k, bailando.fid_k);
    assert_eq!(plain.reports[0].beat_align, bailando.beat_align);

    // Lodge: 22 body joints (66-D kinetic features), the first 1,024 frames at 30 fps.
    let (lodge, table) = run(&argv(&["--protocol-preset", "lodge"])).unwrap();
    let l = &lodge.reports[0];
    assert_eq!(l.config.joints, JointSet::Body22);
    assert!(l
        .sequences
        .iter()
        .all(|s| s.kinetic.len() == 66 && s.frames == 330));
    assert!(table.contains("22 body joints"), "{table}");
}

/// A preset fixes clip length, positions, PFC and BeatAlign's frames: setting one of them as well is
/// refused, and checkpoint mode takes one preset.
#[test]
fn a_preset_and_a_setting_it_fixes_are_refused_together() {
    for flag in [
        ["--max-frames", "300"],
        ["--positions", "mint_absolute"],
        ["--pfc", "ours"],
    ] {
        let e = Args::try_parse_from(
            [
                "qean-eval",
                "--generated",
                "g",
                "--reference",
                "r",
                "--protocol-preset",
                "edge",
            ]
            .into_iter()
            .chain(flag),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("cannot be used with"), "{e}");
    }
    let two = Args::parse_from([
        "qean-eval",
        "--run",
        "R",
        "--data",
        "D",
        "--protocol-preset",
        "edge,lodge",
    ]);
    let e = two.run_request(Path::new("R")).unwrap_err().to_string();
    assert!(e.contains("one --protocol-preset"), "{e}");
    let one = Args::parse_from([
        "qean-eval",
        "--run",
        "R",
        "--data",
        "D",
        "--protocol-preset",
        "lodge",
    ]);
    assert_eq!(one.run_request(Path::new("R")).unwrap().max_frames, 2048);
}
