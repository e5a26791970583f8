#!/bin/sh
# Rebuild src/dloplan/plots/vendor/three.min.js: the classes of three.js the report's viewer
# uses (tools/three_bundle.js), tree-shaken and minified by esbuild into one classic script
# that defines the global THREE, so the report stays one offline HTML file. Run by hand when
# three.js is updated (never at test time); needs node and npm (the npm registry).
set -eu
THREE_VERSION=0.187.0
ESBUILD_VERSION=0.28.2
here=$(cd "$(dirname "$0")" && pwd)
out="$here/../src/dloplan/plots/vendor"
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
cd "$work"
npm init -y >/dev/null
npm install --no-audit --no-fund --silent "three@$THREE_VERSION" "esbuild@$ESBUILD_VERSION"
cp "$here/three_bundle.js" entry.js
{
  printf '/* three.js %s (threejs.org, MIT licence: LICENSE-three.js), the parts the\n' \
    "$THREE_VERSION"
  printf '   dloplan report uses, bundled by tools/build_three_bundle.sh with esbuild %s */\n' \
    "$ESBUILD_VERSION"
  ./node_modules/.bin/esbuild entry.js --bundle --minify --format=iife --global-name=THREE \
    --legal-comments=none --target=es2020
} > "$out/three.min.js"
cp node_modules/three/LICENSE "$out/LICENSE-three.js"
ls -l "$out/three.min.js"
