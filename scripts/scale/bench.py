"""Scale benchmark (docs/performance.md, issue 27): for each size, write the
hexahedral cantilever plate (nlmode example `hex_plate`), reduce it with
nlmode's large-model path (example `reduce_mtx`: stage times and peak memory
per stage) and run scipy's shift-invert `eigsh` for the 10 lowest modes of the
same matrices, each under /usr/bin/time -v (wall, CPU, peak memory).

    python3 scripts/scale/bench.py [--profile release|dev] [--threads N] 100000 300000 1000000

Needs numpy and scipy (the venv of tests/run.sh has them). Models are cached
in $SCALE_DIR (default /tmp/nlmode-scale). A size whose memory estimate exceeds
the limit (75 % of MemAvailable, or --memory-limit-gb) is refused by nlmode
before factorising: the row says so. Timings are not asserted anywhere.
"""
import argparse
import json
import os
import re
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def timed(cmd, log):
    """Runs cmd under /usr/bin/time -v: (stdout, stderr, wall s, cpu s, peak GB)."""
    p = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True, cwd=ROOT)
    with open(log, "w") as f:
        f.write(p.stdout + "\n" + p.stderr)
    err = p.stderr

    def field(name):
        m = re.search(rf"{re.escape(name)}: (.*)", err)
        return m.group(1).strip() if m else "nan"

    wall = field("Elapsed (wall clock) time (h:mm:ss or m:ss)")
    parts = [float(x) for x in wall.split(":")] if wall != "nan" else [float("nan")]
    wall_s = sum(v * 60 ** i for i, v in enumerate(reversed(parts)))
    cpu_s = float(field("User time (seconds)")) + float(field("System time (seconds)"))
    peak_gb = float(field("Maximum resident set size (kbytes)")) * 1024 / 1e9
    return p.returncode, p.stdout, err, wall_s, cpu_s, peak_gb


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("sizes", nargs="*", type=int, default=[100_000, 300_000, 1_000_000])
    ap.add_argument("--profile", default="release")
    ap.add_argument("--threads", default="0")
    ap.add_argument("--memory-limit-gb", default=None)
    ap.add_argument("--no-scipy", action="store_true")
    ap.add_argument("--python", default=sys.executable)
    a = ap.parse_args()
    base = os.environ.get("SCALE_DIR", "/tmp/nlmode-scale")
    prof = ["--release"] if a.profile == "release" else ["--profile", a.profile]
    subprocess.run(["cargo", "build", "-q", "-p", "nlmode", *prof, "--example", "hex_plate",
                    "--example", "reduce_mtx"], check=True, cwd=ROOT)
    tdir = "release" if a.profile == "release" else ("debug" if a.profile == "dev" else a.profile)
    exe = lambda name: os.path.join(ROOT, "target", tdir, "examples", name)
    rows = []
    for size in a.sizes:
        d = os.path.join(base, f"plate{size}")
        if not os.path.exists(os.path.join(d, "points.json")):
            subprocess.run([exe("hex_plate"), "--dofs", str(size), "--out", d], check=True)
        cmd = [exe("reduce_mtx"), d, "--threads", a.threads]
        if a.memory_limit_gb:
            cmd += ["--memory-limit-gb", a.memory_limit_gb]
        rc, out, err, wall, cpu, peak = timed(cmd, os.path.join(d, "reduce.log"))
        print(err.split("\tCommand being timed")[0], file=sys.stderr)
        if rc != 0:
            rows.append((size, f"nlmode refused/failed (exit {rc}): {err.splitlines()[0]}"))
            continue
        res = json.loads(out.strip().splitlines()[-1])
        row = {"ndof": res["ndof"], "wall_s": wall, "cpu_s": cpu, "peak_gb": peak,
               "read_s": res["read_s"], **{k: v for k, v in res["timings"].items()},
               "omega0_rad_s": res["omega0_rad_s"]}
        if not a.no_scipy:
            rc, out, err, swall, scpu, speak = timed(
                [a.python, os.path.join(ROOT, "scripts/scale/scipy_eigsh.py"), d],
                os.path.join(d, "scipy.log"))
            if rc == 0:
                s = json.loads(out.strip().splitlines()[-1])
                row.update(scipy_wall_s=swall, scipy_cpu_s=scpu, scipy_peak_gb=speak,
                           scipy_eigsh_s=s["eigsh_s"], scipy_omega0_rad_s=s["omega_rad_s"][0],
                           omega0_rel_diff=abs(s["omega_rad_s"][0] - row["omega0_rad_s"])
                           / s["omega_rad_s"][0])
            else:
                row.update(scipy=f"failed (exit {rc})")
        rows.append((size, row))
        print(json.dumps(row))
    print("\n| DOFs | wall s | CPU s | peak GB | read | order | factor | eigen | constraint | "
          "nnz(L) | scipy eigsh s | scipy peak GB | omega0 rel. diff |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for size, r in rows:
        if isinstance(r, str):
            print(f"| {size} | {r} |")
            continue
        g = lambda k, f="{:.1f}": f.format(r[k]) if k in r else "-"
        print(f"| {r['ndof']} | {g('wall_s')} | {g('cpu_s')} | {g('peak_gb', '{:.2f}')} | "
              f"{g('read_s')} | {g('order_s')} | {g('factor_s')} | {g('eigen_s')} | "
              f"{g('constraint_modes_s', '{:.2f}')} | {g('factor_nnz', '{:.3g}')} | "
              f"{g('scipy_eigsh_s')} | {g('scipy_peak_gb', '{:.2f}')} | "
              f"{g('omega0_rel_diff', '{:.1e}')} |")


if __name__ == "__main__":
    main()
