#!/usr/bin/env bash
# Reproduces the measurements of docs/freezing.md: the demo's synthetic dataset (and a 240-sequence
# one with the same music), the sweeps of configs/sweeps/freezing/, their evaluation and the figures.
#
#   tools/freezing_study.sh WORKDIR [QEAN_BINARY]
#
# About 9 hours of one CPU core for everything (two sweeps run at once on two cores). Finished
# runs and evaluations are reused, so the script can be stopped and started again.
set -euo pipefail
work=${1:?usage: tools/freezing_study.sh WORKDIR [QEAN_BINARY]}
root=$(cd "$(dirname "$0")/.." && pwd)
qean=${2:-$root/target/release/qean}
sweeps=$root/configs/sweeps/freezing
music=$root/assets/music
mkdir -p "$work"
cd "$work"

# Sections 1-4: 60 sequences of 16 s with plain procedural music (as the demo made them before
# varied music), two training music IDs replaced by real recordings. data60v is the demo's
# dataset now: the same with varied music (loudness, mix, drum sections; section 5).
real=(--real-music "$music/sorohanro_-_solo-trumpet-06.ogg=mBR1"
  --real-music "$music/Brahms_Hungarian_Dance_5.ogg=mLO0")
[ -d data60 ] || "$qean" synth --out data60 --sequences 60 --seconds 16 --seed 0 --plain-music "${real[@]}"
[ -d data60v ] || "$qean" synth --out data60v --sequences 60 --seconds 16 --seed 0 "${real[@]}"
[ -d data240v ] || "$qean" synth --out data240v --sequences 240 --seconds 16 --seed 0 "${real[@]}"
"$qean" features --dataset data60
"$qean" features --dataset data60v
"$qean" features --dataset data240v

# Two sweeps at a time: the CPU backend keeps one core busy per run.
"$qean" sweep --config "$sweeps/ablation.toml" --data data60 --out ablation --plain \
  --only mint,dance,dance-no-std,dance-no-noise &
"$qean" sweep --config "$sweeps/ablation.toml" --data data60 --out ablation --plain \
  --only dance+rollout,dance+velocity,dance+horizon40 &
wait
"$qean" sweep --config "$sweeps/steps.toml" --data data60v --out steps --plain &
"$qean" sweep --config "$sweeps/qean.toml" --data data60v --out qean --plain --only fact,qean,fact-2heads,qean-8heads &
wait
"$qean" sweep --config "$sweeps/qean.toml" --data data60v --out qean --plain --only qean-qra-small,qean-qra-zero &
"$qean" sweep --config "$sweeps/qean.toml" --data data60v --out qean --plain --only qean-dropout0.1 &
wait
# Section 4, window length and dataset size (varied music, three seeds).
# (windows.toml's w120, mint's 120/240, is configured too: about 4x the cost of an update of w30.)
"$qean" sweep --config "$sweeps/windows.toml" --data data60v --out windows --plain --only w30,w60 &
"$qean" sweep --config "$sweeps/data.toml" --data data240v --out data240v-runs --plain &
wait

# Evaluation: 900 generated frames per test/val sequence (all of their music), chance baselines.
eval_runs() { "$qean" curves "$@" --evaluate --data data60 --max-frames 900; }
eval_runs ablation --steps 4000 --out fig/ablation --title "ABLATION AT 4000 STEPS"
# Inference remedies on the same checkpoints: raw feedback, one pass per frame.
for r in ablation/dance-seed*; do
  "$qean" eval --run "$r" --data data60 --max-frames 900 --metrics-mode reference --baselines \
    --raw-feedback --ensemble 1 --tag mint-sampling >/dev/null
  "$qean" eval --run "$r" --data data60 --max-frames 900 --metrics-mode reference --baselines \
    --ensemble 1 --tag no-ensemble >/dev/null
  "$qean" eval --run "$r" --data data60 --max-frames 900 --metrics-mode reference --baselines \
    --raw-feedback --tag raw-feedback >/dev/null
done
for r in ablation/mint-seed*; do
  "$qean" eval --run "$r" --data data60 --max-frames 900 --metrics-mode reference --baselines \
    --feedback-project --ensemble 8 --tag dance-sampling >/dev/null
done
for tag in mint-sampling no-ensemble raw-feedback; do
  "$qean" curves ablation/dance-seed* --steps 4000 --tag "$tag" --out "fig/dance-$tag"
done
"$qean" curves ablation/mint-seed* --steps 4000 --tag dance-sampling --out fig/mint-dance-sampling
"$qean" curves steps --evaluate --data data60v --max-frames 900 \
  --steps 500,1000,2000,4000,8000,12000,16000,20000 --out fig/steps \
  --title "TINY FACT AGAINST TRAINING STEPS (WINDOWS 30/60, VARIED MUSIC)"
"$qean" curves qean --evaluate --data data60v --max-frames 600 --steps 4000 --out fig/qean \
  --title "TINY FACT AND QEAN AT 4000 STEPS (VARIED MUSIC)"
"$qean" curves windows --evaluate --data data60v --max-frames 900 --steps 2000,4000 --out fig/windows \
  --title "TINY FACT, WINDOWS 30/60 AND 60/120 (VARIED MUSIC)"
"$qean" curves data240v-runs --evaluate --data data240v --max-frames 900 --steps 4000 --out fig/data240v
# Their dances to the held-out song, seeded as the demo seeds (speed per 5 s printed by sample).
for run in windows/w*-seed* data240v-runs/dance-seed*; do
  "$qean" sample --run "$run" --music "$music/Kevin_MacLeod_-_Vibe_Ace.ogg" --data data60v \
    --sequence gBR_sBM_cAll_d04_mBR0_ch02 --out "$run/dances"
done
"$qean" curves ablation/dance-seed* ablation/mint-seed* --evaluate --data data60 --max-frames 900 \
  --out fig/ablation-steps --title "TINY FACT, WINDOWS 30/60, 3 SEEDS"

# docs/freezing.md section 5: the four tiny QEAN rows trained as the demo trains (at the 8 heads
# they had then), and their
# dances to the held-out real song and to a training recording (speed per 5 s printed by sample).
demo_set=(--set model.motion_len=30 --set model.audio_len=60 --set train.steps=4000
  --set "schedule.boundaries=[3000]" --set train.checkpoint_every=1000 --set train.val_every=1000
  --set train.batch_size=8)
for row in baseline spe qra full; do
  for seed in 0 1; do
    run=heldout/$row-seed$seed
    [ -d "$run/checkpoints/step-4000" ] ||
      "$qean" train --config "$root/configs/tiny/$row.toml" --data data60 --run-dir "$run" --plain \
        "${demo_set[@]}" --set train.seed=$seed --set model.heads=8
    for song in "$music/Kevin_MacLeod_-_Vibe_Ace.ogg" "$music/Brahms_Hungarian_Dance_5.ogg"; do
      "$qean" sample --run "$run" --music "$song" --data data60 \
        --sequence gBR_sBM_cAll_d04_mBR0_ch02 --out "$run/dances"
    done
  done
done
# Section 5 with varied music: the held-out dances of the three FACT and QEAN seeds at both head
# counts, and the QEAN variants tried against its decay (at 8 heads, as measured then).
for run in qean/fact-seed* qean/qean-seed* qean/fact-2heads-seed* qean/qean-8heads-seed*; do
  "$qean" sample --run "$run" --music "$music/Kevin_MacLeod_-_Vibe_Ace.ogg" --data data60v \
    --sequence gBR_sBM_cAll_d04_mBR0_ch02 --out "$run/dances"
done
variants=("keep-abs model.keep_abs_pos=true" "base100 model.rope_base=100"
  "concat model.cross_positions=\"concatenated\"" "no-noise recipe.input_noise=0.0")
for v in "${variants[@]}"; do
  run=heldout-v/${v%% *}
  [ -d "$run/checkpoints/step-4000" ] ||
    "$qean" train --config "$root/configs/tiny/full.toml" --data data60v --run-dir "$run" --plain \
      "${demo_set[@]}" --set model.heads=8 --set "${v#* }"
  for song in "$music/Kevin_MacLeod_-_Vibe_Ace.ogg" "$music/Brahms_Hungarian_Dance_5.ogg"; do
    "$qean" sample --run "$run" --music "$song" --data data60v \
      --sequence gBR_sBM_cAll_d04_mBR0_ch02 --out "$run/dances"
  done
done
echo "figures and tables: $work/fig/*/{curves.png,table.md}"
