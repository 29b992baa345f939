#!/usr/bin/env bash
# Trains the demo's FACT, QEAN, TSMT or VQ-VAE + GPT stage at several training seeds, exactly as `qean demo`
# does (its presets and its --set overrides, plus train.seed), and dances each run to the songs of
# docs/freezing.md section 7: Vibe Ace (held out) and the Debian excerpts of tools/debian_songs.sh, or, with
# SONG_SET=tuning, to the six tuning songs (DIR/tuning/excerpts) that settings are chosen on (SONG_SET=tuning2:
# the six more of DIR/tuning2/excerpts, for choices the first six leave tied).
# One table row per run: each song's slowest–fastest 5-s speed ratio / sharpest acceleration ratio,
# ✓ when every span is at 0.6–1.6× and ≤ 2×.
#
#   tools/stage_seeds.sh fact|qean|tsmt|gpt DEMO SONGS OUT [SEED ...] [-- KEY=VALUE ...]
#
# DEMO: a `qean demo` output (its data/ is used), SONGS: tools/debian_songs.sh's directory, OUT: where the
# runs go; seeds default to 0 1 2; KEY=VALUE pairs after `--` are extra `--set`s of the stage (the GPT's,
# not its VQ-VAE's; VQ_SET="KEY=VALUE ..." gives the VQ-VAE's; SAMPLE_SET="--flag value ..." adds
# `qean sample` flags, e.g. SAMPLE_SET="--floor-window 0"). QEAN=path/to/qean picks the binary
# (default: target/release/qean, then target/debug).
# Example (docs/freezing.md, section 7): tools/stage_seeds.sh gpt qean-demo songs seeds/gpt 0 1 2
# SONG_SET=tuning tools/stage_seeds.sh qean qean-demo songs seeds/qean 0 1 2 -- recipe.input_noise=0.02
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
stage="$1" demo="$2" songs="$3" out="$4"
shift 4
seeds=() extra=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then shift; for e in "$@"; do extra+=(--set "$e"); done; break; fi
  seeds+=("$1"); shift
done
[ ${#seeds[@]} -gt 0 ] || seeds=(0 1 2)
Q="${QEAN:-}"
if [ -z "$Q" ]; then
  Q="$root/target/release/qean"; [ -x "$Q" ] || Q="$root/target/debug/qean"
fi
data="$demo/data"
[ -f "$data/synth.json" ] || { echo "$data: not a qean demo dataset (no synth.json)" >&2; exit 2; }
mkdir -p "$out"
# The demo's overrides (pipeline/src/demo/mod.rs `overrides`/`plan`): 4,000 steps for FACT and QEAN, 3,000
# for TSMT, the VQ-VAE and the GPT.
case "$stage" in fact | qean) steps=4000 every=1000 log=133 ;; *) steps=3000 every=750 log=100 ;; esac
common=(--set "data.dir=\"$data\"" --set train.steps=$steps --set train.checkpoint_every=$every
  --set train.val_every=$every --set train.log_every=$log --set train.batch_size=8 --set model.motion_len=30
  --set model.audio_len=60 --set "schedule.boundaries=[$((steps * 3 / 4))]")
lr=(--set schedule.initial=1e-3 --set "schedule.values=[1e-4]")
# The demo's VQ-VAE keeps LR 1e-3 to its end (docs/control.md); VQ_SET="KEY=VALUE ..." adds --sets to it.
vq_lr=(--set schedule.initial=1e-3 --set "schedule.values=[1e-3]")
vq_extra=()
for e in ${VQ_SET:-}; do vq_extra+=(--set "$e"); done
train() { # run-dir log config args...
  local dir="$1" log="$2" config="$3"; shift 3
  if [ ! -d "$dir/checkpoints/step-$steps" ]; then
    rm -rf "$dir"
    "$Q" train --config "$root/$config" --plain --run-dir "$dir" "$@" >"$log" 2>&1 ||
      { echo "training $dir failed: $(tail -n 1 "$log")" >&2; exit 1; }
  fi
}
if [ "${SONG_SET:-judging}" = tuning ] || [ "${SONG_SET:-judging}" = tuning2 ]; then
  names=(battle_theme forest-sprint hr-domina-mountain hr-savino-ocean hr3-crossroads hr3-motion)
  [ "$SONG_SET" = tuning2 ] && names=(fortress hr-savino-ivory hr3-icyland hr3-laboratory salcon tropicalbreeze)
  list=() header="| run |"
  for s in "${names[@]}"; do
    list+=("$songs/$SONG_SET/excerpts/$s.ogg") header="$header $s |"
  done
  echo "$header dances |"
  echo "|---|---|---|---|---|---|---|---|"
else
  list=("$root/assets/music/Kevin_MacLeod_-_Vibe_Ace.ogg")
  for s in chipdisko hr-domina-hunting hr-savino-caribbean hr-savino-palace hr3-desert hr3-jungle; do
    list+=("$songs/excerpts/$s.ogg")
  done
  echo "| run | Vibe Ace | Chipdisko | Hunting | Caribbean | Palace | Desert | Jungle | dances |"
  echo "|---|---|---|---|---|---|---|---|---|"
fi
for song in "${list[@]}"; do
  [ -f "$song" ] || { echo "$song: missing (run tools/debian_songs.sh $songs)" >&2; exit 2; }
done
seq="$(head -n 1 "$data/splits/crossmodal_test.txt")"
for seed in "${seeds[@]}"; do
  case "$stage" in
    gpt)
      vq="$out/vq-s$seed"
      train "$vq" "$vq.log" configs/control/vqvae_tiny.toml "${common[@]}" "${vq_lr[@]}" --set train.seed="$seed" \
        "${vq_extra[@]}"
      run="$out/gpt-s$seed"
      train "$run" "$run.log" configs/control/gpt_tiny.toml "${common[@]}" "${lr[@]}" --set train.seed="$seed" \
        --set "gpt.vqvae_run=\"$vq\"" "${extra[@]}" ;;
    tsmt)
      run="$out/tsmt-s$seed"
      train "$run" "$run.log" configs/tsmt/small.toml "${common[@]}" --set train.seed="$seed" "${extra[@]}" ;;
    fact | qean)
      preset=configs/tiny/fact.toml
      [ "$stage" = qean ] && preset=configs/tiny/full.toml
      run="$out/$stage-s$seed"
      train "$run" "$run.log" "$preset" "${common[@]}" --set train.seed="$seed" "${extra[@]}" ;;
    *) echo "unknown stage $stage: expected fact, qean, tsmt or gpt" >&2; exit 2 ;;
  esac
  row="| $stage seed $seed |" n=0
  for song in "${list[@]}"; do
    dances="$(mktemp -d)"
    # shellcheck disable=SC2086 # SAMPLE_SET is split into flags on purpose
    line="$("$Q" sample --run "$run" --music "$song" --data "$data" --sequence "$seq" --frames 1200 \
      --out "$dances" ${SAMPLE_SET:-} 2>&1 | grep 'per 5 s:' || true)"
    rm -rf "$dances"
    cell="$(python3 - "$line" <<'PY'
import re, sys
m = re.search(r"speed ratio (.*?), acceleration ratio (.*?) \(", sys.argv[1])
if not m:
    print("no dance"); sys.exit()
speed = [float(x) for x in re.findall(r"[0-9.]+", m.group(1))]
accel = [float(x) for x in re.findall(r"[0-9.]+", m.group(2))]
ok = all(0.6 <= x <= 1.6 for x in speed) and all(x <= 2 for x in accel)
print(f"{min(speed):.2f}–{max(speed):.2f} / {max(accel):.2f} {'✓' if ok else '✗'}")
PY
)"
    case "$cell" in *✓) n=$((n + 1)) ;; esac
    row="$row $cell |"
  done
  echo "$row $n of ${#list[@]} |"
done
