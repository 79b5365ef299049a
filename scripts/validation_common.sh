# Sourced by scripts/validate*.sh from the repository root: what every comparison with the
# mosquito recording shares. Sets ROOT, REAL (the recording; override with REAL=...),
# EVAL_SEEDS and BIN (the release binary, built here); exits 2 if the recording is missing.
ROOT=$PWD
REAL=${REAL:-$ROOT/../shared/data/mosquito_flights.csv}
# Held-out runs pooled per model: one 60 s run of four insects is too small a sample (the
# speed ΔE of one preset varies from 0.11 to 0.46 between seeds, docs/validation.md).
EVAL_SEEDS=${EVAL_SEEDS:-2026 2027 2028 2029 2030 2031 2032 2033}
if [ ! -f "$REAL" ]; then
    echo "$(basename "$0"): the mosquito recording is not at $REAL (set REAL=...)" >&2
    exit 2
fi
cargo build --release --quiet
BIN=$ROOT/target/release/beeswarm
