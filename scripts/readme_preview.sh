#!/usr/bin/env bash
# Regenerates docs/img/preview.png, the README's picture: the bake preview of
# examples/nest.toml (350 bees at a hive for ten seconds). Takes a few seconds.
#
#   scripts/readme_preview.sh
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
target/release/beeswarm bake examples/nest.toml --format csv --preview --out "$tmp" \
    --progress none --quiet
cp "$tmp/nest.preview.png" docs/img/preview.png
echo "wrote docs/img/preview.png"
