//! A dataset directory: its layout (AIST++'s, SPEC §1.3; FineDance's; a plain folder: `crate::layout`), its
//! split lists and ignore list, and the sequences' motions, music and genres, the same for every layout.
//!
//! ```text
//! DIR/motions/<sequence>.pkl
//! DIR/wav/<music ID>.wav            (also .ogg, .mp3, .flac)
//! DIR/splits/crossmodal_{train,val,test}.txt
//! DIR/ignore_list.txt
//! ```
//!
//! When the split lists or the ignore list are missing, the official AIST++ lists shipped with this crate are
//! used (train and test from the AIST++ release; val derived from test by the mint rule `_ch02` → `_ch01`);
//! for FineDance, FineDance@Genre's; for a folder, `layout::folder_splits`.

use std::collections::{BTreeMap, HashSet};
use std::path::{Path, PathBuf};

use crate::layout::{folder_splits, DataLayout, FineDanceSplit};
use crate::names::{genre_of, music_id_of};
use qean_io::error::{Error, Result};
use qean_motion::Motion;

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

/// A split list file: one error naming the file if it is empty or holds a name its layout cannot have.
fn read_list(path: &Path, layout: DataLayout) -> Result<Vec<String>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let names = parse_list(&text);
    if names.is_empty() {
        return Err(Error::at(path, "split file is empty"));
    }
    for n in &names {
        layout.check_name(n).map_err(|m| Error::at(path, m))?;
    }
    Ok(names)
}

/// An opened dataset directory.
#[derive(Debug, Clone)]
pub struct Dataset {
    pub root: PathBuf,
    pub layout: DataLayout,
    splits: BTreeMap<Split, (Vec<String>, ListSource)>,
    ignore: HashSet<String>,
    ignore_source: ListSource,
}

impl Dataset {
    /// Open `dir`, its layout told by what it holds (`DataLayout::detect`). Split lists are read now.
    pub fn open(dir: &Path) -> Result<Dataset> {
        let layout = DataLayout::detect(dir)?;
        Dataset::open_as(dir, layout)
    }

    /// Open `dir` as a dataset of `layout`, or of the layout it holds when `None`.
    pub fn open_with(dir: &Path, layout: Option<DataLayout>) -> Result<Dataset> {
        match layout {
            Some(layout) => Dataset::open_as(dir, layout),
            None => Dataset::open(dir),
        }
    }

    /// Open `dir` as a dataset of `layout`; its motions directory must exist.
    pub fn open_as(dir: &Path, layout: DataLayout) -> Result<Dataset> {
        let motions = layout.motions_dir(dir);
        if !motions.is_dir() {
            return Err(Error::at(
                dir,
                format!(
                    "not a {} dataset: no {} directory",
                    layout.name(),
                    motions.display()
                ),
            ));
        }
        let defaults = Dataset::default_lists(dir, layout)?;
        let listed: Vec<PathBuf> = Split::ALL
            .iter()
            .map(|s| layout.split_file(dir, *s))
            .collect();
        if layout != DataLayout::Aistpp && listed.iter().any(|p| p.exists()) {
            // A partial set of lists would mix the user's split with the embedded one.
            if let Some(missing) = listed.iter().find(|p| !p.exists()) {
                return Err(Error::at(
                    missing,
                    "split list missing: a FineDance or folder dataset lists all of train.txt, val.txt and test.txt under splits/, or none",
                ));
            }
        }
        let mut splits = BTreeMap::new();
        for (split, fallback) in Split::ALL.into_iter().zip(defaults.iter()) {
            let path = layout.split_file(dir, split);
            let entry = if path.exists() {
                (read_list(&path, layout)?, ListSource::File(path))
            } else {
                (fallback.clone(), ListSource::Embedded)
            };
            splits.insert(split, entry);
        }
        let ignore_path = dir.join("ignore_list.txt");
        let (ignore, ignore_source) = if ignore_path.exists() {
            let text =
                std::fs::read_to_string(&ignore_path).map_err(|e| Error::io(&ignore_path, e))?;
            (parse_list(&text), ListSource::File(ignore_path))
        } else {
            (defaults[3].clone(), ListSource::Embedded)
        };
        Ok(Dataset {
            root: dir.to_path_buf(),
            layout,
            splits,
            ignore: ignore.into_iter().collect(),
            ignore_source,
        })
    }

    /// The lists used where the directory has none: train, val, test and ignore.
    fn default_lists(dir: &Path, layout: DataLayout) -> Result<[Vec<String>; 4]> {
        Ok(match layout {
            DataLayout::Aistpp => [
                parse_list(Split::Train.embedded()),
                parse_list(Split::Val.embedded()),
                parse_list(Split::Test.embedded()),
                parse_list(EMBEDDED_IGNORE),
            ],
            DataLayout::FineDance => FineDanceSplit::Genre.lists(),
            DataLayout::Folder => {
                let [train, val, test] = folder_splits(&layout.list_motions(dir)?);
                [train, val, test, Vec::new()]
            }
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
        self.layout.motions_dir(&self.root)
    }

    pub fn motion_path(&self, name: &str) -> PathBuf {
        self.layout.motion_path(&self.root, name)
    }

    /// The motion of sequence `name` as the 60-fps SMPL motion every model takes, or one error naming its file.
    pub fn read_motion(&self, name: &str) -> Result<Motion> {
        self.layout.read_motion(&self.motion_path(name))
    }

    /// Where the music files are (`wav/`, `music_wav/`, or the folder itself).
    pub fn audio_dir(&self) -> PathBuf {
        self.layout.audio_dir(&self.root)
    }

    /// The audio file of a music ID, if present.
    pub fn audio_path(&self, music_id: &str) -> Option<PathBuf> {
        AUDIO_EXTENSIONS
            .iter()
            .map(|ext| self.audio_dir().join(format!("{music_id}.{ext}")))
            .find(|p| p.is_file())
    }

    /// The music a sequence dances to: AIST++'s music ID from its name; in the other layouts the music file
    /// has the dance's own name.
    pub fn music_id(&self, name: &str) -> Option<String> {
        match self.layout {
            DataLayout::Aistpp => music_id_of(name),
            DataLayout::FineDance | DataLayout::Folder => Some(name.to_string()),
        }
    }

    /// FineDance's genre label of a sequence (`style2` of `label_json/<name>.json`, e.g. "Breaking", "Dai";
    /// `None` where the file is absent or the layout has no labels), or an error naming a malformed file.
    pub fn genre_label(&self, name: &str) -> Result<Option<String>> {
        let path = self.root.join("label_json").join(format!("{name}.json"));
        if self.layout != DataLayout::FineDance || !path.is_file() {
            return Ok(None);
        }
        let text = std::fs::read_to_string(&path).map_err(|e| Error::io(&path, e))?;
        let value: serde_json::Value = serde_json::from_str(&text)
            .map_err(|e| Error::at(&path, format!("not a JSON label file: {e}")))?;
        match value.get("style2").and_then(|v| v.as_str()) {
            Some(label) => match crate::layout::finedance_genre(label) {
                Some(genre) => Ok(Some(genre.to_string())),
                None => Err(Error::at(
                    &path,
                    format!(
                        "unknown FineDance genre \"{label}\" (known: {})",
                        crate::layout::FINEDANCE_GENRES.join(", ")
                    ),
                )),
            },
            None => Err(Error::at(
                &path,
                "a FineDance label file needs a \"style2\" genre (beside \"name\" and \"style1\")",
            )),
        }
    }

    /// Every sequence's genre (present motions and listed names), for a genre run: a malformed or unknown
    /// FineDance label is an error naming its file; sequences without a genre are left out.
    /// The data's genre vocabulary with every sequence's genre, for a genre run (`what` names it in the error
    /// a folder of dances gets).
    pub fn genres(
        &self,
        what: &str,
    ) -> Result<(
        crate::layout::GenreSet,
        std::collections::HashMap<String, usize>,
    )> {
        let set = self.layout.genre_set().ok_or_else(|| {
            Error::at(
                &self.root,
                format!("a folder of dances has no genres: {what} trains on AIST++ or FineDance"),
            )
        })?;
        let mut names = self.all_sequences()?;
        Split::ALL.iter().for_each(|s| names.extend(self.split(*s)));
        let mut out = std::collections::HashMap::new();
        for n in names {
            if let Some(g) = self.try_genre(&n)? {
                out.insert(n, g);
            }
        }
        Ok((set, out))
    }

    /// The genre of a sequence as an index into its layout's [`crate::layout::GenreSet`]: AIST++'s from the
    /// name, FineDance's from its label file (`None` without a readable, known label; a folder has none).
    pub fn genre(&self, name: &str) -> Option<usize> {
        self.try_genre(name).ok().flatten()
    }

    /// [`Dataset::genre`], with a malformed or unknown FineDance label as the error naming its file.
    fn try_genre(&self, name: &str) -> Result<Option<usize>> {
        Ok(match self.layout {
            DataLayout::Aistpp => genre_of(name),
            DataLayout::FineDance => self
                .genre_label(name)?
                .and_then(|label| crate::layout::GenreSet::FineDance.index(&label)),
            DataLayout::Folder => None,
        })
    }

    /// The directory where cached 35-D music features live (`DIR/features/<music ID>.npy`).
    pub fn features_dir(&self) -> PathBuf {
        self.root.join("features")
    }

    /// Every motion file present (stems), sorted, ignored names removed: the GT reference set of SPEC §1.6.
    pub fn all_sequences(&self) -> Result<Vec<String>> {
        let mut names = self.layout.list_motions(&self.root)?;
        names.retain(|n| !self.ignore.contains(n));
        Ok(names)
    }

    /// Music IDs used by the given sequences, sorted and de-duplicated.
    pub fn music_ids<'a>(&self, names: impl IntoIterator<Item = &'a String>) -> Vec<String> {
        let mut ids: Vec<String> = names.into_iter().filter_map(|n| self.music_id(n)).collect();
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
            let music = self.music_ids(&usable);
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
            layout: self.layout,
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
    pub layout: DataLayout,
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
        let train_music: HashSet<String> =
            ds.music_ids(&ds.split(Split::Train)).into_iter().collect();
        let test_music = ds.music_ids(&ds.split(Split::Test));
        assert_eq!(test_music.len(), 10);
        assert!(test_music.iter().all(|m| !train_music.contains(m)));
        assert_eq!(ds.music_ids(&ds.split(Split::Val)), test_music);
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

    /// A FineDance directory: its layout detected, FineDance@Genre's lists when it has none, its own when it
    /// has all three, an error naming the file when one is missing; genre labels read or refused.
    #[test]
    fn finedance_directories() {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir(d.path().join("motion")).unwrap();
        let ds = Dataset::open(d.path()).unwrap();
        assert_eq!(ds.layout, DataLayout::FineDance);
        assert_eq!(ds.split(Split::Test).len(), 18);
        assert!(ds.split(Split::Train).contains(&"001".to_string()));
        assert_eq!(ds.music_id("063").as_deref(), Some("063"));
        assert_eq!(ds.motion_path("063"), d.path().join("motion/063.npy"));
        assert_eq!(ds.audio_dir(), d.path().join("music_wav"));
        assert_eq!(ds.genre("063"), None);
        std::fs::create_dir(d.path().join("splits")).unwrap();
        std::fs::write(d.path().join("splits/train.txt"), "001\n002\n").unwrap();
        let e = Dataset::open(d.path()).unwrap_err().to_string();
        assert!(
            e.contains("splits/val.txt") && e.contains("split list missing"),
            "{e}"
        );
        std::fs::write(d.path().join("splits/test.txt"), "003\n").unwrap();
        std::fs::write(d.path().join("splits/val.txt"), "3\n").unwrap();
        let e = Dataset::open(d.path()).unwrap_err().to_string();
        assert!(
            e.contains("val.txt") && e.contains("not a FineDance sequence ID"),
            "{e}"
        );
        std::fs::write(d.path().join("splits/val.txt"), "003\n").unwrap();
        let ds = Dataset::open(d.path()).unwrap();
        assert_eq!(
            ds.split(Split::Train),
            vec!["001".to_string(), "002".to_string()]
        );
        std::fs::create_dir(d.path().join("label_json")).unwrap();
        let label = |text: &str| {
            std::fs::write(d.path().join("label_json/001.json"), text).unwrap();
            ds.genre_label("001")
        };
        assert_eq!(
            label(r#"{"name": "x", "style1": "Folk", "style2": "Tai"}"#)
                .unwrap()
                .as_deref(),
            Some("Dai")
        );
        assert_eq!(ds.genre_label("002").unwrap(), None);
        let e = label(r#"{"name": "x", "style1": "Folk", "style2": "Polka"}"#)
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("001.json") && e.contains("unknown FineDance genre \"Polka\""),
            "{e}"
        );
        let e = label("{").unwrap_err().to_string();
        assert!(
            e.contains("001.json") && e.contains("not a JSON label file") && !e.contains('\n'),
            "{e}"
        );
    }
}
