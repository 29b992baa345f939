//! `qean demo --quick` end to end: the table, the artefacts, the checks against chance, a second
//! run that reuses every finished stage, and a third that refuses a run of another model.

mod common;

use common::qean;

fn png_size(path: &std::path::Path) -> (u32, u32, usize) {
    let png = std::fs::read(path).unwrap();
    assert_eq!(&png[1..4], b"PNG", "{}", path.display());
    let w = u32::from_be_bytes(png[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(png[20..24].try_into().unwrap());
    (w, h, png.len())
}

#[test]
fn quick_demo_trains_samples_evaluates_and_resumes() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("demo");
    let run = || {
        let o = qean()
            .args(["demo", "--quick", "--plain", "--out"])
            .arg(&out)
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&o.stdout).to_string();
        let stderr = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "demo failed:\n{stdout}\n{stderr}");
        (stdout, stderr)
    };
    let (table, _) = run();
    for row in [
        "| ground truth",
        "| tiny FACT |",
        "| tiny QEAN (full: SPE + QRA) |",
        "| tiny TSMT (Li et al.) |",
        "| tiny VQ-VAE + GPT (multi-modal control) |",
        "| chance: frozen seed pose |",
        "| chance: tiny FACT with random music (all pairings) |",
    ] {
        assert!(table.contains(row), "missing {row:?} in:\n{table}");
    }
    // Each model's held-out dance is judged, and the model is compared with both chance
    // baselines (the full demo's numbers are in docs/freezing.md: the quick one trains too
    // briefly to promise a dance, and says so).
    for label in [
        "tiny FACT",
        "tiny QEAN (full: SPE + QRA)",
        "tiny TSMT (Li et al.)",
        "tiny VQ-VAE + GPT (multi-modal control)",
    ] {
        let line = table
            .lines()
            .find(|l| l.starts_with(&format!("- {label}: the held-out dance ")))
            .unwrap_or_else(|| panic!("no check line for {label}:\n{table}"));
        assert!(
            line.contains("speed ratio per 5 s")
                && line.contains("the frozen baseline's")
                && line.contains("random pairing's"),
            "{line}"
        );
        let row = table
            .lines()
            .find(|l| l.starts_with(&format!("| {label} | ")) && l.matches('/').count() >= 6)
            .unwrap_or_else(|| panic!("no held-out dance row for {label}:\n{table}"));
        // Four 5-s spans of speed and of speed and acceleration ratios.
        assert_eq!(
            row.split('|').nth(2).unwrap().matches('/').count(),
            3,
            "{row}"
        );
    }
    assert!(table.contains("smoke test"), "{table}");
    assert!(table.contains("| beat F1 ↑ | A-seq-D →"), "{table}");
    // The 3-D page: every model's dance and the ground truth, the held-out song embedded.
    let page = std::fs::read_to_string(out.join("dances/compare.html")).unwrap();
    for label in [
        "ground truth",
        "tiny FACT",
        "tiny QEAN",
        "tiny TSMT",
        "tiny VQ-VAE + GPT",
    ] {
        assert!(page.contains(label), "{label} missing from the page");
    }
    assert!(page.contains("data:audio/ogg;base64,"));
    for model in ["fact", "qean", "tsmt", "gpt"] {
        let dir = out.join("dances").join(model);
        for f in [
            "Vibe_Ace.pkl",
            "Vibe_Ace.joints.npy",
            "Vibe_Ace.bvh",
            "Vibe_Ace.png",
            "Vibe_Ace.gif",
        ] {
            assert!(dir.join(f).is_file(), "{model}/{f} missing:\n{table}");
        }
        let joints = qean_io::npy::read(&dir.join("Vibe_Ace.joints.npy")).unwrap();
        // The quick demo's seed is 30 frames (TSMT's and the GPT's own: 120).
        let seed = if model == "tsmt" || model == "gpt" {
            120
        } else {
            30
        };
        assert_eq!(joints.shape, vec![seed + 1200, 24, 3]);
        let (w, h, bytes) = png_size(&dir.join("Vibe_Ace.png"));
        assert!(
            w >= 400 && h >= 200 && bytes > 2_000,
            "{w}×{h}, {bytes} bytes"
        );
        let report = out.join("runs").join(model).join("eval");
        assert!(report.is_dir(), "{}", report.display());
    }
    // The in-betweening section: a test dance rebuilt from 5 keys per measure by SLERP and by the
    // tiny in-betweener, each written and previewed, and the verdict in words.
    for row in [
        "| original | 0.0000 | 0.0000 |",
        "| SLERP |",
        "| tiny motion in-betweener (50 steps) |",
    ] {
        assert!(table.contains(row), "missing {row:?} in:\n{table}");
    }
    assert!(
        table.contains("- the in-betweener beats SLERP")
            || table.contains("- the in-betweener does NOT beat SLERP"),
        "{table}"
    );
    for f in [
        "edits.json",
        "original.gif",
        "slerp.pkl",
        "slerp.report.json",
        "inbetweener.pkl",
        "inbetweener.gif",
    ] {
        assert!(out.join("inbetween").join(f).is_file(), "inbetween/{f}");
    }
    let report: serde_json::Value = serde_json::from_slice(
        &std::fs::read(out.join("inbetween/inbetweener.report.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(report["method"], "transformer");
    assert_eq!(report["keep"], "grid:5");
    let summary = std::fs::read_to_string(out.join("summary.md")).unwrap();
    assert!(summary.contains("| tiny FACT |"), "{summary}");
    for licence in [
        "assets/music/Kevin_MacLeod_-_Vibe_Ace.LICENSE.txt",
        "assets/music/Brahms_Hungarian_Dance_5.LICENSE.txt",
        "assets/music/sorohanro_-_solo-trumpet-06.LICENSE.txt",
    ] {
        assert!(out.join(licence).is_file(), "{licence}");
    }
    let synth: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("data/synth.json")).unwrap()).unwrap();
    assert_eq!(
        synth["music"]["mBR1"]["source"],
        "sorohanro_-_solo-trumpet-06.ogg"
    );

    // Second run: everything is reused and the table is the same.
    let before = std::fs::read(out.join("runs/qean/metrics.csv")).unwrap();
    let (again, log) = run();
    for stage in [
        "dataset: reusing",
        "dance fact: reusing",
        "evaluate: reusing",
    ] {
        assert!(log.contains(stage), "missing {stage:?} in:\n{log}");
    }
    assert_eq!(
        std::fs::read(out.join("runs/qean/metrics.csv")).unwrap(),
        before
    );
    let rows = |t: &str| -> Vec<String> {
        t.lines()
            .filter(|l| l.starts_with('|'))
            .map(|l| {
                let cells: Vec<&str> = l.split('|').collect();
                cells[..cells.len().saturating_sub(2)].join("|")
            })
            .collect()
    };
    assert_eq!(rows(&again), rows(&table));

    // A run an earlier demo trained with another model (e.g. before a preset changed) is refused
    // by name before any training starts, instead of being continued as this demo's.
    for e in std::fs::read_dir(out.join("runs/qean/checkpoints")).unwrap() {
        let stored = e.unwrap().path().join("config.toml");
        let text = std::fs::read_to_string(&stored).unwrap();
        assert!(text.contains("heads = 2"), "{text}");
        std::fs::write(&stored, text.replacen("heads = 2", "heads = 8", 1)).unwrap();
    }
    let fact_before = std::fs::read(out.join("runs/fact/metrics.csv")).unwrap();
    let o = qean()
        .args(["demo", "--quick", "--plain", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    assert!(stderr.contains("runs/qean/checkpoints/step-"), "{stderr}");
    assert!(
        stderr.contains(
            "the checkpoint holds a different model than the config (checkpoint `heads = 8`, config `heads = 2`)"
        ),
        "{stderr}"
    );
    assert_eq!(
        std::fs::read(out.join("runs/fact/metrics.csv")).unwrap(),
        fact_before
    );
}
