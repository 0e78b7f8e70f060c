#!/usr/bin/env python3
"""List every non-test Rust function longer than a limit (default 150 lines).

    scripts/long_functions.py [LIMIT]

Scans the `src/` folder of every workspace crate (the directories beside this
script's parent that hold a `Cargo.toml` and a `src/`). A function's length
counts its lines from the line of `fn` to the line of its closing brace, both
included. Not counted: files named `*tests.rs`, files under a `tests/`
folder, and `#[cfg(test)]` modules (inline ones; `#[cfg(test)] mod x;` files
are skipped when their name ends in `tests.rs`). Nested functions are listed
on their own and also count toward the enclosing function.

Prints `LINES path:line name` per function, longest first, and exits 1 when
there is any (0 when none: the output is then empty).
"""
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def strip(src):
    """The source with comments, string and char literals blanked (newlines
    kept, so line numbers and braces outside literals stay as they are)."""
    out = []
    i, n = 0, len(src)

    def blank(s):
        return "".join("\n" if c == "\n" else " " for c in s)

    while i < n:
        c = src[i]
        if src.startswith("//", i):
            j = src.find("\n", i)
            j = n if j < 0 else j
            out.append(blank(src[i:j]))
            i = j
        elif src.startswith("/*", i):
            depth, j = 1, i + 2
            while j < n and depth:
                if src.startswith("/*", j):
                    depth, j = depth + 1, j + 2
                elif src.startswith("*/", j):
                    depth, j = depth - 1, j + 2
                else:
                    j += 1
            out.append(blank(src[i:j]))
            i = j
        elif re.match(r'b?r#*"', src[i:i + 40]) and (i == 0 or not (src[i - 1].isalnum() or src[i - 1] == "_")):
            m = re.match(r'b?r(#*)"', src[i:])
            end = '"' + m.group(1)
            j = src.find(end, i + m.end())
            j = n if j < 0 else j + len(end)
            out.append(blank(src[i:j]))
            i = j
        elif c == '"':
            j = i + 1
            while j < n and src[j] != '"':
                j += 2 if src[j] == "\\" else 1
            out.append(blank(src[i:j + 1]))
            i = j + 1
        elif c == "'":
            m = re.match(r"'(\\u\{[0-9a-fA-F]*\}|\\x[0-9a-fA-F]{2}|\\.|[^\\'\n])'", src[i:])
            if m:  # a char literal (otherwise a lifetime or label)
                out.append(blank(m.group(0)))
                i += m.end()
            else:
                out.append(c)
                i += 1
        else:
            out.append(c)
            i += 1
    return "".join(out)


def matching(s, i):
    """Index of the brace closing the one at `s[i]`."""
    depth = 0
    for j in range(i, len(s)):
        if s[j] == "{":
            depth += 1
        elif s[j] == "}":
            depth -= 1
            if depth == 0:
                return j
    return len(s) - 1


def test_ranges(s):
    """Character ranges of `#[cfg(test)]` inline modules."""
    ranges = []
    for m in re.finditer(r"#\s*\[\s*cfg\s*\(\s*test\s*\)\s*\]", s):
        k = m.end()
        mm = re.compile(r"(\s|#\s*\[[^\]]*\])*\s*(pub(\([^)]*\))?\s+)?mod\s+\w+\s*([{;])").match(s, k)
        if mm and mm.group(4) == "{":
            ranges.append((m.start(), matching(s, mm.end() - 1)))
        elif not mm:
            # a test-only item (fn, impl, ...): skip to the end of its body
            j = k
            while j < len(s) and s[j] not in "{;":
                j += 1
            if j < len(s) and s[j] == "{":
                ranges.append((m.start(), matching(s, j)))
    return ranges


def functions(path):
    with open(path, encoding="utf-8") as f:
        s = strip(f.read())
    skip = test_ranges(s)
    for m in re.finditer(r"\bfn\s+(r#)?(\w+)", s):
        if any(a <= m.start() <= b for a, b in skip):
            continue
        # the body: the first `{` outside parentheses/brackets/angles of the
        # signature, unless a `;` (a declaration) comes first
        depth, j = 0, m.end()
        while j < len(s):
            ch = s[j]
            if ch in "([":
                depth += 1
            elif ch in ")]":
                depth -= 1
            elif depth == 0 and ch in "{;":
                break
            j += 1
        if j >= len(s) or s[j] == ";":
            continue
        end = matching(s, j)
        first = s.count("\n", 0, m.start()) + 1
        last = s.count("\n", 0, end) + 1
        yield m.group(2), first, last - first + 1


def sources():
    for crate in sorted(os.listdir(ROOT)):
        src = os.path.join(ROOT, crate, "src")
        if not (os.path.isfile(os.path.join(ROOT, crate, "Cargo.toml")) and os.path.isdir(src)):
            continue
        for dirpath, dirnames, filenames in os.walk(src):
            dirnames[:] = sorted(d for d in dirnames if d != "tests")
            for name in sorted(filenames):
                if name.endswith(".rs") and not name.endswith("tests.rs"):
                    yield os.path.join(dirpath, name)


def main():
    limit = int(sys.argv[1]) if len(sys.argv) > 1 else 150
    found = []
    for path in sources():
        for name, line, length in functions(path):
            if length > limit:
                found.append((length, os.path.relpath(path, ROOT), line, name))
    found.sort(key=lambda t: (-t[0], t[1], t[2]))
    for length, path, line, name in found:
        print(f"{length:5d} {path}:{line} {name}")
    return 1 if found else 0


if __name__ == "__main__":
    sys.exit(main())
