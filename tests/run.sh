#!/usr/bin/env bash
# The Python harness: creates .venv at the repository root if missing, installs
# the pinned requirements, packages the FMUs into target/fmus, builds the
# nlmode wheel (python/, maturin, in the workspace's target dir) into the venv
# and runs pytest (the fmpy tests of the FMUs, the nlmode package, Dask).
# Extra arguments go to pytest (e.g. tests/run.sh -k shaker -x).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$ROOT"
PY="${PYTHON:-}"
if [ -z "$PY" ]; then
  if command -v python3.11 >/dev/null 2>&1; then PY=python3.11; else PY=python3; fi
fi
if [ ! -x .venv/bin/python ]; then
  "$PY" -m venv .venv
fi
.venv/bin/python -m pip install --quiet --disable-pip-version-check -r tests/requirements.txt
export FMU_DIR="${FMU_DIR:-$ROOT/target/fmus}"
# Every binary the harness runs is built with one cargo profile (conftest.py
# reads it): `test` by default, the profile `cargo test --workspace` has just
# compiled, so nothing but the PyO3 crates is compiled again; set
# NLMODE_CARGO_PROFILE=release to check the optimised build users ship.
export NLMODE_CARGO_PROFILE="${NLMODE_CARGO_PROFILE:-test}"
case "$NLMODE_CARGO_PROFILE" in
  dev|test) BUILD_DIR=target/debug ;;
  *) BUILD_DIR="target/$NLMODE_CARGO_PROFILE" ;;
esac
# the build puts libstructure.so / libshaker.so / libcontroller.so beside the
# host binary; host package = those cdylibs + the embedded modelDescriptions,
# READMEs and the paper beam's modal table in structure.fmu (host never runs cargo)
cargo build --quiet --profile "$NLMODE_CARGO_PROFILE"
"$BUILD_DIR/host" package --out "$FMU_DIR"
# the nlmode wheel: maturin builds python/ in the shared target/ with the same
# profile (only the PyO3 crates and the module itself are compiled)
rm -f target/wheels/nlmode-*.whl
.venv/bin/maturin build --quiet --profile "$NLMODE_CARGO_PROFILE" -m python/Cargo.toml -o target/wheels -i .venv/bin/python
.venv/bin/python -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps target/wheels/nlmode-*.whl
exec .venv/bin/python -m pytest tests --durations=12 "$@"
