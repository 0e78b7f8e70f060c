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
# reads it): `dev` by default, whose units `cargo test --workspace` has just
# compiled (the test profile inherits dev unchanged), so nothing but the PyO3
# crates is compiled again; set NLMODE_CARGO_PROFILE=release to check the
# optimised build users ship. (Not `test`: maturin would build the module as
# a test harness.)
export NLMODE_CARGO_PROFILE="${NLMODE_CARGO_PROFILE:-dev}"
case "$NLMODE_CARGO_PROFILE" in
  dev|test) BUILD_DIR=target/debug ;;
  *) BUILD_DIR="target/$NLMODE_CARGO_PROFILE" ;;
esac
# the build puts libstructure.so / libshaker.so / libcontroller.so beside the
# host binary; host package = those cdylibs + the embedded modelDescriptions,
# READMEs and the paper beam's modal table in structure.fmu (host never runs cargo)
# `--workspace` as `cargo test --workspace`: the same members give the same
# feature resolution, so every unit cargo test compiled is reused. The PyO3
# variables are the ones maturin sets (below), so that maturin finds the
# native module's dependencies compiled too (if they differ, it recompiles
# the PyO3 crates: slower, same result).
PY_ABS="$ROOT/.venv/bin/python"
PYO3_ENVIRONMENT_SIGNATURE="$("$PY_ABS" -c 'import platform, struct, sys; v = sys.version_info; print("%s-%d.%d-%dbit" % (platform.python_implementation().lower(), v[0], v[1], struct.calcsize("P") * 8))')" \
PYO3_BUILD_EXTENSION_MODULE=1 PYO3_PYTHON="$PY_ABS" PYTHON_SYS_EXECUTABLE="$PY_ABS" \
  cargo build --quiet --profile "$NLMODE_CARGO_PROFILE" --workspace
echo "tests/run.sh: workspace built after ${SECONDS} s"
"$BUILD_DIR/host" package --fmi all --out "$FMU_DIR"
# the nlmode wheel: maturin builds python/ in the shared target/ with the same
# profile (only the PyO3 crates and the module itself are compiled)
rm -f target/wheels/nlmode-*.whl
.venv/bin/maturin build --quiet --profile "$NLMODE_CARGO_PROFILE" -m python/Cargo.toml -o target/wheels -i .venv/bin/python
.venv/bin/python -m pip install --quiet --disable-pip-version-check --force-reinstall --no-deps target/wheels/nlmode-*.whl
echo "tests/run.sh: wheel installed after ${SECONDS} s"
# the Python tests must find the wheel just installed (no silent skip)
export NLMODE_WHEEL=required
exec .venv/bin/python -m pytest tests --durations=12 "$@"
