//! The per-music-ID cache of 35-D music features inside a dataset directory:
//! `DIR/features/<music ID>.npy` (frames × 35, float32) plus `<music ID>.json`, which records the audio file
//! (name, size, modification time) and the options the features were computed with. A cached file is up to
//! date when its record matches; a `.npy` without a record is an imported feature file (e.g. made by librosa
//! itself, SPEC §2.8) and is used as it is.

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use crate::dataset::Dataset;
use crate::windows::{MusicFeatures, AUDIO_DIM};
use qean_io::error::{Error, Result};
use qean_io::fsutil::atomic_write;

/// Version of the feature computation; bump when its output changes.
pub const FEATURE_VERSION: u32 = 1;

/// What the cached features were computed from.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CacheRecord {
    pub audio_file: String,
    pub audio_bytes: u64,
    pub audio_mtime_ns: u128,
    /// Options that change the output, as text (e.g. "start_bpm=80 resampler=kaiser_best").
    pub options: String,
    pub version: u32,
    pub frames: usize,
}

/// The state of one music ID's cache entry.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CacheState {
    UpToDate,
    Imported,
    Stale,
    Missing,
}

pub fn features_path(dataset: &Dataset, music_id: &str) -> PathBuf {
    dataset.features_dir().join(format!("{music_id}.npy"))
}

fn record_path(dataset: &Dataset, music_id: &str) -> PathBuf {
    dataset.features_dir().join(format!("{music_id}.json"))
}

fn audio_identity(audio: &Path) -> Result<(String, u64, u128)> {
    let meta = std::fs::metadata(audio).map_err(|e| Error::io(audio, e))?;
    let mtime = meta
        .modified()
        .ok()
        .and_then(|t| t.duration_since(std::time::UNIX_EPOCH).ok())
        .map(|d| d.as_nanos())
        .unwrap_or(0);
    let name = audio
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok((name, meta.len(), mtime))
}

/// Is the cache entry of `music_id` usable for `audio` computed with `options`?
pub fn state(dataset: &Dataset, music_id: &str, audio: Option<&Path>, options: &str) -> CacheState {
    let npy = features_path(dataset, music_id);
    if !npy.is_file() {
        return CacheState::Missing;
    }
    let rec = record_path(dataset, music_id);
    let Ok(text) = std::fs::read_to_string(&rec) else {
        return CacheState::Imported;
    };
    let Ok(record) = serde_json::from_str::<CacheRecord>(&text) else {
        return CacheState::Stale;
    };
    let Some(audio) = audio else {
        // The audio is gone; the cached features are all we have.
        return CacheState::UpToDate;
    };
    match audio_identity(audio) {
        Ok((name, bytes, mtime))
            if record.audio_file == name
                && record.audio_bytes == bytes
                && record.audio_mtime_ns == mtime
                && record.options == options
                && record.version == FEATURE_VERSION =>
        {
            CacheState::UpToDate
        }
        _ => CacheState::Stale,
    }
}

/// Store freshly computed features and their record. Order: the old features go, then the record, then the
/// features (atomically): an interruption at any point leaves no features (computed again next time), never
/// features without their record (which would pass for imported ones) or a record beside older features.
pub fn store(
    dataset: &Dataset,
    music_id: &str,
    audio: &Path,
    options: &str,
    features: &MusicFeatures,
) -> Result<()> {
    let dir = dataset.features_dir();
    if !dir.is_dir() {
        std::fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
    }
    let (data, frames) = features;
    let npy = features_path(dataset, music_id);
    if npy.is_file() {
        std::fs::remove_file(&npy).map_err(|e| Error::io(&npy, e))?;
    }
    let (audio_file, audio_bytes, audio_mtime_ns) = audio_identity(audio)?;
    let record = CacheRecord {
        audio_file,
        audio_bytes,
        audio_mtime_ns,
        options: options.to_string(),
        version: FEATURE_VERSION,
        frames: *frames,
    };
    let json = serde_json::to_vec_pretty(&record).map_err(|e| Error::msg(e.to_string()))?;
    atomic_write(&record_path(dataset, music_id), &json)?;
    qean_io::npy::write_f32(&npy, &[*frames, AUDIO_DIM], data)
}

/// Load cached (or imported) features of `music_id`, checking their shape and values.
pub fn load(dataset: &Dataset, music_id: &str) -> Result<MusicFeatures> {
    let path = features_path(dataset, music_id);
    let a = qean_io::npy::read(&path)?;
    match a.shape.as_slice() {
        [t, d] if *d == AUDIO_DIM => {
            if let Some(i) = a.data.iter().position(|x| !x.is_finite()) {
                return Err(Error::at(
                    &path,
                    format!("non-finite feature value at frame {}", i / AUDIO_DIM),
                ));
            }
            Ok((a.data.iter().map(|&x| x as f32).collect(), *t))
        }
        other => Err(Error::at(
            &path,
            format!("expected (frames, {AUDIO_DIM}) music features, got shape {other:?}"),
        )),
    }
}

/// Make sure every music ID has up-to-date features, computing missing or stale ones with
/// `compute(audio_path, music_id)`, several tracks at once (a thread a core: the feature pipeline is serial
/// in most of its stages, so tracks side by side keep every core busy); `progress(done, total, music_id)`
/// is called after each track, checked or computed. Each track's files are written atomically as it
/// finishes, so what is cached does not depend on the order; an error is the first failing track's in
/// `music_ids` order (the other tracks are still computed and cached). Returns how many were computed.
pub fn ensure(
    dataset: &Dataset,
    music_ids: &[String],
    options_of: impl Fn(&str) -> String + Sync,
    compute: impl Fn(&Path, &str) -> Result<MusicFeatures> + Sync,
    progress: impl FnMut(usize, usize, &str) + Send,
) -> Result<usize> {
    use std::sync::Mutex;
    // A cache run killed mid-write leaves its temporary behind; it is never read, but clear it.
    qean_io::fsutil::clean_stale_temporaries(&dataset.features_dir())?;
    let total = music_ids.len();
    let progress = Mutex::new((0, progress));
    let tick = |id: &str| {
        let mut p = progress.lock().unwrap_or_else(|e| e.into_inner());
        p.0 += 1;
        let done = p.0;
        (p.1)(done, total, id);
    };
    let mut todo = Vec::new();
    for id in music_ids {
        let audio = dataset.audio_path(id);
        let options = options_of(id);
        match (state(dataset, id, audio.as_deref(), &options), audio) {
            (CacheState::UpToDate | CacheState::Imported, _) => tick(id),
            (CacheState::Missing | CacheState::Stale, Some(audio)) => todo.push((id, audio, options)),
            // Before any track is computed: a missing file is known at once.
            (CacheState::Missing | CacheState::Stale, None) => {
                return Err(Error::at(
                    dataset.audio_dir(),
                    format!("no audio for music {id} (looked for {id}.wav/.ogg/.mp3/.flac) and no cached features"),
                ))
            }
        }
    }
    let one = |(id, audio, options): &(&String, PathBuf, String)| -> Result<()> {
        let f = compute(audio, id)?;
        store(dataset, id, audio, options, &f)?;
        tick(id);
        Ok(())
    };
    let results = crate::parallel::in_parallel(&todo, one);
    let mut first = None;
    for (r, (id, ..)) in results.into_iter().zip(&todo) {
        if let Err(e) = r {
            match first {
                None => first = Some(e),
                Some(_) => tracing::warn!("music {id}: {e}"),
            }
        }
    }
    match first {
        Some(e) => Err(e),
        None => Ok(todo.len()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn dataset() -> (tempfile::TempDir, Dataset) {
        let d = tempfile::tempdir().unwrap();
        std::fs::create_dir_all(d.path().join("motions")).unwrap();
        std::fs::create_dir_all(d.path().join("wav")).unwrap();
        std::fs::write(d.path().join("wav/mBR0.wav"), b"fake audio").unwrap();
        let ds = Dataset::open(d.path()).unwrap();
        (d, ds)
    }

    #[test]
    fn tracks_side_by_side_cache_each_and_report_the_first_failure_in_order() {
        let (_d, ds) = dataset();
        let ids: Vec<String> = (0..8).map(|k| format!("mBR{k}")).collect();
        for id in &ids {
            std::fs::write(ds.root.join(format!("wav/{id}.wav")), id.as_bytes()).unwrap();
        }
        // Each track's value is its index: a mix-up between tracks shows in the cache.
        let value = |id: &str| id[3..].parse::<f32>().unwrap();
        let fail = |id: &str| matches!(id, "mBR3" | "mBR6");
        let compute = |_: &Path, id: &str| {
            if fail(id) {
                return Err(Error::msg(format!("cannot decode {id}")));
            }
            Ok((vec![value(id); 10 * AUDIO_DIM], 10))
        };
        let mut seen = Vec::new();
        let err = ensure(
            &ds,
            &ids,
            |_| "o".into(),
            compute,
            |done, total, _| seen.push((done, total)),
        )
        .unwrap_err();
        assert!(err.to_string().contains("cannot decode mBR3"), "{err}");
        assert_eq!(seen, (1..=6).map(|d| (d, 8)).collect::<Vec<_>>());
        for id in ids.iter().filter(|id| !fail(id)) {
            let (data, frames) = load(&ds, id).unwrap();
            assert_eq!(frames, 10);
            assert!(data.iter().all(|&x| x == value(id)), "{id}");
        }
        assert!(!features_path(&ds, "mBR3").exists());
    }

    #[test]
    fn compute_once_then_reuse_then_recompute_when_stale() {
        let (_d, ds) = dataset();
        let ids = vec!["mBR0".to_string()];
        let calls = std::sync::atomic::AtomicUsize::new(0);
        let compute = |_: &Path, _: &str| {
            calls.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            Ok((vec![0.25f32; 300 * 35], 300))
        };
        let opts = |_: &str| "start_bpm=80".to_string();
        assert_eq!(ensure(&ds, &ids, opts, compute, |_, _, _| {}).unwrap(), 1);
        assert_eq!(ensure(&ds, &ids, opts, compute, |_, _, _| {}).unwrap(), 0);
        assert_eq!(load(&ds, "mBR0").unwrap().1, 300);
        // Other options: stale.
        assert_eq!(
            ensure(&ds, &ids, |_| "start_bpm=90".into(), compute, |_, _, _| {}).unwrap(),
            1
        );
        // Changed audio: stale.
        std::fs::write(ds.root.join("wav/mBR0.wav"), b"other audio, longer").unwrap();
        assert_eq!(
            ensure(&ds, &ids, |_| "start_bpm=90".into(), compute, |_, _, _| {}).unwrap(),
            1
        );
        assert_eq!(calls.load(std::sync::atomic::Ordering::SeqCst), 3);
        // Without a record the features count as imported and are kept.
        std::fs::remove_file(record_path(&ds, "mBR0")).unwrap();
        assert_eq!(
            state(&ds, "mBR0", ds.audio_path("mBR0").as_deref(), "x"),
            CacheState::Imported
        );
    }

    #[test]
    fn missing_audio_and_bad_shapes() {
        let (_d, ds) = dataset();
        let e = ensure(
            &ds,
            &["mPO1".to_string()],
            |_| String::new(),
            |_, _| unreachable!(),
            |_, _, _| {},
        )
        .unwrap_err();
        assert!(e.to_string().contains("no audio for music mPO1"), "{e}");
        std::fs::create_dir_all(ds.features_dir()).unwrap();
        qean_io::npy::write_f32(&features_path(&ds, "mPO1"), &[10, 34], &[0.0; 340]).unwrap();
        let e = load(&ds, "mPO1").unwrap_err();
        assert!(e.to_string().contains("expected (frames, 35)"), "{e}");
    }
}
