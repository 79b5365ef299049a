#!/usr/bin/env bash
# Issue 17: the calibrated mosquito preset keeps its score when the substeps change.
# Bakes examples/mosquito_cage.toml at 2, 4 (the example's own), 8 and 16 substeps per
# frame on the eight held-out seeds of scripts/validate.sh and compares each, pooled, with
# the recording. About 20 s on 2 cores after the build; not part of CI (it needs the
# recording). Writes out/validation_substeps/table.md (quoted in docs/validation.md).
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=out/validation_substeps
source scripts/validation_common.sh
rm -rf "$OUT"
mkdir -p "$OUT"
first=""
others=()
for s in 4 2 8 16; do
    # The example with another substep count; its preset path made absolute for the copy.
    sed -e "s#^substeps = 4#substeps = $s#" -e "s#^preset = \"\.\./presets/#preset = \"$ROOT/presets/#" \
        examples/mosquito_cage.toml > "$OUT/substeps_$s.toml"
    grep -q "^substeps = $s" "$OUT/substeps_$s.toml"
    runs=""
    for seed in $EVAL_SEEDS; do
        "$BIN" bake "$OUT/substeps_$s.toml" --out "$OUT/s$s" --seed "$seed" --format csv \
            --progress none --quiet
        mv "$OUT/s$s/mosquito_cage.tracks.csv" "$OUT/s$s/seed$seed.tracks.csv"
        runs+="${runs:+,}$OUT/s$s/seed$seed.tracks.csv"
    done
    if [ -z "$first" ]; then first="substeps_4=$runs"; else others+=(--candidate "substeps_$s=$runs"); fi
done
"$BIN" eval "$first" "${others[@]}" --reference "$REAL" --out "$OUT/report.json" \
    --markdown "$OUT/table.md"
