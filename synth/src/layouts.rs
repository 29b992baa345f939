//! The synthetic dataset in FineDance's layout or as a plain folder of dances (`qean synth --layout`): the
//! AIST++-layout set converted file by file, so tests and the demo exercise those readers without the real
//! data (FineDance is not redistributed).

use std::collections::BTreeMap;
use std::path::Path;

use qean_aistpp::dataset::{Dataset, Split};
use qean_aistpp::layout::{DataLayout, FineDanceSplit};
use qean_io::error::{Error, Result};
use qean_io::fsutil::atomic_write;
use qean_motion::finedance::{from_motion, WIDTH};

use crate::SynthReport;

/// The FineDance genre label each synthetic genre gets (in AIST++'s genre order): labels only, the synthetic
/// moves are not those styles.
const LABELS: [&str; 10] = [
    "Breaking",
    "Popping",
    "Locking",
    "Hiphop",
    "Urban",
    "Choreography",
    "Korean",
    "Chinese",
    "Jazz",
    "Kun",
];

/// Convert the AIST++-layout set in `aist` into `out` (an existing empty directory) in `layout`; the report
/// is `report` with the new names.
pub fn convert(
    aist: &Path,
    out: &Path,
    layout: DataLayout,
    report: &SynthReport,
) -> Result<SynthReport> {
    let ds = Dataset::open_as(aist, DataLayout::Aistpp)?;
    let plan = plan(&ds, layout)?;
    let (motion_dir, audio_dir) = (layout.motions_dir(out), layout.audio_dir(out));
    let labels = out.join("label_json");
    let mut dirs = vec![&motion_dir, &audio_dir];
    if layout == DataLayout::FineDance {
        dirs.push(&labels);
    }
    for d in dirs {
        std::fs::create_dir_all(d).map_err(|e| Error::io(d, e))?;
    }
    let mut splits: BTreeMap<String, Vec<String>> = BTreeMap::new();
    let mut music = BTreeMap::new();
    for (split, source, name) in &plan {
        let music_id = ds
            .music_id(source)
            .expect("synthetic names carry a music ID");
        let audio = ds
            .audio_path(&music_id)
            .ok_or_else(|| Error::at(ds.audio_dir(), format!("no music for {music_id}")))?;
        let to = audio_dir.join(format!("{name}.wav"));
        std::fs::copy(&audio, &to).map_err(|e| Error::io(&to, e))?;
        match layout {
            DataLayout::FineDance => {
                let rows: Vec<f32> = from_motion(&ds.read_motion(source)?)
                    .iter()
                    .map(|&v| v as f32)
                    .collect();
                let path = motion_dir.join(format!("{name}.npy"));
                qean_io::npy::write_f32(&path, &[rows.len() / WIDTH, WIDTH], &rows)?;
                let genre = ds.genre(source).expect("synthetic names carry a genre");
                let label = serde_json::json!({
                    "name": format!("{music_id} (synthetic)"),
                    "style1": "Street",
                    "style2": LABELS[genre],
                });
                atomic_write(
                    &labels.join(format!("{name}.json")),
                    label.to_string().as_bytes(),
                )?;
            }
            DataLayout::Folder | DataLayout::Aistpp => {
                let to = motion_dir.join(format!("{name}.pkl"));
                std::fs::copy(ds.motion_path(source), &to).map_err(|e| Error::io(&to, e))?;
            }
        }
        splits
            .entry(split.name().to_string())
            .or_default()
            .push(name.clone());
        if let Some(info) = report.music.get(&music_id) {
            music.insert(name.clone(), info.clone());
        }
    }
    if layout == DataLayout::FineDance {
        // FineDance@Genre validates on its test list.
        let test = splits.get("test").cloned().unwrap_or_default();
        splits.insert("val".into(), test);
    }
    // The lists of what was written (the embedded FineDance lists name all 211 dances of the release).
    std::fs::create_dir_all(out.join("splits")).map_err(|e| Error::io(out.join("splits"), e))?;
    for (split, names) in &splits {
        atomic_write(
            &out.join("splits").join(format!("{split}.txt")),
            names.join("\n").as_bytes(),
        )?;
    }
    Ok(SynthReport {
        splits,
        music,
        ..report.clone()
    })
}

/// (split, AIST++ name, new name) of every sequence. FineDance: test dances take FineDance@Genre's test IDs
/// and training dances its training IDs, as the release would split them (@Genre's validation list is its
/// test list, so the AIST++ plan's val dances are left out).
fn plan(ds: &Dataset, layout: DataLayout) -> Result<Vec<(Split, String, String)>> {
    let mut out = Vec::new();
    match layout {
        DataLayout::FineDance => {
            let [train_ids, _, test_ids, ignore] = FineDanceSplit::Genre.lists();
            let test_ids: Vec<String> = test_ids
                .into_iter()
                .filter(|i| !ignore.contains(i))
                .collect();
            for (split, ids) in [(Split::Train, &train_ids), (Split::Test, &test_ids)] {
                let names = ds.split(split);
                if names.len() > ids.len() {
                    return Err(Error::msg(format!(
                        "a FineDance-layout set holds at most {} {} dances (FineDance@Genre's IDs), {} asked",
                        ids.len(),
                        split.name(),
                        names.len()
                    )));
                }
                out.extend(
                    names
                        .into_iter()
                        .zip(ids)
                        .map(|(n, id)| (split, n, id.clone())),
                );
            }
        }
        DataLayout::Folder | DataLayout::Aistpp => {
            for split in Split::ALL {
                out.extend(ds.split(split).into_iter().map(|n| (split, n.clone(), n)));
            }
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{generate, generate_as, SynthOptions};

    fn opts() -> SynthOptions {
        SynthOptions {
            sequences: 6,
            seconds: 2.0,
            ..SynthOptions::default()
        }
    }

    /// The FineDance-layout set read back is the AIST++-layout set it came from: every 30-fps frame kept
    /// (within f32), the music byte for byte, the genre labels readable, the splits by FineDance@Genre's IDs.
    #[test]
    fn a_finedance_set_reads_back_as_written() {
        let d = tempfile::tempdir().unwrap();
        let (aist, fd) = (d.path().join("aist"), d.path().join("fd"));
        let source = generate(&aist, &opts()).unwrap();
        let report = generate_as(&fd, &opts(), DataLayout::FineDance).unwrap();
        let (a, f) = (Dataset::open(&aist).unwrap(), Dataset::open(&fd).unwrap());
        assert_eq!(f.layout, DataLayout::FineDance);
        assert_eq!(f.split(Split::Val), f.split(Split::Test));
        assert_eq!(report.splits["test"], vec!["063".to_string()]);
        for split in [Split::Train, Split::Test] {
            assert_eq!(source.splits[split.name()].len(), f.split(split).len());
            for (name, id) in a.split(split).iter().zip(f.split(split)) {
                let (m, back) = (a.read_motion(name).unwrap(), f.read_motion(&id).unwrap());
                assert_eq!(back.frames, m.frames.div_ceil(2) * 2 - 1);
                for frame in (0..back.frames).step_by(2) {
                    for i in 0..66 {
                        let (x, y) = (m.poses[frame * 72 + i], back.poses[frame * 72 + i]);
                        let (sx, sy) = (x.sin(), y.sin());
                        assert!(
                            (sx - sy).abs() < 1e-4 || (x - y).abs() < 1e-4,
                            "{id} frame {frame}: {x} {y}"
                        );
                    }
                }
                let music = |ds: &Dataset, n: &str| {
                    std::fs::read(ds.audio_path(&ds.music_id(n).unwrap()).unwrap()).unwrap()
                };
                assert_eq!(music(&a, name), music(&f, &id));
                assert!(f.genre_label(&id).unwrap().is_some());
            }
        }
    }

    /// A folder set holds the same dances under their own names, with its split lists.
    #[test]
    fn a_folder_set_reads_back_as_written() {
        let d = tempfile::tempdir().unwrap();
        let (aist, dir) = (d.path().join("aist"), d.path().join("mine"));
        generate(&aist, &opts()).unwrap();
        generate_as(&dir, &opts(), DataLayout::Folder).unwrap();
        let (a, f) = (Dataset::open(&aist).unwrap(), Dataset::open(&dir).unwrap());
        assert_eq!(f.layout, DataLayout::Folder);
        for split in Split::ALL {
            assert_eq!(a.split(split), f.split(split));
        }
        let name = &a.split(Split::Test)[0];
        assert_eq!(
            a.read_motion(name).unwrap().poses,
            f.read_motion(name).unwrap().poses
        );
        assert!(f.audio_path(name).is_some());
    }
}
