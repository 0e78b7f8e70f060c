#!/usr/bin/env python3
"""Import circles among a crate's top-level modules (default: host).

    scripts/module_cycles.py [CRATE_DIR]

Every module declared in `src/lib.rs` (`mod x;`, with its files `src/x.rs`
and `src/x/**.rs`) is a node; module `a` depends on `b` when a file of `a`
names `crate::b` outside comments and string literals (`use crate::b::...`,
`use crate::{b::..., ...}` and paths such as `crate::b::f(...)` in code).
Names that `lib.rs` re-exports (`pub use b::c as d;`) count as `b`. Test
files (`*tests.rs`, `tests/` folders) and `#[cfg(test)]` modules are left
out, as in `long_functions.py`.

Prints each circle (a strongly connected set of two or more modules) with
the files and lines that close it, and exits 1 if there is any (0 and no
output when there is none).
"""
import os
import re
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from long_functions import ROOT, matching, strip, test_ranges  # noqa: E402


def top_modules(lib):
    """The modules of `lib.rs` and the re-exported names mapped to theirs."""
    mods = re.findall(r"^\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;", lib, re.M)
    alias = {}
    for m in re.finditer(r"^\s*pub\s+use\s+(\w+)::([^;]*);", lib, re.M):
        root, tree = m.group(1), m.group(2)
        if root not in mods:
            continue
        for item in re.split(r"[,{}]", tree):
            item = item.strip()
            if not item:
                continue
            name = item.split(" as ")[-1].split("::")[-1].strip()
            alias[name] = root
    return mods, alias


def first_segments(s, i):
    """The first path segments after `crate::` at `s[i]` (one, or several
    for `crate::{a::x, b}`)."""
    if s[i] == "{":
        inner = s[i + 1:matching(s, i)]
        depth, items, cur = 0, [], ""
        for ch in inner:
            if ch == "{":
                depth += 1
            elif ch == "}":
                depth -= 1
            if ch == "," and depth == 0:
                items.append(cur)
                cur = ""
            else:
                cur += ch
        items.append(cur)
        return [re.match(r"\s*(\w*)", it).group(1) for it in items if it.strip()]
    m = re.match(r"\w+", s[i:])
    return [m.group(0)] if m else []


def edges(crate):
    src = os.path.join(crate, "src")
    with open(os.path.join(src, "lib.rs"), encoding="utf-8") as f:
        mods, alias = top_modules(strip(f.read()))
    out = {}
    for mod in mods:
        files = []
        if os.path.isfile(os.path.join(src, mod + ".rs")):
            files.append(os.path.join(src, mod + ".rs"))
        for dirpath, dirnames, filenames in os.walk(os.path.join(src, mod)):
            dirnames[:] = sorted(d for d in dirnames if d != "tests")
            files += [os.path.join(dirpath, n) for n in sorted(filenames)
                      if n.endswith(".rs") and not n.endswith("tests.rs")]
        for path in files:
            with open(path, encoding="utf-8") as f:
                s = strip(f.read())
            skip = test_ranges(s)
            for m in re.finditer(r"\bcrate\s*::\s*", s):
                if any(a <= m.start() <= b for a, b in skip):
                    continue
                for seg in first_segments(s, m.end()):
                    target = seg if seg in mods else alias.get(seg)
                    if target and target != mod:
                        line = s.count("\n", 0, m.start()) + 1
                        out.setdefault((mod, target), []).append(
                            f"{os.path.relpath(path, ROOT)}:{line}")
    return mods, out


def cycles(mods, out):
    """Strongly connected sets of two or more modules (Tarjan)."""
    graph = {m: sorted({b for (a, b) in out if a == m}) for m in mods}
    index, low, stack, on, comps, n = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = n[0]
        n[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                comps.append(sorted(comp))

    for v in mods:
        if v not in index:
            visit(v)
    return comps


def main():
    crate = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "host")
    mods, out = edges(crate)
    comps = cycles(mods, out)
    for comp in comps:
        print("circle: " + ", ".join(comp))
        for (a, b), where in sorted(out.items()):
            if a in comp and b in comp:
                print(f"  {a} -> {b}: " + ", ".join(where))
    return 1 if comps else 0


if __name__ == "__main__":
    sys.exit(main())
