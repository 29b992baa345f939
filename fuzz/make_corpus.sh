#!/usr/bin/env bash
# Builds the seed corpus of every fuzz target in fuzz/corpus/<target>/ from the shared test data and
# the project's configs. Needs a built `qean` binary (QEAN=path, default ../target/debug/qean) for the
# .npy and .bvh seeds. Usage: fuzz/make_corpus.sh [SHARED_DATA_DIR]
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$here/.."
shared="${1:-$root/../shared/data}"
qean="${QEAN:-$root/target/debug/qean}"
c="$here/corpus"
mkdir -p "$c"/{pickle,npy,bvh,config,audio}

install -m 644 "$shared"/aistpp/motions/*.pkl "$c/pickle/"
find "$root/configs" -name '*.toml' | while read -r f; do
    cp "$f" "$c/config/$(echo "${f#$root/configs/}" | tr / _)"
done
# Audio: the first byte of an input picks the extension (0 wav, 1 ogg, 2 mp3, 3 flac); keep seeds small.
printf '\001' | cat - "$shared/music/sorohanro_-_solo-trumpet-06.ogg" > "$c/audio/trumpet.ogg.bin"
for w in "$shared"/music/*.wav; do
    printf '\000' | cat - <(head -c 65536 "$w") > "$c/audio/$(basename "$w").head.bin"
done

tmp="$(mktemp -d)"
trap 'rm -rf "$tmp"' EXIT
"$qean" joints "$shared/aistpp/motions/softcat477_sample_with_scaling.pkl" --out "$c/npy/joints.npy"
"$qean" convert "$shared/aistpp/motions/softcat477_sample_with_scaling.pkl" --out "$c/bvh/softcat.bvh"
"$qean" features "$shared/music/sorohanro_-_solo-trumpet-06.ogg" --out "$tmp" > /dev/null
cp "$tmp"/*.npy "$c/npy/trumpet_features.npy"
echo "corpus in $c: $(find "$c" -type f | wc -l) files"
