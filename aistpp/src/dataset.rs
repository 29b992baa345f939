//! An AIST++-layout dataset directory (SPEC §1.3):
//!
//! ```text
//! DIR/motions/<sequence>.pkl
//! DIR/wav/<music ID>.wav            (also .ogg, .mp3, .flac)
//! DIR/splits/crossmodal_{train,val,test}.txt
//! DIR/ignore_list.txt
//! ```
//!
//! When the split lists or the ignore list are missing, the official AIST++ lists shipped with this crate are
//! used (train and test from the AIST++ release; val derived from test by the mint rule `_ch02` → `_ch01`).

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

use crate::names::{music_id_of, SequenceName};
use qean_io::error::{Error, Result};

const EMBEDDED_TRAIN: &str = include_str!("../assets/aistpp/splits/crossmodal_train.txt");
const EMBEDDED_VAL: &str = include_str!("../assets/aistpp/splits/crossmodal_val.txt");
const EMBEDDED_TEST: &str = include_str!("../assets/aistpp/splits/crossmodal_test.txt");
const EMBEDDED_IGNORE: &str = include_str!("../assets/aistpp/ignore_list.txt");

/// Audio extensions looked for under `wav/`, in order.
pub const AUDIO_EXTENSIONS: [&str; 4] = ["wav", "ogg", "mp3", "flac"];

#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    Train,
    Val,
    Test,
}

impl Split {
    pub const ALL: [Split; 3] = [Split::Train, Split::Val, Split::Test];

    pub fn name(self) -> &'static str {
        match self {
            Split::Train => "train",
            Split::Val => "val",
            Split::Test => "test",
        }
    }

    pub fn file_name(self) -> String {
        format!("crossmodal_{}.txt", self.name())
    }

    fn embedded(self) -> &'static str {
        match self {
            Split::Train => EMBEDDED_TRAIN,
            Split::Val => EMBEDDED_VAL,
            Split::Test => EMBEDDED_TEST,
        }
    }
}

impl std::str::FromStr for Split {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s {
            "train" => Ok(Split::Train),
            "val" => Ok(Split::Val),
            "test" => Ok(Split::Test),
            _ => Err(format!("unknown split '{s}' (expected train, val or test)")),
        }
    }
}

/// Where a list came from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum ListSource {
    File(PathBuf),
    Embedded,
}

/// Parse a name list: one name per line; trim, skip blank lines and `#` comments.
pub fn parse_list(text: &str) -> Vec<String> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(String::from)
        .collect()
}

/// An opened dataset directory.
#[derive(Debug, Clone)]
pub struct Dataset {
    pub root: PathBuf,
    splits: BTreeMap<Split, (Vec<String>, ListSource)>,
    ignore: HashSet<String>,
    ignore_source: ListSource,
}

impl Dataset {
    /// Open `dir`: it must exist and hold a `motions/` directory. Split lists are read now.
    pub fn open(dir: &Path) -> Result<Dataset> {
        if !dir.exists() {
            return Err(Error::at(dir, "dataset directory does not exist"));
        }
        if !dir.is_dir() {
            return Err(Error::at(
                dir,
                "is not a directory (expected an AIST++-layout dataset)",
            ));
        }
        let motions = dir.join("motions");
        if !motions.is_dir() {
            return Err(Error::at(
                dir,
                "not an AIST++-layout dataset: no motions/ directory (expected motions/*.pkl, wav/, splits/)",
            ));
        }
        let mut splits = BTreeMap::new();
        for split in Split::ALL {
            let path = dir.join("splits").join(split.file_name());
            let entry = if path.exists() {
                let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
                let names = parse_list(&text);
                if names.is_empty() {
                    return Err(Error::at(&path, "split file is empty"));
                }
                for n in &names {
                    SequenceName::parse(n).map_err(|e| Error::at(&path, e.message))?;
                }
                (names, ListSource::File(path))
            } else {
                (parse_list(split.embedded()), ListSource::Embedded)
            };
            splits.insert(split, entry);
        }
        let ignore_path = dir.join("ignore_list.txt");
        let (ignore, ignore_source) = if ignore_path.exists() {
            let text =
                std::fs::read_to_string(&ignore_path).map_err(|e| Error::io(&ignore_path, e))?;
            (parse_list(&text), ListSource::File(ignore_path))
        } else {
            (parse_list(EMBEDDED_IGNORE), ListSource::Embedded)
        };
        Ok(Dataset {
            root: dir.to_path_buf(),
            splits,
            ignore: ignore.into_iter().collect(),
            ignore_source,
        })
    }

    /// The usable sequences of a split (ignored names removed, as mint does), in file order.
    pub fn split(&self, split: Split) -> Vec<String> {
        self.splits[&split]
            .0
            .iter()
            .filter(|n| !self.ignore.contains(*n))
            .cloned()
            .collect()
    }

    /// The split list as written, ignored names included.
    pub fn split_listed(&self, split: Split) -> &[String] {
        &self.splits[&split].0
    }

    pub fn split_source(&self, split: Split) -> &ListSource {
        &self.splits[&split].1
    }

    pub fn ignore_source(&self) -> &ListSource {
        &self.ignore_source
    }

    pub fn is_ignored(&self, name: &str) -> bool {
        self.ignore.contains(name)
    }

    pub fn motions_dir(&self) -> PathBuf {
        self.root.join("motions")
    }

    pub fn motion_path(&self, name: &str) -> PathBuf {
        self.motions_dir().join(format!("{name}.pkl"))
    }

    /// The audio file of a music ID, if present under `wav/`.
    pub fn audio_path(&self, music_id: &str) -> Option<PathBuf> {
        AUDIO_EXTENSIONS
            .iter()
            .map(|ext| self.root.join("wav").join(format!("{music_id}.{ext}")))
            .find(|p| p.is_file())
    }

    /// The directory where cached 35-D music features live (`DIR/features/<music ID>.npy`).
    pub fn features_dir(&self) -> PathBuf {
        self.root.join("features")
    }

    /// Every motion file present (stems), sorted, ignored names removed: the GT reference set of SPEC §1.6.
    pub fn all_sequences(&self) -> Result<Vec<String>> {
        let dir = self.motions_dir();
        let mut names = Vec::new();
        for entry in std::fs::read_dir(&dir).map_err(|e| Error::io(&dir, e))? {
            let entry = entry.map_err(|e| Error::io(&dir, e))?;
            let path = entry.path();
            if path.extension().and_then(|e| e.to_str()) == Some("pkl") {
                if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
                    if !self.ignore.contains(stem) {
                        names.push(stem.to_string());
                    }
                }
            }
        }
        names.sort();
        Ok(names)
    }

    /// Music IDs used by the given sequences, sorted and de-duplicated.
    pub fn music_ids<'a>(names: impl IntoIterator<Item = &'a String>) -> Vec<String> {
        let mut ids: Vec<String> = names.into_iter().filter_map(|n| music_id_of(n)).collect();
        ids.sort();
        ids.dedup();
        ids
    }

    /// Counts per split and what is missing on disk.
    pub fn summary(&self) -> Result<DatasetSummary> {
        let mut splits = Vec::new();
        for split in Split::ALL {
            let listed = self.split_listed(split);
            let usable = self.split(split);
            let missing_motions: Vec<String> = usable
                .iter()
                .filter(|n| !self.motion_path(n).is_file())
                .cloned()
                .collect();
            let music = Self::music_ids(&usable);
            let missing_music: Vec<String> = music
                .iter()
                .filter(|m| self.audio_path(m).is_none())
                .cloned()
                .collect();
            splits.push(SplitSummary {
                split,
                listed: listed.len(),
                ignored: listed.len() - usable.len(),
                usable: usable.len(),
                music_ids: music.len(),
                missing_motions,
                missing_music,
                source: self.split_source(split).clone(),
            });
        }
        Ok(DatasetSummary {
            root: self.root.clone(),
            motion_files: self.all_sequences()?.len(),
            splits,
        })
    }
}

#[derive(Debug, Clone)]
pub struct SplitSummary {
    pub split: Split,
    pub listed: usize,
    pub ignored: usize,
    pub usable: usize,
    pub music_ids: usize,
    pub missing_motions: Vec<String>,
    pub missing_music: Vec<String>,
    pub source: ListSource,
}

#[derive(Debug, Clone)]
pub struct DatasetSummary {
    pub root: PathBuf,
    /// Motion files present and not ignored.
    pub motion_files: usize,
    pub splits: Vec<SplitSummary>,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn empty_dataset() -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("motions")).unwrap();
        d
    }

    /// SPEC §9.1: 980/20/20/45 names; 952 usable for training; music disjointness.
    #[test]
    fn embedded_official_lists() {
        let d = empty_dataset();
        let ds = Dataset::open(d.path()).unwrap();
        assert_eq!(ds.split_listed(Split::Train).len(), 980);
        assert_eq!(ds.split_listed(Split::Test).len(), 20);
        assert_eq!(ds.split_listed(Split::Val).len(), 20);
        assert_eq!(ds.ignore.len(), 45);
        assert_eq!(ds.split(Split::Train).len(), 952);
        assert_eq!(ds.split(Split::Test).len(), 20);
        let train_music: HashSet<String> = Dataset::music_ids(&ds.split(Split::Train))
            .into_iter()
            .collect();
        let test_music = Dataset::music_ids(&ds.split(Split::Test));
        assert_eq!(test_music.len(), 10);
        assert!(test_music.iter().all(|m| !train_music.contains(m)));
        assert_eq!(Dataset::music_ids(&ds.split(Split::Val)), test_music);
        assert_eq!(*ds.split_source(Split::Train), ListSource::Embedded);
    }

    #[test]
    fn shipped_lists_equal_shared_ones() {
        let shared = qean_io::testdata::shared_dir().join("aistpp");
        for split in Split::ALL {
            let text =
                std::fs::read_to_string(shared.join("splits").join(split.file_name())).unwrap();
            assert_eq!(parse_list(&text), parse_list(split.embedded()));
        }
        let text = std::fs::read_to_string(shared.join("ignore_list.txt")).unwrap();
        assert_eq!(parse_list(&text), parse_list(EMBEDDED_IGNORE));
    }

    #[test]
    fn bad_directories() {
        let d = tempfile::tempdir().unwrap();
        let e = Dataset::open(&d.path().join("nope")).unwrap_err();
        assert!(e.to_string().contains("does not exist"));
        let e = Dataset::open(d.path()).unwrap_err();
        assert!(e.to_string().contains("no motions/"));
        std::fs::create_dir(d.path().join("motions")).unwrap();
        std::fs::create_dir(d.path().join("splits")).unwrap();
        std::fs::write(d.path().join("splits/crossmodal_test.txt"), "\n  \n").unwrap();
        let e = Dataset::open(d.path()).unwrap_err();
        assert!(
            e.to_string()
                .contains("crossmodal_test.txt: split file is empty"),
            "{e}"
        );
        std::fs::write(d.path().join("splits/crossmodal_test.txt"), "not_a_name\n").unwrap();
        let e = Dataset::open(d.path()).unwrap_err();
        assert!(e.to_string().contains("not an AIST++ sequence name"), "{e}");
    }
}
