#!/usr/bin/env bash
# Fetches the freely licensed songs of docs/freezing.md's "Songs in general" study from Debian's packages
# (no model here was trained or tuned on them) into DIR (default: songs/), with each licence beside them:
#   hyperrogue-music (CC BY-SA 3.0: Shawn Parrotte, Will Savino, Lincoln Domina; see its copyright file)
#   supertux-data    (data/music/*: GPL-2+, Marek Moeckel and the SuperTux team; see its copyright file)
# The study used 26-s mono excerpts from 10 s in (past the intros), written beside the tracks as
# DIR/excerpts/*.ogg when python3 has the soundfile module.
# Six other tracks of the same packages go to DIR/tuning/ (and DIR/tuning/excerpts/): songs to choose
# sampler settings on, so that the six judging songs above stay unseen by every choice
# (hr3-motion, hr3-crossroads: Shawn Parrotte; hr-savino-ocean: Will Savino; hr-domina-mountain:
# Lincoln Domina, all CC BY-SA 3.0; SuperTux's forest-sprint and battle_theme: GPL-2+), and six more to
# DIR/tuning2/ for choices the first six leave tied (hr3-laboratory, hr3-icyland: Shawn Parrotte;
# hr-savino-ivory: Will Savino, CC BY-SA 3.0; SuperTux's salcon, fortress and tropicalbreeze: GPL-2+).
# Then, e.g.: qean sample --run qean-demo/runs/qean --music DIR/excerpts/hr3-desert.ogg --out dances
set -euo pipefail
out="${1:-songs}"
mkdir -p "$out"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
(cd "$work" && apt-get download hyperrogue-music supertux-data >/dev/null)
for deb in "$work"/*.deb; do
  dpkg-deb -x "$deb" "$work/x"
done
hr="$work/x/usr/share/hyperrogue/music"
st="$work/x/usr/share/games/supertux2/music"
for f in hr3-desert hr3-jungle hr-savino-caribbean hr-savino-palace hr-domina-hunting; do
  cp "$hr/$f.ogg" "$out/"
done
cp "$st/antarctic/chipdisko.ogg" "$out/"
mkdir -p "$out/tuning"
for f in hr3-motion hr3-crossroads hr-savino-ocean hr-domina-mountain; do
  cp "$hr/$f.ogg" "$out/tuning/"
done
cp "$st/forest/forest-sprint.ogg" "$st/misc/battle_theme.ogg" "$out/tuning/"
mkdir -p "$out/tuning2"
for f in hr3-laboratory hr3-icyland hr-savino-ivory; do
  cp "$hr/$f.ogg" "$out/tuning2/"
done
cp "$st/antarctic/salcon.ogg" "$st/castle/fortress.ogg" "$st/tropical/tropicalbreeze.ogg" "$out/tuning2/"
cp "$work/x/usr/share/doc/hyperrogue-music/copyright" "$out/hyperrogue-music.copyright"
cp "$work/x/usr/share/doc/supertux-data/copyright" "$out/supertux-data.copyright"
if python3 -c "import soundfile" 2>/dev/null; then
  mkdir -p "$out/excerpts"
  python3 - "$out" <<'PY'
import sys, pathlib, soundfile as sf
for out in [pathlib.Path(sys.argv[1]) / d for d in ["", "tuning", "tuning2"]]:
    (out / "excerpts").mkdir(exist_ok=True)
    for f in sorted(out.glob("*.ogg")):
        audio, sr = sf.read(f, always_2d=True)
        clip = audio[10 * sr : 36 * sr].mean(axis=1)
        tmp = out / "excerpts" / (f.stem + ".tmp.ogg")
        sf.write(tmp, clip, sr, format="OGG", subtype="VORBIS")
        tmp.rename(out / "excerpts" / f.name)
PY
  ls -1 "$out" "$out/excerpts" "$out/tuning/excerpts" "$out/tuning2/excerpts"
else
  ls -1 "$out" "$out/tuning" "$out/tuning2"
  echo "python3 has no soundfile module (pip install soundfile): the full tracks only, no excerpts" >&2
fi
