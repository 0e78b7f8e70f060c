#!/usr/bin/env bash
# Output check for restructures: every output of `host run` (the default
# scenario and every examples/*.toml that `host run` accepts), `host nma` and
# `host frf` (default scenario) must stay byte-identical, except the timing
# fields of the JSON files (`wall_time_s`, `*_wall_time_s`, `*_s` timings
# listed in TIMING_KEYS, `speedup_nlmode_over_reference`).
#
#   scripts/check_outputs.sh produce HOST_BIN OUT_DIR [FMU_DIR]
#       runs the binary HOST_BIN into OUT_DIR/<case>/ (stdout, stderr and the
#       exit code of each run kept in OUT_DIR/<case>.log / .rc). FMU_DIR holds
#       libstructure.so and libshaker.so for `cosim` (default: beside HOST_BIN).
#   scripts/check_outputs.sh compare DIR_A DIR_B
#       byte comparison of two OUT_DIRs (the same files, the same bytes; JSON
#       files up to the timing fields; packaged .fmu archives by their members'
#       contents). Exit 0 if identical, 1 otherwise (the differing files listed).
#   scripts/check_outputs.sh check OUT_DIR BASELINE_DIR [HOST_BIN [FMU_DIR]]
#       produce with HOST_BIN (default: target/debug/host, built by
#       `cargo build -p host -p fmu-structure -p fmu-shaker`) then compare.
#
# Skipped (more than ~2 minutes each with the dev profile): none of `host run`'s
# examples today except those listed in SKIP below. examples/study_lhs.toml is a
# study file (`host study`), not a scenario.
set -uo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SKIP=" study_lhs "
TIMING_KEYS='["wall_time_s","speedup_nlmode_over_reference","nma_wall_time_s","structure_wall_time_s","steady_state_wall_time_s","table_wall_time_s"]'

produce() {
  local bin="$1" out="$2" fmu="${3:-$(dirname "$1")}"
  mkdir -p "$out"
  local cases=("default:")
  for f in "$ROOT"/examples/*.toml; do
    local n; n="$(basename "$f" .toml)"
    case "$SKIP" in *" $n "*) continue ;; esac
    cases+=("$n:$f")
  done
  for c in "${cases[@]}"; do
    local n="${c%%:*}" f="${c#*:}"
    local t0=$SECONDS
    rm -rf "${out:?}/run_$n"
    # run from the repository root (relative paths in messages stay the same)
    (cd "$ROOT" && "$bin" run ${f:+"$f"} -o "$out/run_$n" --fmu-dir "$fmu") \
      >"$out/run_$n.log" 2>&1
    echo $? >"$out/run_$n.rc"
    echo "run $n: exit $(cat "$out/run_$n.rc") in $((SECONDS - t0)) s"
  done
  for cmd in nma frf; do
    local t0=$SECONDS
    rm -rf "${out:?}/${cmd}_default"
    (cd "$ROOT" && "$bin" "$cmd" -o "$out/${cmd}_default") >"$out/${cmd}_default.log" 2>&1
    echo $? >"$out/${cmd}_default.rc"
    echo "$cmd default: exit $(cat "$out/${cmd}_default.rc") in $((SECONDS - t0)) s"
  done
}

# JSON without the timing keys, the keys in the file's order (so the order is
# compared too).
normalize_json() {
  jq --argjson keys "$TIMING_KEYS" \
    'walk(if type == "object" then with_entries(select(.key as $k | $keys | index($k) | not)) else . end)' "$1"
}

# A zip archive as the sorted list of (member, sha256 of its content).
zip_digest() {
  python3 - "$1" <<'PY'
import hashlib, sys, zipfile
with zipfile.ZipFile(sys.argv[1]) as z:
    for n in sorted(z.namelist()):
        print(n, hashlib.sha256(z.read(n)).hexdigest())
PY
}

compare() {
  local a="$1" b="$2" bad=0
  # the same set of files (the logs aside: they print timings)
  local la lb
  la="$(cd "$a" && find . -type f ! -name '*.log' | sort)"
  lb="$(cd "$b" && find . -type f ! -name '*.log' | sort)"
  if [ "$la" != "$lb" ]; then
    echo "DIFFERENT FILE SETS:"; diff <(echo "$la") <(echo "$lb"); bad=1
  fi
  local n=0
  while IFS= read -r f; do
    [ -f "$b/$f" ] || continue
    n=$((n + 1))
    case "$f" in
      *.json)
        if ! cmp -s <(normalize_json "$a/$f") <(normalize_json "$b/$f"); then
          echo "DIFFERS (json up to timings): $f"; bad=1
        fi ;;
      *.fmu)
        if ! cmp -s <(zip_digest "$a/$f") <(zip_digest "$b/$f"); then
          echo "DIFFERS (fmu members): $f"; bad=1
        fi ;;
      *)
        if ! cmp -s "$a/$f" "$b/$f"; then echo "DIFFERS: $f"; bad=1; fi ;;
    esac
  done <<<"$la"
  if [ $bad = 0 ]; then echo "identical: $n files"; fi
  return $bad
}

case "${1:-}" in
  produce) shift; produce "$@" ;;
  compare) shift; compare "$@" ;;
  check)
    shift
    out="$1" base="$2" bin="${3:-$ROOT/target/debug/host}" fmu="${4:-}"
    produce "$bin" "$out" ${fmu:+"$fmu"} && compare "$out" "$base" ;;
  *) sed -n '2,22p' "$0"; exit 2 ;;
esac
