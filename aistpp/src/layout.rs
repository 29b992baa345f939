//! Where a dataset directory keeps its motions, music and split lists: AIST++'s layout, FineDance's, or a
//! plain folder of a user's own dances. Every reader past [`crate::dataset::Dataset`] sees the same thing
//! (names, 60-fps SMPL motions, music files), whatever the layout.
//!
//! ```text
//! aistpp     DIR/motions/<name>.pkl     DIR/wav/<music ID>.wav       DIR/splits/crossmodal_<split>.txt
//! finedance  DIR/motion/<NNN>.npy       DIR/music_wav/<NNN>.wav      DIR/splits/<split>.txt, DIR/label_json/
//! folder     DIR/<name>.pkl|.npy        DIR/<name>.wav               DIR/splits/<split>.txt
//! ```
//!
//! Music may be `.wav`, `.ogg`, `.mp3` or `.flac` in every layout. Missing split lists fall back to
//! AIST++'s official lists, FineDance@Genre's, or (folder) a fixed hold-out of every tenth name.

use std::path::{Path, PathBuf};

use crate::dataset::Split;
use crate::names::SequenceName;
use qean_io::error::{Error, Result};
use qean_motion::fk::FkRoot;
use qean_motion::ik::{motion_from_joints, IkMode};
use qean_motion::motion::Layout;
use qean_motion::skeleton::NUM_JOINTS;
use qean_motion::Motion;

/// FineDance's sequence IDs run 001–211 (the release's `motion/` names).
pub const FINEDANCE_IDS: std::ops::RangeInclusive<u32> = 1..=211;

const GENRE_TEST: &str = include_str!("../assets/finedance/genre_test.txt");
const GENRE_IGNORE: &str = include_str!("../assets/finedance/genre_ignore.txt");
const DANCER_TEST: &str = include_str!("../assets/finedance/dancer_test.txt");
const DANCER_VAL: &str = include_str!("../assets/finedance/dancer_val.txt");
const DANCER_IGNORE: &str = include_str!("../assets/finedance/dancer_ignore.txt");

/// A dataset directory's layout.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataLayout {
    /// AIST++ (SPEC §1.3): pickles of SMPL poses at 60 fps, music named by ID, the crossmodal splits.
    Aistpp,
    /// FineDance (Li et al., ICCV 2023): [T, 315] 6-D rotations at 30 fps, read as 60-fps SMPL
    /// (`qean_motion::finedance`), a wav per dance, genre labels in `label_json/`.
    FineDance,
    /// A user's own dances: `.pkl` (AIST++'s pickle) or `.npy` ((frames, 24, 3) joint positions in metres at
    /// 60 fps, solved to rotations by `qean_motion::ik`; (frames, 225 | 219) model vectors; (frames, 315)
    /// FineDance rows), each with the music file of the same name.
    Folder,
}

/// FineDance's fine-grained genres (`style2` of `label_json/NNN.json`) as the released labels name them: 16,
/// not the paper's 22 (FineDance issue #8).
pub const FINEDANCE_GENRES: [&str; 16] = [
    "Breaking",
    "Popping",
    "Locking",
    "Hiphop",
    "Urban",
    "Jazz",
    "Dai",
    "Wei",
    "Miao",
    "HanTang",
    "ShenYun",
    "Kun",
    "DunHuang",
    "Korean",
    "Choreography",
    "Chinese",
];

/// Other spellings of those genres in the labels and in Lodge's table (`jazz`; `Tai`, `Uighur`, `Hmong`).
const FINEDANCE_ALIASES: [(&str, &str); 4] = [
    ("jazz", "Jazz"),
    ("Tai", "Dai"),
    ("Uighur", "Wei"),
    ("Hmong", "Miao"),
];

/// The FineDance genre a label names, as its canonical spelling.
pub fn finedance_genre(label: &str) -> Option<&'static str> {
    let label = label.trim();
    FINEDANCE_GENRES
        .iter()
        .copied()
        .find(|g| *g == label)
        .or_else(|| {
            FINEDANCE_ALIASES
                .iter()
                .find(|(a, _)| *a == label)
                .map(|(_, g)| *g)
        })
}

/// A dataset's genre vocabulary: what a genre index means to the classifier that judges dances.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "lowercase")]
pub enum GenreSet {
    /// AIST++'s ten, by their codes (BR, PO, …, JB).
    #[default]
    Aistpp,
    /// FineDance's sixteen labels ([`FINEDANCE_GENRES`]).
    FineDance,
}

impl GenreSet {
    pub fn names(self) -> &'static [&'static str] {
        match self {
            GenreSet::Aistpp => &crate::names::GENRES,
            GenreSet::FineDance => &FINEDANCE_GENRES,
        }
    }

    pub fn count(self) -> usize {
        self.names().len()
    }

    /// The index of a genre named as the vocabulary spells it (AIST++: a code such as `KR`; FineDance: a label
    /// or one of its aliases), ignoring case.
    pub fn index(self, name: &str) -> Option<usize> {
        let name = match self {
            GenreSet::Aistpp => name.trim(),
            GenreSet::FineDance => finedance_genre(name).or_else(|| {
                FINEDANCE_GENRES
                    .iter()
                    .copied()
                    .find(|g| g.eq_ignore_ascii_case(name.trim()))
            })?,
        };
        self.names()
            .iter()
            .position(|g| g.eq_ignore_ascii_case(name))
    }
}

/// Which of FineDance's two published splits embedded lists stand for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FineDanceSplit {
    /// FineDance@Genre (`cross_genre`): the split its paper and Lodge report.
    Genre,
    /// FineDance@Dancer (`cross_dancer`): no dancer in two splits.
    Dancer,
}

impl FineDanceSplit {
    /// The split's lists as IDs: (train, val, test, ignore). Train is every ID in no other list; @Genre
    /// has no validation list, so its test list stands in for it (a monitor: no checkpoint is chosen by it).
    pub fn lists(self) -> [Vec<String>; 4] {
        let parse = crate::dataset::parse_list;
        let (test, val, ignore) = match self {
            FineDanceSplit::Genre => (parse(GENRE_TEST), parse(GENRE_TEST), parse(GENRE_IGNORE)),
            FineDanceSplit::Dancer => (parse(DANCER_TEST), parse(DANCER_VAL), parse(DANCER_IGNORE)),
        };
        let train = FINEDANCE_IDS
            .map(|i| format!("{i:03}"))
            .filter(|n| !test.contains(n) && !val.contains(n) && !ignore.contains(n))
            .collect();
        [train, val, test, ignore]
    }
}

/// Motion file extensions of a folder dataset, in the order a name's file is looked for.
const FOLDER_MOTIONS: [&str; 2] = ["pkl", "npy"];

impl DataLayout {
    pub const ALL: [DataLayout; 3] = [
        DataLayout::Aistpp,
        DataLayout::FineDance,
        DataLayout::Folder,
    ];

    pub fn name(self) -> &'static str {
        match self {
            DataLayout::Aistpp => "aistpp",
            DataLayout::FineDance => "finedance",
            DataLayout::Folder => "folder",
        }
    }

    /// The genre vocabulary of its data (a folder's dances have none).
    pub fn genre_set(self) -> Option<GenreSet> {
        match self {
            DataLayout::Aistpp => Some(GenreSet::Aistpp),
            DataLayout::FineDance => Some(GenreSet::FineDance),
            DataLayout::Folder => None,
        }
    }

    /// The name of its data in tables: the ground-truth row of a report.
    pub fn title(self) -> &'static str {
        match self {
            DataLayout::Aistpp => "AIST++",
            DataLayout::FineDance => "FineDance",
            DataLayout::Folder => "ground truth",
        }
    }

    /// The layout of `dir` by what it holds: `motions/` is AIST++, `motion/` FineDance, motion files at the
    /// top a folder dataset. An error names the directory and what each layout needs.
    pub fn detect(dir: &Path) -> Result<DataLayout> {
        if !dir.exists() {
            return Err(Error::at(dir, "dataset directory does not exist"));
        }
        if !dir.is_dir() {
            return Err(Error::at(dir, "is not a directory (expected a dataset)"));
        }
        if dir.join("motions").is_dir() {
            return Ok(DataLayout::Aistpp);
        }
        if dir.join("motion").is_dir() {
            return Ok(DataLayout::FineDance);
        }
        if !DataLayout::Folder.list_motions(dir)?.is_empty() {
            return Ok(DataLayout::Folder);
        }
        Err(Error::at(
            dir,
            "not a dataset: no motions/ (AIST++: motions/*.pkl, wav/), no motion/ (FineDance: motion/*.npy, \
             music_wav/) and no .pkl or .npy motion files (a folder of dances, each with its music)",
        ))
    }

    pub fn motions_dir(self, root: &Path) -> PathBuf {
        match self {
            DataLayout::Aistpp => root.join("motions"),
            DataLayout::FineDance => root.join("motion"),
            DataLayout::Folder => root.to_path_buf(),
        }
    }

    pub fn audio_dir(self, root: &Path) -> PathBuf {
        match self {
            DataLayout::Aistpp => root.join("wav"),
            DataLayout::FineDance => root.join("music_wav"),
            DataLayout::Folder => root.to_path_buf(),
        }
    }

    /// The motion file of `name` (for a folder, the first of `.pkl`, `.npy` that exists, else the `.pkl`).
    pub fn motion_path(self, root: &Path, name: &str) -> PathBuf {
        let dir = self.motions_dir(root);
        match self {
            DataLayout::Aistpp => dir.join(format!("{name}.pkl")),
            DataLayout::FineDance => dir.join(format!("{name}.npy")),
            DataLayout::Folder => FOLDER_MOTIONS
                .iter()
                .map(|ext| dir.join(format!("{name}.{ext}")))
                .find(|p| p.is_file())
                .unwrap_or_else(|| dir.join(format!("{name}.pkl"))),
        }
    }

    /// The stems of every motion file present, sorted and de-duplicated.
    pub fn list_motions(self, root: &Path) -> Result<Vec<String>> {
        let dir = self.motions_dir(root);
        let wanted: &[&str] = match self {
            DataLayout::Aistpp => &["pkl"],
            DataLayout::FineDance => &["npy"],
            DataLayout::Folder => &FOLDER_MOTIONS,
        };
        let mut names = Vec::new();
        for entry in std::fs::read_dir(&dir).map_err(|e| Error::io(&dir, e))? {
            let path = entry.map_err(|e| Error::io(&dir, e))?.path();
            let ext = qean_io::fsutil::extension_lower(&path);
            if path.is_file() && wanted.contains(&ext.as_str()) {
                if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
                    names.push(stem.to_string());
                }
            }
        }
        names.sort();
        names.dedup();
        Ok(names)
    }

    /// Read a motion file of this layout as the 60-fps SMPL motion the models take.
    pub fn read_motion(self, path: &Path) -> Result<Motion> {
        match self {
            DataLayout::Aistpp => Motion::read_pkl(path),
            DataLayout::FineDance => crate::finedance::read_motion(path),
            DataLayout::Folder => read_folder_motion(path),
        }
    }

    /// The split list file of `split` under `root`.
    pub fn split_file(self, root: &Path, split: Split) -> PathBuf {
        let file = match self {
            DataLayout::Aistpp => split.file_name(),
            DataLayout::FineDance | DataLayout::Folder => format!("{}.txt", split.name()),
        };
        root.join("splits").join(file)
    }

    /// Whether `name` may stand in a split list of this layout.
    pub fn check_name(self, name: &str) -> std::result::Result<(), String> {
        match self {
            DataLayout::Aistpp => SequenceName::parse(name).map(|_| ()).map_err(|e| e.message),
            DataLayout::FineDance => match name.parse::<u32>() {
                Ok(i) if name.len() == 3 && FINEDANCE_IDS.contains(&i) => Ok(()),
                _ => Err(format!(
                    "'{name}' is not a FineDance sequence ID (expected 001–211)"
                )),
            },
            DataLayout::Folder if name.contains(['/', '\\']) => Err(format!(
                "'{name}' is not a file name (it holds a path separator)"
            )),
            DataLayout::Folder => Ok(()),
        }
    }
}

impl std::str::FromStr for DataLayout {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        DataLayout::ALL
            .into_iter()
            .find(|l| l.name() == s)
            .ok_or_else(|| {
                format!("unknown dataset layout '{s}' (expected aistpp, finedance or folder)")
            })
    }
}

/// A folder dataset's motion file: an AIST++ pickle, or a `.npy` of joint positions, model vectors or
/// FineDance rows, told apart by its shape.
fn read_folder_motion(path: &Path) -> Result<Motion> {
    if qean_io::fsutil::extension_lower(path) != "npy" {
        return Motion::read_pkl(path);
    }
    let a = qean_io::npy::read(path)?;
    match a.shape[..] {
        [_, j, 3] if j == NUM_JOINTS => {
            let joints: Vec<[f64; 3]> = a.data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            qean_motion::joints_file::check_joints(path, &joints)?;
            Ok(motion_from_joints(&joints, IkMode::Hinge, FkRoot::Smpl))
        }
        [_, w] if w == qean_motion::finedance::WIDTH => crate::finedance::read_motion(path),
        [_, d] if Layout::from_dim(d).is_some() => qean_motion::motion::read_motion(path),
        _ => Err(Error::at(
            path,
            format!(
                "array of shape {:?} is not a dance (expected (frames, 24, 3) joint positions, (frames, 225 | 219) \
                 model vectors or (frames, 315) FineDance rows)",
                a.shape
            ),
        )),
    }
}

/// A folder dataset without split lists: names sorted, every tenth (the 10th, 20th, …; the last one when
/// there are fewer than ten) held out as test and val, the rest train.
pub fn folder_splits(names: &[String]) -> [Vec<String>; 3] {
    let held = |i: usize| {
        if names.len() < 10 {
            i + 1 == names.len()
        } else {
            i % 10 == 9
        }
    };
    let (mut train, mut test) = (Vec::new(), Vec::new());
    for (i, n) in names.iter().enumerate() {
        if held(i) { &mut test } else { &mut train }.push(n.clone());
    }
    [train, test.clone(), test]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finedance_lists_as_the_authors_loader_has_them() {
        let [train, val, test, ignore] = FineDanceSplit::Genre.lists();
        assert_eq!(test.len(), 20);
        assert_eq!(val, test);
        assert_eq!(ignore.len(), 10);
        // 211 IDs less the 20 test IDs and the 8 ignored ones not among them.
        assert_eq!(train.len(), 211 - 20 - 8);
        assert!(train
            .iter()
            .all(|n| !test.contains(n) && !ignore.contains(n)));
        let [train, val, test, ignore] = FineDanceSplit::Dancer.lists();
        assert_eq!((test.len(), val.len(), ignore.len()), (18, 12, 7));
        // 130 is in test and ignore: 36 IDs out of training.
        assert_eq!(train.len(), 211 - 18 - 12 - 6);
        for n in test.iter().chain(&val).chain(&ignore) {
            assert!(DataLayout::FineDance.check_name(n).is_ok(), "{n}");
        }
    }

    #[test]
    fn genre_vocabularies() {
        assert_eq!(GenreSet::Aistpp.count(), 10);
        assert_eq!(GenreSet::FineDance.count(), 16);
        assert_eq!(GenreSet::Aistpp.index("kr"), Some(7));
        assert_eq!(GenreSet::FineDance.index("breaking"), Some(0));
        assert_eq!(
            GenreSet::FineDance.index("Tai"),
            GenreSet::FineDance.index("Dai")
        );
        assert_eq!(GenreSet::FineDance.index("KR"), None);
        assert_eq!(DataLayout::Folder.genre_set(), None);
    }

    #[test]
    fn names_each_layout_accepts() {
        assert!(DataLayout::FineDance.check_name("007").is_ok());
        for bad in ["7", "000", "212", "abc"] {
            assert!(DataLayout::FineDance.check_name(bad).is_err(), "{bad}");
        }
        assert!(DataLayout::Aistpp
            .check_name("gBR_sBM_cAll_d04_mBR0_ch02")
            .is_ok());
        assert!(DataLayout::Aistpp.check_name("001").is_err());
        assert!(DataLayout::Folder.check_name("my dance").is_ok());
        assert!(DataLayout::Folder.check_name("a/b").is_err());
        assert_eq!("finedance".parse::<DataLayout>(), Ok(DataLayout::FineDance));
        assert!("bvh"
            .parse::<DataLayout>()
            .unwrap_err()
            .contains("aistpp, finedance or folder"));
    }

    #[test]
    fn folder_hold_out() {
        let names: Vec<String> = (0..25).map(|i| format!("d{i:02}")).collect();
        let [train, val, test] = folder_splits(&names);
        assert_eq!(test, vec!["d09".to_string(), "d19".to_string()]);
        assert_eq!(val, test);
        assert_eq!(train.len(), 23);
        let [train, _, test] = folder_splits(&names[..3]);
        assert_eq!((train.len(), test), (2, vec!["d02".to_string()]));
    }

    #[test]
    fn detection_by_contents() {
        let d = tempfile::tempdir().unwrap();
        let e = DataLayout::detect(d.path()).unwrap_err().to_string();
        assert!(e.contains("not a dataset") && !e.contains('\n'), "{e}");
        std::fs::write(d.path().join("a.npy"), b"x").unwrap();
        assert_eq!(DataLayout::detect(d.path()).unwrap(), DataLayout::Folder);
        std::fs::create_dir(d.path().join("motion")).unwrap();
        assert_eq!(DataLayout::detect(d.path()).unwrap(), DataLayout::FineDance);
        std::fs::create_dir(d.path().join("motions")).unwrap();
        assert_eq!(DataLayout::detect(d.path()).unwrap(), DataLayout::Aistpp);
        let e = DataLayout::detect(&d.path().join("nope"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("does not exist"), "{e}");
    }

    /// A folder's (frames, 24, 3) joints are solved to rotations whose joints come back; a NaN names its frame.
    #[test]
    fn folder_joint_positions_read_as_a_motion() {
        let d = tempfile::tempdir().unwrap();
        let truth = Motion::standing(4, FkRoot::Smpl).joints(FkRoot::Smpl);
        let mut flat: Vec<f64> = truth.iter().flatten().copied().collect();
        let path = d.path().join("mine.npy");
        qean_io::npy::write_f64(&path, &[4, 24, 3], &flat).unwrap();
        let m = DataLayout::Folder.read_motion(&path).unwrap();
        assert_eq!(m.frames, 4);
        for (a, b) in m.joints(FkRoot::Smpl).iter().zip(&truth) {
            for k in 0..3 {
                assert!((a[k] - b[k]).abs() < 1e-6);
            }
        }
        flat[2 * 72 + 5] = f64::NAN;
        qean_io::npy::write_f64(&path, &[4, 24, 3], &flat).unwrap();
        let e = DataLayout::Folder
            .read_motion(&path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("mine.npy") && e.contains("frame 2"), "{e}");
        qean_io::npy::write_f64(&path, &[4, 7], &[0.0; 28]).unwrap();
        let e = DataLayout::Folder
            .read_motion(&path)
            .unwrap_err()
            .to_string();
        assert!(e.contains("[4, 7]") && e.contains("joint positions"), "{e}");
    }
}
