//! What checkpoint mode (`qean eval --run R --data DIR`, SPEC §1.6; run by `qean-pipeline`) reports
//! and the parts of it that need no model: the protocol's pairings of motions with music, the
//! chance baselines, the motion-energy reference of a dataset, and `report.json`'s layout.

use std::collections::HashSet;
use std::path::{Path, PathBuf};

use qean_aistpp::dataset::Dataset;
use qean_aistpp::names::music_id_of;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::io::write_json_atomic;
use crate::motion_energy::EnergyReference;
use crate::positions::{Frame, Sequence, N_JOINTS};
use crate::report::MetricsReport;

/// Which motion is paired with which music.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum Protocol {
    /// Each test/val motion with its own music (Bailando, QEAN; the default).
    Paired,
    /// mint's: 10 draws of music per motion from the same set (seed 42), duplicates dropped.
    Unpaired,
}

/// Where each seed starts in its ground-truth motion (SPEC §1.6): frame 0 (mint), or uniformly at
/// random in `[0, T − seed_frames]` from a seeded generator, one draw per sequence in protocol order
/// (QEAN's "random motion seeds"). Written `zero`, `random` (seed 0) or `random:SEED`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SeedStart {
    #[default]
    Zero,
    Random(u64),
}

impl SeedStart {
    /// The start frame of each motion of these lengths (each at least `seed_frames` long).
    pub fn starts(self, lengths: &[usize], seed_frames: usize) -> Vec<usize> {
        match self {
            SeedStart::Zero => vec![0; lengths.len()],
            SeedStart::Random(seed) => {
                let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
                lengths
                    .iter()
                    .map(|&t| rng.random_range(0..=t.saturating_sub(seed_frames)))
                    .collect()
            }
        }
    }
}

impl std::fmt::Display for SeedStart {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            SeedStart::Zero => write!(f, "zero"),
            SeedStart::Random(seed) => write!(f, "random:{seed}"),
        }
    }
}

impl std::str::FromStr for SeedStart {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "zero" => Ok(SeedStart::Zero),
            "random" => Ok(SeedStart::Random(0)),
            _ => s
                .strip_prefix("random:")
                .and_then(|n| n.parse().ok())
                .map(SeedStart::Random)
                .ok_or_else(|| format!("{s:?}: expected zero, random or random:SEED")),
        }
    }
}

impl Serialize for SeedStart {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(&self.to_string())
    }
}

impl<'de> Deserialize<'de> for SeedStart {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        String::deserialize(d)?
            .parse()
            .map_err(serde::de::Error::custom)
    }
}

/// One generated sequence of the protocol.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Pairing {
    /// Output name; its 5th `_` field is the music ID (AIST++ naming), so BeatAlign finds the music.
    pub name: String,
    /// The ground-truth sequence giving the seed.
    pub motion: String,
    pub music_id: String,
    /// Frames generated after the seed.
    pub generated: usize,
    /// The seed's first frame in the ground-truth motion (and the music frame the dance starts at).
    #[serde(default)]
    pub seed_start: usize,
}

/// report.json of checkpoint mode.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunReport {
    pub checkpoint: PathBuf,
    pub step: u64,
    pub protocol: Protocol,
    pub frames: usize,
    /// Whether fed-back frames were projected to SO(3) while sampling.
    #[serde(default)]
    pub feedback_project: bool,
    /// Passes averaged per frame (temporal ensembling; 1 = token 0 only).
    #[serde(default = "one")]
    pub ensemble: usize,
    /// Frames over which the jump at the seed's end faded out (0 = off; reports written before
    /// the option existed were sampled without it).
    #[serde(default)]
    pub seam_frames: usize,
    /// Where the seeds started (`zero` for reports written before the option existed).
    #[serde(default)]
    pub seed_start: SeedStart,
    /// How a token model's dances were drawn (TSMT's decoding, temperature, top-k; the GPT's picking);
    /// `None` for FACT and QEAN, which are deterministic.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sampler: Option<String>,
    pub pairings: Vec<Pairing>,
    pub reports: Vec<MetricsReport>,
    /// With `--baselines`: the chance baselines, scored like the first report.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baselines: Option<Baselines>,
}

fn one() -> usize {
    1
}

/// Chance baselines of checkpoint mode (`--baselines`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Baselines {
    /// Every dance replaced by its seed's last frame, held: no motion at all.
    pub frozen: MetricsReport,
    /// The generated dances scored against other music IDs' beats: every rotation of the sorted
    /// music IDs that moves each dance to another song, its BeatAlign values averaged over those
    /// pairings (the expected score of a random mismatched pairing); `None` when all sequences share
    /// one music ID.
    pub random_pairing: Option<MetricsReport>,
}

/// The frozen baseline: seed frames, then the last seed frame held for the rest of each sequence.
pub fn frozen_dances(generated: &[Sequence], seed_frames: usize) -> Vec<Sequence> {
    generated
        .iter()
        .map(|s| {
            let keep = seed_frames.min(s.joints.len());
            let mut joints = s.joints[..keep].to_vec();
            if let Some(&last) = joints.last() {
                joints.resize(s.joints.len(), last);
            }
            Sequence {
                name: s.name.clone(),
                joints,
                music: s.music.clone(),
                music_offset: s.music_offset,
            }
        })
        .collect()
}

/// One random-pairing set: each dance's music ([`crate::protocol::music_key`]) replaced by the distinct
/// music `shift` places later in sorted order (1 ≤ shift < number of musics), so no dance keeps its own
/// music; an AIST++ name's music field (the 5th) is renamed with it, another name gets `@MUSIC`.
/// `None` with fewer than two musics or a shift outside that range.
pub fn repaired_dances(generated: &[Sequence], shift: usize) -> Option<Vec<Sequence>> {
    let mut ids: Vec<String> = generated
        .iter()
        .filter_map(crate::protocol::music_key)
        .collect();
    ids.sort();
    ids.dedup();
    if ids.len() < 2 || shift == 0 || shift >= ids.len() {
        return None;
    }
    let out = generated
        .iter()
        .map(|s| {
            let own = crate::protocol::music_key(s);
            let other = own
                .as_ref()
                .and_then(|m| ids.iter().position(|x| x == m))
                .map(|pos| ids[(pos + shift) % ids.len()].clone());
            let name = match (&other, music_id_of(&s.name)) {
                (Some(o), Some(_)) => {
                    let mut fields: Vec<String> = s.name.split('_').map(str::to_string).collect();
                    fields[4] = o.clone();
                    fields.join("_")
                }
                (Some(o), None) => format!("{}@{o}", s.name),
                (None, _) => s.name.clone(),
            };
            Sequence {
                name,
                joints: s.joints.clone(),
                music: other.or(own),
                music_offset: s.music_offset,
            }
        })
        .collect();
    Some(out)
}

/// The first report with every BeatAlign value replaced by its mean over `reports` (the motions,
/// hence every other metric, are the same in each). `None` for no reports.
pub fn average_beat_align(reports: Vec<MetricsReport>) -> Option<MetricsReport> {
    let mean = |get: fn(&MetricsReport) -> Option<f64>| -> Option<f64> {
        let v: Vec<f64> = reports.iter().filter_map(get).collect();
        (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
    };
    let beat_align = mean(|r| r.beat_align);
    let bailando = mean(|r| r.beat_align_bailando);
    let mint = mean(|r| r.beat_align_mint);
    let n = reports.len();
    let mut first = reports.into_iter().next()?;
    first.beat_align = beat_align;
    first.beat_align_bailando = bailando;
    first.beat_align_mint = mint;
    first.label = format!("{} (mean of {n} pairings)", first.label);
    Some(first)
}

/// The (motion, music, name) pairs of a protocol over the test + val sequences; `music_of` is the
/// dataset's music of a sequence (`Dataset::music_id`).
pub fn pairings(
    names: &[String],
    protocol: Protocol,
    music_of: impl Fn(&str) -> Option<String>,
) -> Vec<(String, String, String)> {
    match protocol {
        Protocol::Paired => names
            .iter()
            .filter_map(|n| music_of(n).map(|m| (n.clone(), m, n.clone())))
            .collect(),
        Protocol::Unpaired => {
            let musics: Vec<String> = names.iter().filter_map(|n| music_of(n)).collect();
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
            let mut seen = HashSet::new();
            let mut out = Vec::new();
            for n in names {
                for _ in 0..10 {
                    let m = musics[rng.random_range(0..musics.len())].clone();
                    if seen.insert((n.clone(), m.clone())) {
                        // The music field replaced, the source motion's music kept as a suffix.
                        let fields: Vec<&str> = n.split('_').collect();
                        let name = if fields.len() >= 6 {
                            let mut f: Vec<String> = fields.iter().map(|s| s.to_string()).collect();
                            let own = f[4].clone();
                            f[4] = m.clone();
                            format!("{}_from-{own}", f.join("_"))
                        } else {
                            format!("{n}_{m}")
                        };
                        out.push((n.clone(), m, name));
                    }
                }
            }
            out
        }
    }
}

/// The motion-energy statistics of a dataset's reference set: every non-ignored sequence, full
/// length, as the metrics' reference set (SPEC §1.6).
pub fn dataset_energy_reference(
    data: &Path,
    root: qean_motion::FkRoot,
) -> crate::Result<EnergyReference> {
    let ds = Dataset::open(data)?;
    let mut sequences = Vec::new();
    for name in ds.all_sequences()? {
        let m = ds.read_motion(&name)?;
        sequences.push(frames_of(m.joints(root)));
    }
    if sequences.is_empty() {
        return Err(crate::Error::file(
            data,
            "no motions to take the reference speed from",
        ));
    }
    Ok(EnergyReference::fit(sequences.iter().map(Vec::as_slice)))
}

/// The reference of [`dataset_energy_reference`], cached in `cache` (a JSON file naming the
/// dataset; recomputed when it names another or cannot be read or written).
pub fn cached_energy_reference(data: &Path, cache: &Path) -> crate::Result<EnergyReference> {
    #[derive(Serialize, Deserialize)]
    struct Cached {
        data: PathBuf,
        reference: EnergyReference,
    }
    let data_abs = std::fs::canonicalize(data).unwrap_or_else(|_| data.to_path_buf());
    if let Some(c) = std::fs::read_to_string(cache)
        .ok()
        .and_then(|t| serde_json::from_str::<Cached>(&t).ok())
        .filter(|c| c.data == data_abs)
    {
        return Ok(c.reference);
    }
    let reference = dataset_energy_reference(data, qean_motion::FkRoot::Smpl)?;
    let _ = write_json_atomic(
        cache,
        &Cached {
            data: data_abs,
            reference,
        },
    );
    Ok(reference)
}

/// Joint positions (frames × 24 points) as metric frames.
pub fn frames_of(points: Vec<[f64; 3]>) -> Vec<Frame> {
    points
        .chunks_exact(N_JOINTS)
        .map(|c| {
            let mut f = [[0.0; 3]; N_JOINTS];
            f.copy_from_slice(c);
            f
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seq(name: &str, frames: usize) -> Sequence {
        let joints = (0..frames)
            .map(|t| [[t as f64, 0.0, 0.0]; N_JOINTS])
            .collect();
        Sequence {
            name: name.to_string(),
            joints,
            music: None,
            music_offset: 0,
        }
    }

    #[test]
    fn frozen_dances_hold_the_last_seed_frame() {
        let g = vec![seq("gBR_sBM_cAll_d04_mBR0_ch02", 10)];
        let f = frozen_dances(&g, 4);
        assert_eq!(f[0].joints.len(), 10);
        assert_eq!(f[0].name, g[0].name);
        for t in 0..4 {
            assert_eq!(f[0].joints[t], g[0].joints[t]);
        }
        for t in 4..10 {
            assert_eq!(f[0].joints[t], g[0].joints[3]);
        }
    }

    #[test]
    fn repairing_gives_every_dance_another_music_id() {
        let g = vec![
            seq("gBR_sBM_cAll_d04_mBR0_ch02", 3),
            seq("gPO_sBM_cAll_d10_mPO1_ch02", 3),
            seq("gLO_sBM_cAll_d13_mLO2_ch02", 3),
            seq("gBR_sBM_cAll_d05_mBR0_ch01", 3),
        ];
        let r = repaired_dances(&g, 1).unwrap();
        let ids: Vec<String> = r.iter().map(|s| music_id_of(&s.name).unwrap()).collect();
        assert_eq!(ids, ["mLO2", "mBR0", "mPO1", "mLO2"]);
        let r2 = repaired_dances(&g, 2).unwrap();
        let ids2: Vec<String> = r2.iter().map(|s| music_id_of(&s.name).unwrap()).collect();
        assert_eq!(ids2, ["mPO1", "mLO2", "mBR0", "mPO1"]);
        for (a, b) in g.iter().zip(r.iter().chain(&r2)) {
            assert_ne!(music_id_of(&a.name), music_id_of(&b.name));
            assert_eq!(a.joints, b.joints);
        }
        // Three music IDs: shifts 1 and 2 only.
        assert!(repaired_dances(&g, 3).is_none());
        assert!(repaired_dances(&g, 0).is_none());
        assert!(repaired_dances(&g[..1], 1).is_none());
    }

    #[test]
    fn seed_starts_are_zero_or_seeded_draws_inside_each_motion() {
        assert_eq!(SeedStart::Zero.starts(&[500, 130], 120), vec![0, 0]);
        let r = SeedStart::Random(7);
        let a = r.starts(&[500, 130, 120, 1000], 120);
        assert_eq!(a, r.starts(&[500, 130, 120, 1000], 120), "deterministic");
        assert!(
            a[0] <= 380 && a[1] <= 10 && a[2] == 0 && a[3] <= 880,
            "{a:?}"
        );
        assert_ne!(a, SeedStart::Random(8).starts(&[500, 130, 120, 1000], 120));
        for s in ["zero", "random", "random:42"] {
            assert_eq!(
                s.parse::<SeedStart>()
                    .unwrap()
                    .to_string()
                    .split(':')
                    .next(),
                s.split(':').next()
            );
        }
        assert_eq!("random".parse::<SeedStart>(), Ok(SeedStart::Random(0)));
        assert!("random:x"
            .parse::<SeedStart>()
            .unwrap_err()
            .contains("random:SEED"));
        let json = serde_json::to_string(&SeedStart::Random(3)).unwrap();
        assert_eq!(
            serde_json::from_str::<SeedStart>(&json).unwrap(),
            SeedStart::Random(3)
        );
    }
}
