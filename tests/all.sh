#!/usr/bin/env bash
# Run every test of the repository: the Rust workspace (unit, integration and
# doc tests) and the fmpy harness that checks each FMU on its own (it creates
# its own Python venv in .venv and pins its versions, see tests/requirements.txt).
set -euo pipefail
cd "$(dirname "$0")/.."
# A from-scratch build gains nothing from incremental compilation's caches
# (only their cost): off for this run and the harness's builds (inherited),
# which then also use rustc's default of 16 codegen units per crate.
export CARGO_INCREMENTAL="${CARGO_INCREMENTAL:-0}"
echo "== cargo test (workspace; the test profile optimises the numerics)"
cargo test --workspace 2>&1
echo "== cargo test done after ${SECONDS} s"
# nlmode's METIS nested dissection is an opt-in feature that the workspace
# build leaves out: the sparse path's unit tests again with it
echo "== cargo test -p nlmode --features metis (the sparse path with nested dissection)"
cargo test -p nlmode --features metis --lib structure:: 2>&1
echo "== nested-dissection tests done after ${SECONDS} s"
if [ -x tests/run.sh ]; then
  echo "== fmpy harness (the binaries of the test profile, already built)"
  ./tests/run.sh
  echo "== fmpy harness done after ${SECONDS} s"
fi
