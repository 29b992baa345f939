//! Procedural music for the synthetic dataset: a drum/bass/chord pattern at a fixed tempo whose chord changes
//! every 8-beat phrase. The phrase's chord is what the synthetic dances follow, so a model can learn
//! music → dance from the chroma and beat columns of the audio features.
//!
//! An [`Arrangement`] varies what real songs vary and the dances do not follow: the loudness (a gain
//! ramp over the track), the mix (drums, bass, pad levels), sustained strings and a noise floor (no
//! silent gaps between hits), and phrases where the drums drop out or play softly (intros,
//! breakdowns). A model trained on plain tracks ties its motion to their exact loudness and
//! drum level and stands still when a real song starts quietly (docs/freezing.md, section 5).

use rand::Rng;
use rand_chacha::ChaCha8Rng;

/// Chords (semitones above the key root): I, IV, V, vi.
pub const CHORDS: [[i32; 3]; 4] = [[0, 4, 7], [5, 9, 12], [7, 11, 14], [9, 12, 16]];

/// Beats per bar and per phrase.
pub const BEATS_PER_BAR: usize = 4;
pub const BEATS_PER_PHRASE: usize = 8;

/// The rhythmic feel of a genre's music.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Groove {
    /// Kick on every beat, snare on 2 and 4, open hats on the off-beats (house, pop, waacking).
    FourOnFloor,
    /// Syncopated kick, snare on 2 and 4, straight eighth hats (break, krump, hip hop).
    Breakbeat,
    /// Kick on 1 and 3, brushed snare, swung hats (jazz, lock).
    Swing,
}

/// Everything that defines one procedural track.
#[derive(Debug, Clone)]
pub struct MusicSpec {
    pub bpm: f64,
    /// Time of the first beat in seconds.
    pub first_beat: f64,
    /// MIDI note of the key root (e.g. 45 = A2).
    pub key_root: i32,
    /// Chord index (into [`CHORDS`]) of each phrase, cycled if the track is longer.
    pub phrase_chords: Vec<usize>,
    pub groove: Groove,
    pub seconds: f64,
    /// Loudness, mix and drum sections (plain: every phrase the same, peak at 0.8).
    pub arrangement: Arrangement,
    /// The genre's riff ([`SIGNATURES`], by genre index in AIST++ order), or none.
    pub signature: Option<usize>,
}

/// Each genre's riff, as real AIST++ genres have their own music (break beats, house, funk for locking, …):
/// the sixteenths hit within every two beats (bit i = sixteenth i of 8) and the riff's pitch class. The masks
/// differ under every shift by whole beats, so a window of one to two beats tells the genres apart; they
/// survive per-track standardisation of the features (they are rhythm and pitch, not level).
pub const SIGNATURES: [(u8, i32); 10] = [
    (0b0100_1001, 0),  // BR: sixteenths 0, 3, 6
    (0b0100_0100, 2),  // PO: 2, 6
    (0b0011_0011, 4),  // LO: 0, 1, 4, 5
    (0b1010_1010, 5),  // MH: 1, 3, 5, 7
    (0b0010_0001, 7),  // LH: 0, 5
    (0b1100_1100, 9),  // HO: 2, 3, 6, 7
    (0b0101_0101, 11), // WA: 0, 2, 4, 6
    (0b0000_0111, 1),  // KR: 0, 1, 2
    (0b1000_1000, 3),  // JS: 3, 7
    (0b1101_0001, 6),  // JB: 0, 4, 6, 7
];

/// How a track's loudness and mix vary; the dances ignore all of it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Arrangement {
    /// Gain (dB, after peak normalisation to 0.8) at the start and the end of the track, linear
    /// in dB between them.
    pub gain_db: [f64; 2],
    /// Level of the drums, the bass and the per-beat chord pad.
    pub drums: f64,
    pub bass: f64,
    pub pad: f64,
    /// Level of chord strings held through each phrase (0: none).
    pub strings: f64,
    /// Level of a constant noise floor (0: none).
    pub noise: f64,
    /// Drum level of each phrase (cycled like the chords): 1 full, 0 drums out.
    pub phrase_drums: Vec<f64>,
}

impl Arrangement {
    /// Every phrase the same, no strings or noise, no gain change: the original procedural music.
    pub fn plain() -> Arrangement {
        Arrangement {
            gain_db: [0.0, 0.0],
            drums: 1.0,
            bass: 1.0,
            pad: 1.0,
            strings: 0.0,
            noise: 0.0,
            phrase_drums: vec![1.0],
        }
    }

    /// A random arrangement for `phrases` phrases: gain −15..0 dB at each end, mix levels, and
    /// per phrase full drums (70 %), soft drums (15 %) or none (15 %); the first phrase is an
    /// intro without or with soft drums half of the time.
    pub fn random(rng: &mut ChaCha8Rng, phrases: usize) -> Arrangement {
        let mut phrase_drums: Vec<f64> = (0..phrases.max(1))
            .map(|_| match rng.random_range(0..20) {
                0..=2 => 0.0,
                3..=5 => 0.35,
                _ => 1.0,
            })
            .collect();
        if rng.random_bool(0.5) {
            phrase_drums[0] = if rng.random_bool(0.5) { 0.0 } else { 0.35 };
        }
        Arrangement {
            gain_db: [rng.random_range(-15.0..0.0), rng.random_range(-15.0..0.0)],
            drums: rng.random_range(0.4..1.0),
            bass: rng.random_range(0.5..1.3),
            pad: rng.random_range(0.5..2.0),
            strings: rng.random_range(0.5..2.0),
            noise: rng.random_range(0.002..0.02),
            phrase_drums,
        }
    }

    fn phrase_drum(&self, beat: usize) -> f64 {
        self.drums * self.phrase_drums[(beat / BEATS_PER_PHRASE) % self.phrase_drums.len()]
    }
}

impl MusicSpec {
    /// A random track at `bpm` for `seconds`.
    pub fn random(rng: &mut ChaCha8Rng, bpm: f64, groove: Groove, seconds: f64) -> MusicSpec {
        let beats = (seconds * bpm / 60.0).ceil() as usize + 1;
        let phrases = beats.div_ceil(BEATS_PER_PHRASE).max(1);
        let mut chords = Vec::with_capacity(phrases);
        let mut last = usize::MAX;
        for _ in 0..phrases {
            // No chord twice in a row, so every phrase boundary is audible.
            let mut c = rng.random_range(0..CHORDS.len());
            while c == last {
                c = rng.random_range(0..CHORDS.len());
            }
            chords.push(c);
            last = c;
        }
        MusicSpec {
            bpm,
            first_beat: 0.0,
            key_root: 40 + rng.random_range(0..12),
            phrase_chords: chords,
            groove,
            seconds,
            arrangement: Arrangement::plain(),
            signature: None,
        }
    }

    pub fn beat_period(&self) -> f64 {
        60.0 / self.bpm
    }

    /// Beat times (seconds) inside the track.
    pub fn beat_times(&self) -> Vec<f64> {
        let p = self.beat_period();
        (0..)
            .map(|b| self.first_beat + b as f64 * p)
            .take_while(|&t| t < self.seconds)
            .collect()
    }

    /// Chord index sounding at beat `b` (0-based).
    pub fn chord_at_beat(&self, b: usize) -> usize {
        self.phrase_chords[(b / BEATS_PER_PHRASE) % self.phrase_chords.len()]
    }
}

fn midi_hz(n: f64) -> f64 {
    440.0 * 2f64.powf((n - 69.0) / 12.0)
}

/// Render the track as mono samples in [−1, 1].
pub fn render(spec: &MusicSpec, sample_rate: u32, rng: &mut ChaCha8Rng) -> Vec<f64> {
    let sr = sample_rate as f64;
    let n = (spec.seconds * sr).round() as usize;
    let mut out = vec![0.0; n];
    let period = spec.beat_period();
    let total_beats = (spec.seconds / period).ceil() as usize + 1;
    let arr = &spec.arrangement;

    for beat in 0..total_beats {
        let t_beat = spec.first_beat + beat as f64 * period;
        let in_bar = beat % BEATS_PER_BAR;
        let chord = CHORDS[spec.chord_at_beat(beat)];
        let root = spec.key_root as f64 + chord[0] as f64;

        add_drums(&mut out, sr, spec, beat, rng);
        if let Some(g) = spec.signature {
            add_signature(&mut out, sr, spec, beat, g);
        }
        // Bass: root on the beat, fifth on the off-beat.
        add_tone(
            &mut out,
            sr,
            t_beat,
            period * 0.45,
            midi_hz(root - 12.0),
            0.28 * arr.bass,
            0.01,
            0.12,
        );
        add_tone(
            &mut out,
            sr,
            t_beat + period * 0.5,
            period * 0.4,
            midi_hz(root - 5.0),
            0.18 * arr.bass,
            0.01,
            0.1,
        );
        // Chord pad: held through the beat, re-struck each bar.
        for &iv in &chord {
            let f = midi_hz(spec.key_root as f64 + 12.0 + iv as f64);
            let amp = if in_bar == 0 { 0.09 } else { 0.06 };
            add_tone(
                &mut out,
                sr,
                t_beat,
                period * 0.95,
                f,
                amp * arr.pad,
                0.02,
                0.6,
            );
        }
        // Strings: the chord held through the phrase, one octave up, slow attack.
        if arr.strings > 0.0 && beat % BEATS_PER_PHRASE == 0 {
            for &iv in &chord {
                let f = midi_hz(spec.key_root as f64 + 24.0 + iv as f64);
                let len = period * BEATS_PER_PHRASE as f64;
                add_tone(&mut out, sr, t_beat, len, f, 0.025 * arr.strings, 0.3, 1e9);
            }
        }
    }
    master(&mut out, arr, rng);
    out
}

/// The drums of beat `beat`, on a 16th grid within the beat, after the groove.
fn add_drums(out: &mut [f64], sr: f64, spec: &MusicSpec, beat: usize, rng: &mut ChaCha8Rng) {
    let period = spec.beat_period();
    let sixteenth = period / 4.0;
    let t_beat = spec.first_beat + beat as f64 * period;
    let in_bar = beat % BEATS_PER_BAR;
    let (kick16, snare, hats): (&[usize], bool, &[f64]) = match spec.groove {
        Groove::FourOnFloor => (&[0], in_bar % 2 == 1, &[0.5]),
        Groove::Breakbeat => (
            if in_bar == 2 { &[0, 2] } else { &[0] },
            in_bar % 2 == 1,
            &[0.0, 0.5],
        ),
        Groove::Swing => (
            if in_bar.is_multiple_of(2) { &[0] } else { &[] },
            in_bar % 2 == 1,
            &[0.0, 2.0 / 3.0],
        ),
    };
    let drums = spec.arrangement.phrase_drum(beat);
    for &k in kick16 {
        add_kick(out, sr, t_beat + k as f64 * sixteenth, 0.9 * drums);
    }
    if !kick16.contains(&0) {
        // A soft kick on every beat keeps the pulse clear for beat tracking.
        add_kick(out, sr, t_beat, 0.5 * drums);
    }
    if snare {
        add_snare(out, sr, t_beat, 0.5 * drums, rng);
    }
    for &h in hats {
        add_hat(out, sr, t_beat + h * period, 0.18 * drums, rng);
    }
}

/// Genre `g`'s riff ([`SIGNATURES`]) over beat `beat`: short plucks two octaves above the key's register,
/// the same level in every phrase (drum breaks included).
fn add_signature(out: &mut [f64], sr: f64, spec: &MusicSpec, beat: usize, g: usize) {
    let (mask, pitch) = SIGNATURES[g];
    let period = spec.beat_period();
    let t_beat = spec.first_beat + beat as f64 * period;
    let f = midi_hz(84.0 + pitch as f64);
    for k in 0..4 {
        if mask >> ((beat % 2) * 4 + k) & 1 == 1 {
            let t = t_beat + k as f64 * period / 4.0;
            add_tone(out, sr, t, period / 5.0, f, 0.12, 0.002, 0.04);
        }
    }
}

/// The mix's last touches: the arrangement's noise floor, the peak at 0.8 and its gain ramp (dB).
fn master(out: &mut [f64], arr: &Arrangement, rng: &mut ChaCha8Rng) {
    let n = out.len();
    if arr.noise > 0.0 {
        out.iter_mut()
            .for_each(|x| *x += arr.noise * rng.random_range(-1.0..1.0));
    }
    let peak = out.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    if peak > 0.0 {
        let g = 0.8 / peak;
        out.iter_mut().for_each(|x| *x *= g);
    }
    let [g0, g1] = arr.gain_db;
    if g0 != 0.0 || g1 != 0.0 {
        let last = (n.max(2) - 1) as f64;
        for (i, x) in out.iter_mut().enumerate() {
            let db = g0 + (g1 - g0) * i as f64 / last;
            *x *= 10f64.powf(db / 20.0);
        }
    }
}

fn span(out_len: usize, sr: f64, t0: f64, dur: f64) -> (usize, usize) {
    let a = (t0 * sr).round().max(0.0) as usize;
    let b = ((t0 + dur) * sr).round().max(0.0) as usize;
    (a.min(out_len), b.min(out_len))
}

fn add_kick(out: &mut [f64], sr: f64, t0: f64, amp: f64) {
    let (a, b) = span(out.len(), sr, t0, 0.25);
    let mut phase = 0.0;
    for (i, s) in out[a..b].iter_mut().enumerate() {
        let t = i as f64 / sr;
        let f = 50.0 + 110.0 * (-t / 0.03).exp();
        phase += 2.0 * std::f64::consts::PI * f / sr;
        *s += amp * phase.sin() * (-t / 0.12).exp();
    }
}

fn add_snare(out: &mut [f64], sr: f64, t0: f64, amp: f64, rng: &mut ChaCha8Rng) {
    let (a, b) = span(out.len(), sr, t0, 0.2);
    for (i, s) in out[a..b].iter_mut().enumerate() {
        let t = i as f64 / sr;
        let noise: f64 = rng.random_range(-1.0..1.0);
        let body = (2.0 * std::f64::consts::PI * 185.0 * t).sin() * (-t / 0.04).exp();
        *s += amp * (0.7 * noise * (-t / 0.07).exp() + 0.5 * body);
    }
}

fn add_hat(out: &mut [f64], sr: f64, t0: f64, amp: f64, rng: &mut ChaCha8Rng) {
    let (a, b) = span(out.len(), sr, t0, 0.06);
    let mut prev = 0.0;
    for (i, s) in out[a..b].iter_mut().enumerate() {
        let t = i as f64 / sr;
        let noise: f64 = rng.random_range(-1.0..1.0);
        // First difference = crude high-pass.
        *s += amp * (noise - prev) * (-t / 0.015).exp();
        prev = noise;
    }
}

#[allow(clippy::too_many_arguments)]
fn add_tone(
    out: &mut [f64],
    sr: f64,
    t0: f64,
    dur: f64,
    f: f64,
    amp: f64,
    attack: f64,
    decay: f64,
) {
    let (a, b) = span(out.len(), sr, t0, dur);
    let w = 2.0 * std::f64::consts::PI * f;
    let len = (b - a) as f64 / sr;
    for (i, s) in out[a..b].iter_mut().enumerate() {
        let t = i as f64 / sr;
        let env = (t / attack).min(1.0) * (-t / decay).exp() * ((len - t) / 0.01).clamp(0.0, 1.0);
        *s += amp * env * ((w * t).sin() + 0.3 * (2.0 * w * t).sin());
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    /// No two genres' riffs are the same, nor the same one beat later (halves swapped), nor share a pitch.
    #[test]
    fn signatures_tell_genres_apart() {
        let swap = |m: u8| m.rotate_left(4);
        for (i, &(a, pa)) in SIGNATURES.iter().enumerate() {
            assert!(a != 0, "genre {i} has an empty riff");
            for (j, &(b, pb)) in SIGNATURES.iter().enumerate().skip(i + 1) {
                assert!(a != b && a != swap(b), "genres {i} and {j} share a riff");
                assert_ne!(pa, pb, "genres {i} and {j} share a pitch");
            }
        }
    }

    /// The riff is added on top of the same track.
    #[test]
    fn signature_adds_a_riff() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let plain = MusicSpec::random(&mut rng, 120.0, Groove::Breakbeat, 4.0);
        let riff = MusicSpec {
            signature: Some(7),
            ..plain.clone()
        };
        let a = render(&plain, 8000, &mut ChaCha8Rng::seed_from_u64(1));
        let b = render(&riff, 8000, &mut ChaCha8Rng::seed_from_u64(1));
        assert_eq!(a.len(), b.len());
        let diff: f64 = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).sum::<f64>() / a.len() as f64;
        assert!(diff > 1e-3, "the riff changes the track ({diff})");
    }

    #[test]
    fn render_is_deterministic_and_bounded() {
        let mk = || {
            let mut rng = ChaCha8Rng::seed_from_u64(5);
            let spec = MusicSpec::random(&mut rng, 120.0, Groove::Breakbeat, 4.0);
            render(&spec, 8000, &mut rng)
        };
        let a = mk();
        assert_eq!(a.len(), 32000);
        assert_eq!(a, mk());
        let peak = a.iter().fold(0.0f64, |m, x| m.max(x.abs()));
        assert!((peak - 0.8).abs() < 1e-12);
    }

    #[test]
    fn arrangement_sets_loudness_and_drum_sections() {
        // Mean energy of the 50 ms after each of the given beats.
        let after_beats = |x: &[f64], beats: &[f64], sr: f64| {
            let e: f64 = beats
                .iter()
                .map(|&t| {
                    let i = (t * sr) as usize;
                    x[i..i + 400].iter().map(|v| v * v).sum::<f64>()
                })
                .sum();
            e / beats.len() as f64
        };
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let mut spec = MusicSpec::random(&mut rng, 120.0, Groove::FourOnFloor, 8.5);
        spec.arrangement = Arrangement {
            gain_db: [-12.0, -12.0],
            phrase_drums: vec![0.0, 1.0],
            strings: 1.0,
            noise: 0.01,
            ..Arrangement::plain()
        };
        let sr = 8000.0;
        let x = render(&spec, 8000, &mut rng);
        // Peak normalised to 0.8, then 12 dB down.
        let peak = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((peak - 0.8 * 10f64.powf(-0.6)).abs() < 1e-12, "{peak}");
        // Phrase 0 (beats 0–7) has no drums, phrase 1 has them: its beats carry far more energy.
        let beats = spec.beat_times();
        let (quiet, loud) = (
            after_beats(&x, &beats[1..8], sr),
            after_beats(&x, &beats[8..16], sr),
        );
        assert!(
            quiet < 0.3 * loud,
            "after beats: {quiet} without drums, {loud} with"
        );
        // Strings and noise fill the gaps: no silent stretch of 50 ms.
        let quiet = x
            .chunks(400)
            .map(|c| c.iter().map(|v| v * v).sum::<f64>() / 400.0)
            .fold(f64::INFINITY, f64::min);
        assert!(quiet > 1e-6, "quietest 50 ms: {quiet}");
        // Random arrangements stay inside their documented ranges, first phrase included.
        for seed in 0..50 {
            let a = Arrangement::random(&mut ChaCha8Rng::seed_from_u64(seed), 4);
            assert_eq!(a.phrase_drums.len(), 4);
            assert!(a.gain_db.iter().all(|g| (-15.0..0.0).contains(g)));
            assert!(a.phrase_drums.iter().all(|d| [0.0, 0.35, 1.0].contains(d)));
        }
    }

    #[test]
    fn onsets_on_the_beat() {
        // Energy right after each beat exceeds the energy just before it.
        let mut rng = ChaCha8Rng::seed_from_u64(9);
        let spec = MusicSpec::random(&mut rng, 100.0, Groove::FourOnFloor, 6.0);
        let sr = 8000.0;
        let x = render(&spec, 8000, &mut rng);
        for &t in spec.beat_times().iter().skip(1).take(8) {
            let i = (t * sr) as usize;
            let after: f64 = x[i..i + 400].iter().map(|v| v * v).sum();
            let before: f64 = x[i - 400..i].iter().map(|v| v * v).sum();
            assert!(after > 2.0 * before, "beat at {t}: {after} vs {before}");
        }
    }
}
