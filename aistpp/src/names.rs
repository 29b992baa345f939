//! AIST++ sequence and music names (SPEC §1.1).
//!
//! A sequence name looks like `gBR_sBM_cAll_d04_mBR0_ch02`: genre, situation (sBM basic / sFM advanced),
//! camera, dancer, music ID, choreography. The music ID is the second-to-last `_` field.

use qean_io::error::{Error, Result};

/// The ten AIST++ genres, in the order the dataset lists them.
pub const GENRES: [&str; 10] = ["BR", "PO", "LO", "MH", "LH", "HO", "WA", "KR", "JS", "JB"];

/// The parsed fields of an AIST++ sequence name.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SequenceName {
    pub genre: String,
    /// `sBM` (basic) or `sFM` (advanced).
    pub situation: String,
    pub camera: String,
    pub dancer: u32,
    pub music_id: String,
    pub choreo: u32,
}

impl SequenceName {
    /// Parse a name such as `gBR_sBM_cAll_d04_mBR0_ch02` (a trailing extension is ignored).
    pub fn parse(name: &str) -> Result<Self> {
        let stem = name.split('.').next().unwrap_or(name);
        let fields: Vec<&str> = stem.split('_').collect();
        let bad = |why: &str| {
            Error::msg(format!(
                "'{name}' is not an AIST++ sequence name ({why}; expected e.g. gBR_sBM_cAll_d04_mBR0_ch02)"
            ))
        };
        if fields.len() != 6 {
            return Err(bad("it needs six '_'-separated fields"));
        }
        let genre = fields[0]
            .strip_prefix('g')
            .ok_or_else(|| bad("the genre field must start with 'g'"))?;
        if !GENRES.contains(&genre) {
            return Err(bad("unknown genre"));
        }
        if fields[1] != "sBM" && fields[1] != "sFM" {
            return Err(bad("the situation field must be sBM or sFM"));
        }
        let dancer = fields[3]
            .strip_prefix('d')
            .and_then(|d| d.parse().ok())
            .ok_or_else(|| bad("the dancer field must be dNN"))?;
        let music_id = fields[4].to_string();
        tempo_prior(&music_id).ok_or_else(|| bad("the music field must be m<genre><0-5>"))?;
        let choreo = fields[5]
            .strip_prefix("ch")
            .and_then(|d| d.parse().ok())
            .ok_or_else(|| bad("the choreography field must be chNN"))?;
        Ok(SequenceName {
            genre: genre.to_string(),
            situation: fields[1].to_string(),
            camera: fields[2].to_string(),
            dancer,
            music_id,
            choreo,
        })
    }

    /// Tempo prior (BPM) of this sequence's music.
    pub fn tempo(&self) -> f64 {
        tempo_prior(&self.music_id).expect("validated in parse")
    }
}

/// The music ID of a file or sequence name: the second-to-last `_` field of an AIST++ sequence name,
/// or the name itself when it already is a music ID such as `mBR0`.
pub fn music_id_of(name: &str) -> Option<String> {
    let stem = name.split('.').next().unwrap_or(name);
    if tempo_prior(stem).is_some() {
        return Some(stem.to_string());
    }
    let fields: Vec<&str> = stem.split('_').collect();
    if fields.len() >= 2 {
        let m = fields[fields.len() - 2];
        if tempo_prior(m).is_some() {
            return Some(m.to_string());
        }
    }
    None
}

/// The beat tracker's tempo prior for an AIST++ name (music ID or sequence name): [`tempo_prior`] of its
/// music ID, else 120 BPM (librosa's default).
pub fn start_bpm(name: &str) -> f64 {
    music_id_of(name)
        .and_then(|m| tempo_prior(&m))
        .unwrap_or(120.0)
}

/// Tempo prior in BPM of an AIST++ music ID `m<GG><k>`: 80 + 10k, except house (HO): 110 + 5k
/// (mint `tools/preprocessing.py`). `None` for names that are not AIST++ music IDs.
pub fn tempo_prior(music_id: &str) -> Option<f64> {
    let rest = music_id.strip_prefix('m')?;
    if rest.len() != 3 {
        return None;
    }
    let (genre, k) = rest.split_at(2);
    if !GENRES.contains(&genre) {
        return None;
    }
    let k: u32 = k.parse().ok().filter(|k| *k <= 5)?;
    Some(if genre == "HO" {
        110.0 + 5.0 * k as f64
    } else {
        80.0 + 10.0 * k as f64
    })
}

/// The genre index of an AIST++ name (`gBR_…` → 0), if it has one.
pub fn genre_of(name: &str) -> Option<usize> {
    genre_index(name.strip_prefix('g')?)
}

/// The genre whose two-letter AIST++ code starts `code` (`BR…` → 0).
pub fn genre_index(code: &str) -> Option<usize> {
    let code = code.get(..2)?;
    GENRES.iter().position(|g| *g == code)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn genre_codes_in_order() {
        assert_eq!(genre_of("gBR_sBM_cAll_d04_mBR0_ch01"), Some(0));
        assert_eq!(genre_of("gJB_sFM_cAll_d09_mJB5_ch10"), Some(9));
        assert_eq!(genre_of("gKR_x"), Some(7));
        assert_eq!(genre_of("softcat"), None);
        assert_eq!(genre_index("KR"), Some(7));
    }

    #[test]
    fn start_bpm_from_names() {
        assert_eq!(start_bpm("mBR0"), 80.0);
        assert_eq!(start_bpm("gHO_sBM_cAll_d19_mHO5_ch02"), 135.0);
        assert_eq!(start_bpm("Vibe_Ace"), 120.0);
    }

    #[test]
    fn tempo_from_name() {
        assert_eq!(tempo_prior("mBR0"), Some(80.0));
        assert_eq!(tempo_prior("mHO5"), Some(135.0));
        assert_eq!(tempo_prior("mJB5"), Some(130.0));
        assert_eq!(tempo_prior("mXX0"), None);
        assert_eq!(tempo_prior("mBR6"), None);
    }

    #[test]
    fn parse_sequence_name() {
        let n = SequenceName::parse("gBR_sBM_cAll_d04_mBR0_ch02").unwrap();
        assert_eq!(n.genre, "BR");
        assert_eq!(n.dancer, 4);
        assert_eq!(n.music_id, "mBR0");
        assert_eq!(n.choreo, 2);
        assert_eq!(n.tempo(), 80.0);
        assert!(SequenceName::parse("gBR_sBM_cAll_d04_mBR0").is_err());
        assert!(SequenceName::parse("gZZ_sBM_cAll_d04_mBR0_ch02").is_err());
    }

    #[test]
    fn music_ids() {
        assert_eq!(
            music_id_of("gBR_sBM_cAll_d04_mBR0_ch02.pkl").as_deref(),
            Some("mBR0")
        );
        assert_eq!(music_id_of("mHO3.wav").as_deref(), Some("mHO3"));
        assert_eq!(music_id_of("Kevin_MacLeod_-_Vibe_Ace"), None);
    }
}
