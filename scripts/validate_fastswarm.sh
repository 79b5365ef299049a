#!/usr/bin/env bash
# Reproduces docs/validation.md, "FASTSWARM (paper 003)": paper 003's claim that its flight
# statistics are closer to real data than a force-based model's, tested on held-out flights.
#
# The mosquito recording's segments are split in two by `--part` (ids numbered in order of
# first appearance; even ones part 0/2, odd ones part 1/2). FASTSWARM's database is built
# from part 0/2 only; fastswarm, the calibrated bee model (presets/mosquito_cage.toml) and
# the calibrated zonal model of paper 002 (presets/mosquito_cage_zonal.toml) are baked on
# eight held-out seeds each and compared with part 1/2, the flights the database never saw.
#
#   scripts/validate_fastswarm.sh        # about 5 s on 2 cores after the build; not part of CI
#
# Writes out/validation_fastswarm/* and docs/validation_fastswarm_table.md.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=out/validation_fastswarm
source scripts/validation_common.sh
mkdir -p "$OUT"

# 1. The database from the even-numbered recorded segments only.
"$BIN" fastswarm-db "$REAL" --part 0/2 --out "$OUT/mosquito_db_part0.csv" \
    --note "From the even-numbered segments of ../shared/data/mosquito_flights.csv (GPL-3.0)."

# 2. The shots. The bee model flies examples/mosquito_cage.toml as calibrated (with the
#    landing surface, as in docs/validation.md's main table); the others fly the bare cage
#    (scripts/validate.sh: the surface only makes models without it worse). fastswarm steps
#    at the database's 0.02 s (one substep at 50 fps) with Table 1's aggregation weights.
bare=(-e '/^params = /d' -e '/^# --- landing surface/,/^# --- end of landing surface/d')
sed -e 's#^preset = .*#preset = "'"$ROOT"'/presets/mosquito_cage.toml"#' \
    examples/mosquito_cage.toml > "$OUT/mosquito_cage.toml"
sed -e 's#^model = "bee"#model = "zonal"#' \
    -e 's#^preset = .*#preset = "'"$ROOT"'/presets/mosquito_cage_zonal.toml"#' \
    -e 's#^name = "mosquito_cage"#name = "mosquito_cage_zonal"#' "${bare[@]}" \
    examples/mosquito_cage.toml > "$OUT/mosquito_cage_zonal.toml"
sed -e 's#^model = "bee"#model = "fastswarm"\ndatabase = "mosquito_db_part0.csv"#' \
    -e 's#^preset = .*#preset = "aggregation"#' \
    -e 's#^name = "mosquito_cage"#name = "mosquito_cage_fastswarm"#' \
    -e 's#^substeps = 4#substeps = 1#' "${bare[@]}" \
    examples/mosquito_cage.toml > "$OUT/mosquito_cage_fastswarm.toml"

# 3. Bake on the held-out seeds; each run's tracks kept as <name>.seed<N>.tracks.csv.
declare -A runs
for seed in $EVAL_SEEDS; do
    for name in mosquito_cage mosquito_cage_zonal mosquito_cage_fastswarm; do
        "$BIN" bake "$OUT/$name.toml" --out "$OUT" --seed "$seed" --progress none --quiet
        mv "$OUT/$name.tracks.csv" "$OUT/$name.seed$seed.tracks.csv"
        runs[$name]+="${runs[$name]:+,}$OUT/$name.seed$seed.tracks.csv"
    done
done

# 4. Compare with the odd-numbered segments, each model's runs pooled.
"$BIN" eval "bee=${runs[mosquito_cage]}" \
    --candidate "zonal=${runs[mosquito_cage_zonal]}" \
    --candidate "fastswarm=${runs[mosquito_cage_fastswarm]}" \
    --reference "$REAL" --reference-part 1/2 --out "$OUT/report.json" \
    --figure "$OUT/fastswarm_validation.png" --markdown docs/validation_fastswarm_table.md
