#!/usr/bin/env bash
# Rebuilds render/assets/viewer.bundle.js from render/viewer/viewer.js and three.js (npm, MIT): one minified
# script that `qean view` embeds in its pages. Needs node and npm (the npm registry); run after changing viewer.js.
set -euo pipefail
cd "$(dirname "$0")/.."
work=target/viewer-build
mkdir -p "$work"
npm install --silent --prefix "$work" three@0.187.0 esbuild@0.25 >/dev/null
cp render/viewer/viewer.js "$work/viewer.js"
{
  echo "/* qean view. Includes three.js r187 (https://threejs.org), MIT License:"
  sed 's/^/ * /' "$work/node_modules/three/LICENSE"
  echo " */"
  "$work/node_modules/.bin/esbuild" "$work/viewer.js" --bundle --minify --format=iife --log-level=warning \
    --legal-comments=none
} > render/assets/viewer.bundle.js
echo "wrote render/assets/viewer.bundle.js ($(wc -c < render/assets/viewer.bundle.js) bytes)"
