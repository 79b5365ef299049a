#!/usr/bin/env bash
# Reproduces docs/validation.md: calibrates the bee model and the two baselines on the
# mosquito recording, bakes each on eight seeds the calibration never saw, and compares
# all three, each pooled over those seeds, with the recording in one report and one figure.
#
#   scripts/validate.sh                 # full run (200 generations, about 5 minutes on 2 cores)
#   GENERATIONS=20 scripts/validate.sh  # a quick look
#   CALIBRATE=0 scripts/validate.sh     # keep the checked-in bee and zonal presets: re-bake
#                                       # and re-evaluate only (the baselines and the
#                                       # zonal model's noise variants are refitted)
#   CALIBRATE=0 ZONAL_CALIBRATE=1 ...   # refit the zonal model only
#   BASELINES=0 ...                     # skip the baselines; the tables then go to
#                                       # out/validation/ instead of docs/ (a quick look)
#
# Writes presets/mosquito_cage.toml, presets/mosquito_cage_zonal.toml,
# docs/img/mosquito_validation.png, docs/img/mosquito_cage_fitness.png (and .csv: its data,
# which `beeswarm fitness-figure` draws again without calibrating), the zonal model's the same,
# docs/validation_table.md, docs/validation_noise_table.md and out/validation/*.
set -euo pipefail
cd "$(dirname "$0")/.."
GENERATIONS=${GENERATIONS:-200}
BASELINE_GENERATIONS=${BASELINE_GENERATIONS:-30}
GA_SEED=${GA_SEED:-1}
CALIBRATE=${CALIBRATE:-1}
ZONAL_CALIBRATE=${ZONAL_CALIBRATE:-$CALIBRATE}
ZONAL_GENERATIONS=${ZONAL_GENERATIONS:-40}
NOISE_GENERATIONS=${NOISE_GENERATIONS:-20}
BASELINES=${BASELINES:-1}
if [ "$BASELINES" != 0 ]; then
    TABLES=docs; FIGURE=docs/img/mosquito_validation.png
else
    TABLES=out/validation; FIGURE=out/validation/mosquito_validation.png
fi
SEEDS=${SEEDS:-4}              # simulation runs pooled per individual (seeds 11, 12, ...)
OUT=out/validation
source scripts/validation_common.sh
mkdir -p "$OUT" docs/img

# The example shot with another model and preset; paths made absolute so the copy works
# from out/validation. The baselines fly the bare cage: without the landing surface and
# its 5 cm avoidance distance, which only make them worse (docs/validation.md), so they
# are compared at their best.
variant() { # model preset > shot
    local bare=()
    [ "$1" = bee ] || bare=(-e '/^params = /d' -e '/^# --- landing surface/,/^# --- end of landing surface/d')
    sed -e "s#^model = \"bee\"#model = \"$1\"#" \
        -e "s#^preset = .*#preset = \"$2\"#" \
        -e "s#^name = \"mosquito_cage\"#name = \"mosquito_cage_$1\"#" \
        "${bare[@]}" examples/mosquito_cage.toml
}

# 1. Calibrate. Every model starts from its default preset ("nest" for the bee model); the bee model fits
#    Γ = {κ1, κ2, κ3, L, ε, h} and the speed (d0 is set by the shot), the baselines
#    (which read only the speed) fit the speed.
variant bee nest > "$OUT/calibrate_bee.toml"
if [ "$CALIBRATE" != 0 ]; then
    "$BIN" calibrate --reference "$REAL" --shot "$OUT/calibrate_bee.toml" \
        --only kappa1,kappa2,kappa3,noise_cell,noise_gain,neighbour_radius,speed,heading_lag \
        --out presets/mosquito_cage.toml --name mosquito_cage \
        --generations "$GENERATIONS" --population 10 --seed "$GA_SEED" --seeds "$SEEDS" \
        --figure docs/img/mosquito_cage_fitness.png --progress bar
fi
BASELINE_MODELS="brownian boids"
[ "$BASELINES" != 0 ] || BASELINE_MODELS=""
for m in $BASELINE_MODELS; do
    variant "$m" default > "$OUT/calibrate_$m.toml"
    "$BIN" calibrate --reference "$REAL" --shot "$OUT/calibrate_$m.toml" \
        --out "$OUT/mosquito_cage_$m.preset.toml" --name "mosquito_cage_$m" --only speed \
        --generations "$BASELINE_GENERATIONS" --population 10 --seed "$GA_SEED" --seeds "$SEEDS" --progress none
done

# 1b. The zonal model (paper 002) fits the seven parameters the paper estimates from its
#     recordings (γ, scale, gain, χ_rep, r_rep, χ_att, r_att*) from Table 1's "midge"
#     column, in the bare cage like the baselines. Then paper 002's noise comparison
#     (Fig. 10): the same dynamics with white, Gaussian and Perlin noise instead of curl
#     noise, each refitting only the noise's own parameters (scale and gain), as the
#     paper does.
variant zonal midge > "$OUT/calibrate_zonal.toml"
if [ "$ZONAL_CALIBRATE" != 0 ]; then
    "$BIN" calibrate --reference "$REAL" --shot "$OUT/calibrate_zonal.toml" \
        --only gamma,scale,gain,chi_rep,r_rep,chi_att,r_att_star \
        --out presets/mosquito_cage_zonal.toml --name mosquito_cage_zonal \
        --figure docs/img/mosquito_cage_zonal_fitness.png \
        --generations "$ZONAL_GENERATIONS" --population 10 --seed "$GA_SEED" --seeds "$SEEDS" --progress none
fi
# A zonal shot on a preset, with noise kind N (0 curl, 1 white, 2 Gaussian, 3 Perlin).
zonal_variant() { # preset noise name > shot
    variant zonal "$1" | sed -e "s#^name = \"mosquito_cage_zonal\"#name = \"$3\"#" \
        -e "s#^preset = \(.*\)#preset = \1\nparams = { noise = $2 }#"
}
NOISES="white:1 gaussian:2 perlin:3"
for kv in $NOISES; do
    kind=${kv%%:*}
    zonal_variant "$ROOT/presets/mosquito_cage_zonal.toml" "${kv##*:}" "mosquito_cage_zonal_$kind" \
        > "$OUT/calibrate_zonal_$kind.toml"
    "$BIN" calibrate --reference "$REAL" --shot "$OUT/calibrate_zonal_$kind.toml" \
        --out "$OUT/mosquito_cage_zonal_$kind.preset.toml" --name "mosquito_cage_zonal_$kind" \
        --only scale,gain --generations "$NOISE_GENERATIONS" --population 10 --seed "$GA_SEED" \
        --seeds "$SEEDS" --progress none
    zonal_variant "$ROOT/$OUT/mosquito_cage_zonal_$kind.preset.toml" "${kv##*:}" "mosquito_cage_zonal_$kind" \
        > "$OUT/mosquito_cage_zonal_$kind.toml"
done
variant zonal "$ROOT/presets/mosquito_cage_zonal.toml" > "$OUT/mosquito_cage_zonal.toml"

# 2. Bake on the held-out seeds: the checked-in example for the bee model, variants for
#    the baselines. Each run's tracks are kept as <name>.seed<N>.tracks.csv.
baseline_shots=()
for m in $BASELINE_MODELS; do
    variant "$m" "$ROOT/$OUT/mosquito_cage_$m.preset.toml" > "$OUT/mosquito_cage_$m.toml"
    baseline_shots+=("$OUT/mosquito_cage_$m.toml")
done
declare -A runs
for seed in $EVAL_SEEDS; do
    for shot in examples/mosquito_cage.toml "${baseline_shots[@]}" \
        "$OUT/mosquito_cage_zonal.toml" "$OUT"/mosquito_cage_zonal_{white,gaussian,perlin}.toml; do
        name=$(basename "$shot" .toml)
        "$BIN" bake "$shot" --out "$OUT" --seed "$seed" --progress none --quiet
        mv "$OUT/$name.tracks.csv" "$OUT/$name.seed$seed.tracks.csv"
        runs[$name]+="${runs[$name]:+,}$OUT/$name.seed$seed.tracks.csv"
    done
done

# 3. Compare, each model's runs pooled (eval measures each run on its own, then pools).
candidates=()
for m in $BASELINE_MODELS; do
    candidates+=(--candidate "$m=${runs[mosquito_cage_$m]}")
done
"$BIN" eval "calibrated=${runs[mosquito_cage]}" "${candidates[@]}" \
    --candidate "zonal=${runs[mosquito_cage_zonal]}" \
    --reference "$REAL" --out "$OUT/report.json" \
    --figure "$FIGURE" --markdown "$TABLES/validation_table.md"

# 4. Paper 002's noise comparison on the same held-out seeds.
"$BIN" eval "curl=${runs[mosquito_cage_zonal]}" \
    --candidate "white=${runs[mosquito_cage_zonal_white]}" \
    --candidate "gaussian=${runs[mosquito_cage_zonal_gaussian]}" \
    --candidate "perlin=${runs[mosquito_cage_zonal_perlin]}" \
    --reference "$REAL" --out "$OUT/noise_report.json" --markdown "$TABLES/validation_noise_table.md"
