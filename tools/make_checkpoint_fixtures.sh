#!/usr/bin/env bash
# Makes tests/data/checkpoints/: one tiny run of every model family, trained for 2 updates, and what a given
# build of `qean` does with each (tests/stored_checkpoints.rs checks that later builds load, sample and
# resume them identically). Run it with the build whose behaviour the fixtures pin:
#
#   tools/make_checkpoint_fixtures.sh path/to/qean tests/data/checkpoints
#
# Needs ../shared (the AIST++ excerpt used as the seed motion) and python3 (the parameter summaries).
set -euo pipefail
QEAN=$(realpath "$1")
OUT=$(realpath -m "$2")
ROOT=$(cd "$(dirname "$0")/.." && pwd)
SEED="$ROOT/../shared/data/aistpp/motions/softcat477_sample_with_scaling.pkl"
MUSIC="$ROOT/tests/data/hr3-desert_excerpt.ogg"
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

rm -rf "$OUT"
mkdir -p "$OUT/runs" "$OUT/expected"
"$QEAN" synth --sequences 12 --seconds 8 --out "$WORK/synth" >/dev/null

COMMON=(--set train.steps=2 --set train.batch_size=4 --set train.checkpoint_every=2 --set train.val_every=2)
SMALL=(--set model.hidden=16 --set model.heads=2 --set model.ffn=32 --set model.motion_layers=1
       --set model.audio_layers=1 --set model.cross_layers=1)
GPT=(--set gpt.codes=16 --set gpt.hidden=16 --set gpt.heads=2 --set gpt.base_layers=1 --set gpt.head_layers=1)
# Runs refer to each other by relative paths: commands run inside runs/.
cd "$OUT/runs"
train() { # family config sets...
  local family=$1 config=$2
  shift 2
  "$QEAN" train --plain --config "$ROOT/configs/$config" --data "$WORK/synth" --run-dir "$family" \
    "${COMMON[@]}" "$@" >/dev/null
}
train fact tiny/fact.toml "${SMALL[@]}"
train qean tiny/full.toml "${SMALL[@]}"
train tsmt tsmt/tiny.toml --set tsmt.window=32
train inbetween inbetween/tiny.toml --set inbetween.hidden=16 --set inbetween.heads=2 --set inbetween.ffn=32 \
  --set inbetween.layers=1 --set inbetween.audio_layers=1
train vqvae control/vqvae_tiny.toml --set vq.width=16 --set vq.code_dim=8 --set vq.codes=16 --set vq.depth=1
train gpt control/gpt_tiny.toml "${GPT[@]}" --set 'gpt.vqvae_run="vqvae"'
train genre control/genre_tiny.toml "${GPT[@]}" --set 'genre.gpt_run="gpt"' --set genre.code_dim=8 \
  --set genre.z_dim=4 --set 'genre.xattn_on="all"' --set genre.disc_width=8 --set genre.disc_layers=1 --set genre.disc_ff=16 \
  --set genre.disc_heads=2
train genre_clf control/genre_clf_tiny.toml --set genre_clf.width=8 --set genre_clf.window=64
# Only what a checkpoint is: no logs, plots or locks.
rm -f ./*/train.log ./*/loss.png ./*/lock

# What the build does with them: dances (the same seed and song), an edit, the evaluations of the VQ-VAE and
# the classifier on the synthetic test + val split, and one more update after resuming (parameter sums).
for family in fact qean tsmt gpt genre; do
  extra=()
  [ "$family" = genre ] && extra=(--genre BR)
  "$QEAN" sample --run "$family" --music "$MUSIC" --seed-motion "$SEED" --frames 60 --name "$family" \
    --out "$WORK/dances" "${extra[@]}" >/dev/null
  cp "$WORK/dances/$family.pkl" "$OUT/expected/"
done
echo '{"regenerate": [[20, 80]], "keep": "grid:5"}' > "$WORK/edits.json"
"$QEAN" edit --method transformer --motion "$SEED" --edits "$WORK/edits.json" --bpm 120 --run inbetween \
  --out "$OUT/expected/inbetween.pkl" >/dev/null
# Evaluations and resumes in a copy of the runs. A stage checks that its frozen run is the one it was
# trained on, so the stages resume before the runs they froze (genre, then gpt, then vqvae).
cp -r "$OUT/runs" "$WORK/copy"
cd "$WORK/copy"
for family in vqvae genre_clf; do
  "$QEAN" eval --run "$family" --data "$WORK/synth" >/dev/null
  cp "$family/eval/step-2/report.json" "$OUT/expected/$family.report.json"
done
for family in genre gpt vqvae fact qean tsmt inbetween genre_clf; do
  "$QEAN" train --plain --resume "$family" --data "$WORK/synth" --set train.steps=3 >/dev/null
  "$QEAN" export "$family/checkpoints/step-3" --out "$WORK/$family.safetensors" >/dev/null
done
python3 - "$WORK" "$OUT/expected/resumed.json" <<'PY'
import json, struct, sys
work, out = sys.argv[1], sys.argv[2]
result = {}
for family in ["fact", "qean", "tsmt", "inbetween", "vqvae", "gpt", "genre", "genre_clf"]:
    blob = open(f"{work}/{family}.safetensors", "rb").read()
    n = struct.unpack("<Q", blob[:8])[0]
    header = json.loads(blob[8:8 + n])
    sums = {}
    for name, t in header.items():
        if name == "__metadata__":
            continue
        a, b = t["data_offsets"]
        vals = struct.unpack(f"<{(b - a) // 4}f", blob[8 + n + a:8 + n + b])
        sums[name] = [sum(vals), sum(v * v for v in vals)]
    state = json.load(open(f"{work}/copy/{family}/checkpoints/step-3/state.json"))
    result[family] = {"last_loss": state["last_loss"], "params": sums}
json.dump(result, open(out, "w"), indent=1, sort_keys=True)
PY
du -sh "$OUT"
