#!/usr/bin/env python3
"""Parity fixtures for the 35-D audio feature (SPEC §2, §2.8).

Reference: librosa 0.8.1 + resampy 0.2.2 (install into a venv outside the repo, see SPEC §2.8):
    python3.11 -m venv /work/venv-librosa
    /work/venv-librosa/bin/pip install "librosa==0.8.1" "resampy==0.2.2" "numpy<1.24" "scipy<1.13" \
        six setuptools soundfile
Run from the repo root:
    /work/venv-librosa/bin/python tools/make_audio_fixtures.py [MUSIC_DIR] [OUT_DIR] [DEBUG_DIR]
    /work/venv-librosa/bin/python tools/make_audio_fixtures.py --formats-only [MUSIC_DIR] [OUT_DIR]
MUSIC_DIR defaults to ../shared/data/music, OUT_DIR to audio/tests/fixtures. DEBUG_DIR (optional, not
committed) receives large intermediates (resampled signals, CQT magnitudes).
The feature assembly follows mint's tools/preprocessing.py (cache_audio_features).
"""
import json
import os
import sys

import numpy as np
import librosa
import resampy
import soundfile

assert librosa.__version__ == "0.8.1", librosa.__version__
assert resampy.__version__ == "0.2.2", resampy.__version__

SR = 30720
HOP = 512

TRACKS = [
    ("vibe_ace_wav", "Kevin_MacLeod_-_Vibe_Ace.wav"),
    ("vibe_ace_ogg", "Kevin_MacLeod_-_Vibe_Ace.ogg"),
    ("brahms_wav", "Brahms_Hungarian_Dance_5.wav"),
    ("brahms_ogg", "Brahms_Hungarian_Dance_5.ogg"),
    ("trumpet_wav", "sorohanro_-_solo-trumpet-06_90bpm.wav"),
    ("trumpet_ogg", "sorohanro_-_solo-trumpet-06.ogg"),
]


def features(y, start_bpm):
    env = librosa.onset.onset_strength(y, sr=SR)
    mfcc = librosa.feature.mfcc(y, sr=SR, n_mfcc=20).T
    chroma = librosa.feature.chroma_cens(y, sr=SR, hop_length=HOP, n_chroma=12).T
    peaks = librosa.onset.onset_detect(onset_envelope=env.flatten(), sr=SR, hop_length=HOP)
    peak_onehot = np.zeros_like(env, dtype=np.float32)
    peak_onehot[peaks] = 1.0
    tempo, beats = librosa.beat.beat_track(
        onset_envelope=env, sr=SR, hop_length=HOP, start_bpm=start_bpm, tightness=100
    )
    beat_onehot = np.zeros_like(env, dtype=np.float32)
    beat_onehot[beats] = 1.0
    feat = np.concatenate(
        [env[:, None], mfcc, chroma, peak_onehot[:, None], beat_onehot[:, None]], axis=-1
    )
    return feat, env, peaks, float(tempo), beats


def main():
    music = sys.argv[1] if len(sys.argv) > 1 else "../shared/data/music"
    out = sys.argv[2] if len(sys.argv) > 2 else "audio/tests/fixtures"
    debug = sys.argv[3] if len(sys.argv) > 3 else None
    os.makedirs(out, exist_ok=True)
    if debug:
        os.makedirs(debug, exist_ok=True)
    for key, fname in TRACKS:
        path = os.path.join(music, fname)
        native, sr_native = soundfile.read(path, dtype="float32", always_2d=True)
        y, _ = librosa.load(path, sr=SR)
        feat, env, peaks, tempo, beats = features(y, 120.0)
        tuning = float(librosa.estimate_tuning(y=y, sr=SR, bins_per_octave=36))
        meta = {
            "file": fname,
            "native_rate": int(sr_native),
            "native_frames": int(native.shape[0]),
            "native_channels": int(native.shape[1]),
            "native_sum": float(np.sum(native.astype(np.float64))),
            "native_sum_sq": float(np.sum(native.astype(np.float64) ** 2)),
            "resampled_len": int(len(y)),
            "resampled_sum": float(np.sum(y.astype(np.float64))),
            "resampled_sum_sq": float(np.sum(y.astype(np.float64) ** 2)),
            "frames": int(feat.shape[0]),
            "tempo_120": tempo,
            "beats_120": [int(b) for b in beats],
            "onsets": [int(p) for p in peaks],
            "tuning": tuning,
        }
        t90, b90 = librosa.beat.beat_track(
            onset_envelope=env, sr=SR, hop_length=HOP, start_bpm=90.0, tightness=100
        )
        meta["tempo_90"] = float(t90)
        meta["beats_90"] = [int(b) for b in b90]
        # Bailando's music beats on librosa's signal (SPEC §2.6; Bailando loads with essentia instead).
        y_perc = librosa.effects.hpss(y)[1]
        env_p = librosa.onset.onset_strength(y_perc, aggregate=np.median, sr=SR)
        tp, bp = librosa.beat.beat_track(onset_envelope=env_p, sr=SR, start_bpm=120.0)
        meta["hpss_tempo"] = float(tp)
        meta["hpss_beats"] = [int(b) for b in bp]
        np.save(os.path.join(out, key + "_feat35.npy"), np.ascontiguousarray(feat, dtype=np.float32))
        with open(os.path.join(out, key + ".json"), "w") as f:
            json.dump(meta, f, indent=1)
        if key == "trumpet_wav":
            # The resampled signal of the short loop (resampy kaiser_best parity), and kaiser_fast.
            np.save(os.path.join(out, "trumpet_resampled_best.npy"), np.ascontiguousarray(y))
            y_fast, _ = librosa.load(path, sr=SR, res_type="kaiser_fast")
            np.save(os.path.join(out, "trumpet_resampled_fast.npy"), np.ascontiguousarray(y_fast))
        if debug:
            np.save(os.path.join(debug, key + "_y.npy"), np.ascontiguousarray(y))
            cqt = np.abs(librosa.cqt(y, sr=SR, hop_length=HOP, n_bins=252, bins_per_octave=36, tuning=None))
            np.save(os.path.join(debug, key + "_cqt.npy"), np.ascontiguousarray(cqt.T.astype(np.float64)))
            np.save(os.path.join(debug, key + "_env_p.npy"), np.ascontiguousarray(env_p.astype(np.float64)))
        print(key, feat.shape, "tempo", tempo, "beats", len(beats), "onsets", len(peaks), "tuning", tuning)

    # Mel filterbanks (SPEC §2.2), stored sparsely: per band the first nonzero bin and the values.
    banks = {}
    for name, fmax in [("fmax_11025", 11025.0), ("fmax_sr2", None)]:
        m = librosa.filters.mel(SR, 2048, n_mels=128, fmax=fmax, dtype=np.float64)
        rows = []
        for r in m:
            nz = np.nonzero(r)[0]
            if len(nz) == 0:
                rows.append({"start": 0, "values": []})
            else:
                rows.append({"start": int(nz[0]), "values": [float(v) for v in r[nz[0]: nz[-1] + 1]]})
        banks[name] = rows
    with open(os.path.join(out, "mel_filterbanks.json"), "w") as f:
        json.dump(banks, f)


# Small decoding fixtures (0.5 s excerpts of the trumpet loop) in every container/sample format we read.
FORMATS = [
    # name, container, subtype, rate, channels
    ("u8_mono_11025.wav", "WAV", "PCM_U8", 11025, 1),
    ("s16_stereo_48000.wav", "WAV", "PCM_16", 48000, 2),
    ("s24_mono_44100.wav", "WAV", "PCM_24", 44100, 1),
    ("s32_mono_32000.wav", "WAV", "PCM_32", 32000, 1),
    ("f32_stereo_22050.wav", "WAV", "FLOAT", 22050, 2),
    ("f64_mono_30720.wav", "WAV", "DOUBLE", 30720, 1),
    ("s16_6ch_16000.wav", "WAV", "PCM_16", 16000, 6),
    ("flac_stereo_44100.flac", "FLAC", "PCM_16", 44100, 2),
    ("vorbis_stereo_44100.ogg", "OGG", "VORBIS", 44100, 2),
    ("mp3_mono_44100.mp3", "MP3", "MPEG_LAYER_III", 44100, 1),
]


def make_format_fixtures(music, out):
    src, _ = soundfile.read(os.path.join(music, "sorohanro_-_solo-trumpet-06_90bpm.wav"), dtype="float64")
    os.makedirs(os.path.join(out, "formats"), exist_ok=True)
    meta = {}
    for name, container, subtype, rate, ch in FORMATS:
        n = rate // 2
        x = src[20000: 20000 + n]
        chans = [x * (0.9 - 0.1 * c) if c % 2 == 0 else np.roll(x, 37 * c) * 0.6 for c in range(ch)]
        data = np.stack(chans, axis=1) if ch > 1 else x
        path = os.path.join(out, "formats", name)
        soundfile.write(path, data, rate, subtype=subtype, format=container)
        native, sr_native = soundfile.read(path, dtype="float32", always_2d=True)
        mono = librosa.to_mono(native.T) if native.shape[1] > 1 else native[:, 0]
        y, _ = librosa.load(path, sr=SR)
        feat, env, peaks, tempo, beats = features(y, 120.0)
        meta[name] = {
            "rate": int(sr_native),
            "channels": int(native.shape[1]),
            "frames": int(native.shape[0]),
            "mono_head": [float(v) for v in mono[:32]],
            "mono_sum_sq": float(np.sum(mono.astype(np.float64) ** 2)),
            "resampled_len": int(len(y)),
            "resampled_stride97": [float(v) for v in y[::97]],
            "resampled_sum_sq": float(np.sum(y.astype(np.float64) ** 2)),
            "feat35": [[float(v) for v in row] for row in feat],
            "tempo": tempo,
            "beats": [int(b) for b in beats],
            "onsets": [int(p) for p in peaks],
        }
        print(name, native.shape, sr_native, len(y), feat.shape)
    with open(os.path.join(out, "formats.json"), "w") as f:
        json.dump(meta, f)
    # A codec we do not decode (Opus in Ogg): must be rejected with a clear error.
    soundfile.write(os.path.join(out, "unsupported_opus.ogg"), src[:4800], 48000, format="OGG", subtype="OPUS")


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--formats-only":
        make_format_fixtures(sys.argv[2] if len(sys.argv) > 2 else "../shared/data/music",
                             sys.argv[3] if len(sys.argv) > 3 else "audio/tests/fixtures")
    else:
        main()
        make_format_fixtures(sys.argv[1] if len(sys.argv) > 1 else "../shared/data/music",
                             sys.argv[2] if len(sys.argv) > 2 else "audio/tests/fixtures")
