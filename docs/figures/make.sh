#!/usr/bin/env bash
# Regenerate the README's figures from the example scenarios (one per paper
# figure). Needs the release build: cargo build --release
set -euo pipefail
ROOT="$(cd "$(dirname "$0")/../.." && pwd)"
HOST="$ROOT/target/release/host"
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
