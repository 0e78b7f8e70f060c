#!/usr/bin/env bash
# Regenerate the README's figures from the example scenarios (one per paper
# figure, and the controlled virtual tests). Needs the release build: cargo
# build --release (or another host binary: HOST=path/to/host docs/figures/make.sh).
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
HOST="${HOST:-$ROOT/target/release/host}"
OUT="$(mktemp -d)"
FIG="$ROOT/docs/figures"
trap 'rm -rf "$OUT"' EXIT
for ex in sweep_rate_2pct sweep_rate_10pct level_1V level_5V level_10V frequency_error force_drop_2l3 force_drop_l3; do
  sed 's/^\[output\]//' "$ROOT/examples/fig_$ex.toml" > "$OUT/$ex.toml"
  printf '\n[output]\nfmus = false\ntime_series = false\n' >> "$OUT/$ex.toml"
  "$HOST" run "$OUT/$ex.toml" -o "$OUT/$ex" > "$OUT/$ex.log"
  cp "$OUT/$ex/sweep.svg" "$FIG/$ex.svg"
  echo "figure $ex.svg"
done
"$HOST" nma "$ROOT/examples/fig_backbone.toml" -o "$OUT/backbone" > "$OUT/backbone.log"
cp "$OUT/backbone/backbone.svg" "$FIG/backbone.svg"
cp "$OUT/backbone/damping.svg" "$FIG/damping.svg"
echo "figure backbone.svg, damping.svg"
# the controlled virtual tests (issue 16): name, example, files to copy (as name_file)
run_controlled() {
  local name="$1" ex="$2"; shift 2
  sed 's/^\[output\]//' "$ROOT/examples/$ex.toml" > "$OUT/$name.toml"
  printf '\n[output]\nfmus = false\ntime_series = false\n' >> "$OUT/$name.toml"
  "$HOST" run "$OUT/$name.toml" -o "$OUT/$name" > "$OUT/$name.log"
  for f in "$@"; do
    cp "$OUT/$name/$f.svg" "$FIG/$f.svg"
    echo "figure $f.svg"
  done
}
run_controlled pll phase_resonance phase_resonance_backbone phase_resonance_damping
run_controlled force force_controlled force_control
run_controlled response response_controlled response_control
run_controlled plan test_plan test_plan
# the paper's prospect: case (a) predicted from the measured modal table of the
# phase-resonance test (nlmode with the shaker model) against the reference
cat > "$OUT/prediction.toml" <<EOT
title = "Case (a) predicted from the measured modal table"
[run]
methods = ["reference", "nlmode"]
[[exciter]]
location = "2l/3"
[nma]
table = "$OUT/pll/modal_table.json"
[output]
fmus = false
time_series = false
EOT
"$HOST" run "$OUT/prediction.toml" -o "$OUT/prediction" > "$OUT/prediction.log"
cp "$OUT/prediction/sweep.svg" "$FIG/measured_table_prediction.svg"
echo "figure measured_table_prediction.svg"
