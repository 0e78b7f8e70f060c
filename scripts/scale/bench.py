"""Scale benchmark (docs/performance.md, issue 27): for each size, write the
hexahedral cantilever plate (nlmode example `hex_plate`), run `host nma` on it
once per fill-reducing ordering (`[structure] ordering`: stage times, CPU and
peak memory per stage from modal_table.json's `provenance`) and scipy's
shift-invert `eigsh` for the 10 lowest modes of the same matrices, each under
/usr/bin/time -v (wall, CPU, peak memory of the whole run), and nlmode's own
10 lowest modes of the same matrices (nlmode example `lowest_modes`: ordering,
factorisation and Lanczos alone), the work of `eigsh`. Two ratios to scipy:
the whole `host nma` run against scipy's whole script, and `lowest_modes`'
eigen-analysis against `eigsh` alone (both without reading the files).
With `--repeat N` the two eigen-analyses run N times each, alternately (ours,
scipy's, ours, ...: a change of the machine's load falls on both), and the
tables give the medians and the range of the N pairwise ratios.

    python3 scripts/scale/bench.py [--profile release|dev] [--orderings amd,nested-dissection]
                                   [--no-scipy] [--repeat N] 100000 300000 1000000

Needs numpy and scipy (the venv of tests/run.sh has them). Models are cached
in $SCALE_DIR (default /tmp/nlmode-scale). A size whose memory estimate exceeds
the limit (75 % of MemAvailable, or --memory-limit-gb) is refused by the host
before factorising (exit 2): the row says so. Timings are not asserted anywhere.
"""
import argparse
import json
import os
import re
import resource
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def timed(cmd, log, limit_gb=None):
    """Runs cmd under /usr/bin/time -v (its address space capped at limit_gb):
    (exit code, stdout, stderr, wall s, cpu s, peak GB)."""
    def cap():
        if limit_gb:
            lim = int(float(limit_gb) * 1e9)
            resource.setrlimit(resource.RLIMIT_AS, (lim, lim))
    p = subprocess.run(["/usr/bin/time", "-v", *cmd], capture_output=True, text=True, cwd=ROOT,
                       preexec_fn=cap)
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


def scenario_with(src, dst, ordering, limit_gb):
    """plate.toml with `ordering` (and `memory_limit_gb`) under [structure]."""
    text = open(src).read()
    extra = f'ordering = "{ordering}"\n'
    if limit_gb:
        extra += f"memory_limit_gb = {limit_gb}\n"
    text = text.replace("[structure]\n", "[structure]\n" + extra, 1)
    with open(dst, "w") as f:
        f.write(text)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("sizes", nargs="*", type=int, default=[100_000, 300_000, 1_000_000])
    ap.add_argument("--profile", default="release")
    ap.add_argument("--orderings", default="amd,nested-dissection")
    ap.add_argument("--memory-limit-gb", default=None)
    ap.add_argument("--no-scipy", action="store_true")
    ap.add_argument("--scipy-limit-gb", default="16",
                    help="address-space cap of the scipy run (it has no memory estimate)")
    ap.add_argument("--python", default=sys.executable)
    ap.add_argument("--repeat", type=int, default=1,
                    help="runs of lowest_modes and of scipy's eigsh per size (medians reported)")
    a = ap.parse_args()
    if a.repeat < 1:
        ap.error("--repeat must be at least 1")
    base = os.environ.get("SCALE_DIR", "/tmp/nlmode-scale")
    prof = ["--release"] if a.profile == "release" else ["--profile", a.profile]
    subprocess.run(["cargo", "build", "-q", *prof, "-p", "nlmode", "--example", "hex_plate"],
                   check=True, cwd=ROOT)
    subprocess.run(["cargo", "build", "-q", *prof, "-p", "host", "--features", "metis", "--bin", "host"],
                   check=True, cwd=ROOT)
    subprocess.run(["cargo", "build", "-q", *prof, "-p", "nlmode", "--features", "metis",
                    "--example", "lowest_modes"], check=True, cwd=ROOT)
    tdir = "release" if a.profile == "release" else ("debug" if a.profile == "dev" else a.profile)
    exe = lambda name: os.path.join(ROOT, "target", tdir, name)
    rows = []
    for size in a.sizes:
        d = os.path.join(base, f"plate{size}")
        if not os.path.exists(os.path.join(d, "points.json")):
            subprocess.run([exe("examples/hex_plate"), "--dofs", str(size), "--out", d], check=True)
        for ordering in a.orderings.split(","):
            sc = os.path.join(d, f"plate_{ordering}.toml")
            scenario_with(os.path.join(d, "plate.toml"), sc, ordering, a.memory_limit_gb)
            out = os.path.join(d, f"nma_{ordering}")
            rc, _, err, wall, cpu, peak = timed([exe("host"), "nma", sc, "-o", out],
                                                os.path.join(d, f"nma_{ordering}.log"))
            if rc != 0:
                msg = next((l for l in err.splitlines() if "error" in l.lower()), "see the log")
                rows.append((size, ordering, f"host nma failed (exit {rc}): {msg}"))
                continue
            table = json.load(open(os.path.join(out, "modal_table.json")))
            t = table["provenance"]["structure_stages"]
            row = {"ndof": table["provenance"]["full_ndof"], "ordering": t["ordering"],
                   "wall_s": wall, "cpu_s": cpu, "peak_gb": peak,
                   "omega0_rad_s": table["provenance"]["omega0_rad_s"], **t}
            rows.append((size, ordering, row))
            print(json.dumps(row), flush=True)
        eigen, scipy_runs = [], []
        for r in range(a.repeat):
            eigen.append(eigen_only(exe, d, a.orderings.split(",")[-1], r))
            if not a.no_scipy:
                scipy_runs.append(scipy_eigsh(a, d, r))
        for label, runs in (("eigen-only", eigen), ("scipy", scipy_runs)):
            if not runs:
                continue
            failed = next((x for x in runs if isinstance(x, str)), None)
            row = failed or merge_runs(runs)
            rows.append((size, label, row))
            print(json.dumps(row), flush=True)
    print("\n| DOFs | ordering | wall s | CPU s | peak GB | read | order | factor | eigen | "
          "constraint | nnz(L) | estimate GB | omega0 rad/s | vs scipy |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    scipy = {size: r["scipy_omega0_rad_s"] for size, o, r in rows
             if o == "scipy" and isinstance(r, dict)}
    for size, ordering, r in rows:
        if isinstance(r, str):
            print(f"| {size} | {ordering} | {r} |")
            continue
        if ordering in ("scipy", "eigen-only"):
            continue
        g = lambda k, f="{:.1f}": f.format(r[k]) if k in r else "-"
        w, s = r["omega0_rad_s"], scipy.get(size)
        diff = f"{abs(w - s) / s:.1e}" if s else "-"
        print(f"| {r['ndof']} | {r['ordering']} | {g('wall_s')} | {g('cpu_s')} | "
              f"{g('peak_gb', '{:.2f}')} | {g('read_s')} | {g('order_s')} | {g('factor_s')} | "
              f"{g('eigen_s')} | {g('constraint_modes_s', '{:.2f}')} | {g('factor_nnz', '{:.3g}')} | "
              f"{r['memory_estimate_bytes'] / 1e9:.2f} | {w:.9f} | {diff} |")
    print("\nPer stage (wall s / CPU s / peak GB after it):")
    for size, ordering, r in rows:
        if isinstance(r, dict) and "stages" in r:
            st = ", ".join(f"{s['stage']} {s['wall_s']:.1f}/{s['cpu_s']:.1f}/"
                           f"{s['peak_rss_bytes'] / 1e9:.2f}" for s in r["stages"])
            print(f"- {size} {ordering}: {st}")
    print("\n| DOFs | scipy wall s | scipy CPU s | scipy peak GB | scipy omega0 rad/s |")
    print("|---|---|---|---|---|")
    for size, ordering, r in rows:
        if ordering != "scipy":
            continue
        if isinstance(r, str):
            print(f"| {size} | {r} |")
            continue
        print(f"| {size} | {r['scipy_wall_s']:.1f} | {r['scipy_cpu_s']:.1f} | "
              f"{r['scipy_peak_gb']:.2f} | {r['scipy_omega0_rad_s']:.9f} |")
    print("\nRatios to scipy (10 lowest modes; wall time):\n")
    print("| DOFs | host nma (whole run) / scipy (whole script) | lowest_modes eigen s (median; runs) | "
          "scipy eigsh s (median; runs) | eigsh / lowest_modes (medians) | omega0 difference |")
    print("|---|---|---|---|---|---|")
    by = {(size, o): r for size, o, r in rows if isinstance(r, dict)}
    for size in a.sizes:
        s, e = by.get((size, "scipy")), by.get((size, "eigen-only"))
        host = [r for (sz, o), r in by.items() if sz == size and o not in ("scipy", "eigen-only")]
        if not (s and e):
            continue
        whole = "; ".join(f"{s['scipy_wall_s'] / h['wall_s']:.1f}x ({h['ordering']})" for h in host)
        diff = abs(e["eigen_only_omega0_rad_s"] - s["scipy_omega0_rad_s"]) / s["scipy_omega0_rad_s"]
        pairs = [b / o for o, b in zip(e["eigen_only_s_runs"], s["scipy_eigsh_s_runs"])]
        spread = f" (runs {min(pairs):.1f}-{max(pairs):.1f}x)" if len(pairs) > 1 else ""
        print(f"| {size} | {whole} | {runs_text(e, 'eigen_only_s', '{:.2f}')} | "
              f"{runs_text(s, 'scipy_eigsh_s', '{:.1f}')} | "
              f"{s['scipy_eigsh_s'] / e['eigen_only_s']:.1f}x{spread} | {diff:.1e} |")


def eigen_only(exe, d, ordering, r):
    """One run of `lowest_modes` on the plate in d: its row, or why it failed."""
    rc, out, _, _, cpu, peak = timed([exe("examples/lowest_modes"), d, "--ordering", ordering],
                                        os.path.join(d, f"lowest_modes_{r}.log"))
    if rc != 0:
        return f"lowest_modes failed (exit {rc}): see {d}/lowest_modes_{r}.log"
    e = json.loads(out.strip().splitlines()[-1])
    return {"eigen_only_s": e["eigen_s"], "eigen_only_cpu_s": cpu, "eigen_only_peak_gb": peak,
            "eigen_only_omega0_rad_s": e["omega_rad_s"][0], "eigen_only_basis": e["basis"]}


def scipy_eigsh(a, d, r):
    """One run of scipy_eigsh.py on the plate in d: its row, or why it failed."""
    rc, out, _, wall, cpu, peak = timed(
        [a.python, os.path.join(ROOT, "scripts/scale/scipy_eigsh.py"), d],
        os.path.join(d, f"scipy_{r}.log"), a.scipy_limit_gb)
    if rc != 0:
        return f"scipy failed (exit {rc}; MemoryError above --scipy-limit-gb?)"
    s = json.loads(out.strip().splitlines()[-1])
    return {"scipy_wall_s": wall, "scipy_cpu_s": cpu, "scipy_peak_gb": peak,
            "scipy_eigsh_s": s["eigsh_s"], "scipy_omega0_rad_s": s["omega_rad_s"][0]}


def merge_runs(runs):
    """The rows of repeated runs as one: each number's median, and every
    run's time under `<key>_runs` for the timed keys."""
    out = {}
    for k in runs[0]:
        out[k] = statistics.median(r[k] for r in runs)
    for k in ("eigen_only_s", "scipy_eigsh_s"):
        if k in out:
            out[k + "_runs"] = [r[k] for r in runs]
    return out


def runs_text(row, key, fmt):
    """A merged row's time `key` as `median` or `median; run, run, ...`."""
    runs = row[key + "_runs"]
    med = fmt.format(row[key])
    return med if len(runs) == 1 else med + "; " + ", ".join(fmt.format(x) for x in runs)


if __name__ == "__main__":
    main()
