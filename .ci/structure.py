#!/usr/bin/env python3
"""The tree's structure rules (issue 48), checked in CI:

* no import loop inside a crate: the graph of a crate's top-level modules
  (`crate::m` paths in code, not in comments; test files and `mod tests`
  blocks left out) has no cycle;
* no Rust file over MAX_LINES lines without a `//! Long file:` reason in its
  module docs.

Exits 1 naming every violation. O(size of the tree)."""
import os
import re
import sys

MAX_LINES = 1000
ROOTS = ["crates", "tests", "benches", "fuzz/fuzz_targets"]


def rust_files(root):
    for d, dirs, files in os.walk(root):
        dirs[:] = [x for x in dirs if x != "target" and not x.startswith(".")]
        for f in files:
            if f.endswith(".rs"):
                yield os.path.join(d, f)


def module_of(src, path):
    parts = os.path.relpath(path, src)[:-3].split(os.sep)
    if parts[-1] in ("mod", "lib", "main"):
        parts = parts[:-1]
    return parts[0] if parts else "crate"


def import_graph(src):
    g = {}
    for path in rust_files(src):
        name = os.path.basename(path)
        if name == "tests.rs" or name.endswith("_tests.rs"):
            continue
        text = open(path, encoding="utf-8").read()
        text = re.split(r"#\[cfg\(test\)\]\s*mod tests\s*\{", text)[0]
        code = "\n".join(l for l in text.split("\n") if not l.lstrip().startswith("//"))
        m = module_of(src, path)
        edges = g.setdefault(m, set())
        for target in re.findall(r"crate::([a-z_0-9]+)", code):
            if target != m:
                edges.add(target)
    return {k: {t for t in v if t in g} for k, v in g.items()}


def cycles(g):
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]
    sys.setrecursionlimit(10000)

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in g.get(v, ()):
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
                out.append(sorted(comp))

    for v in list(g):
        if v not in index:
            visit(v)
    return out


def main():
    bad = []
    srcs = [os.path.join("crates", c, "src") for c in sorted(os.listdir("crates"))]
    srcs += ["tests/src", "benches/src"]
    for src in srcs:
        if os.path.isdir(src):
            for c in cycles(import_graph(src)):
                bad.append(f"{src}: import loop {' <-> '.join(c)}")
    for root in ROOTS:
        for path in rust_files(root):
            with open(path, encoding="utf-8") as f:
                lines = f.read().split("\n")
            if len(lines) > MAX_LINES and not any(l.startswith("//! Long file:") for l in lines):
                bad.append(f"{path}: {len(lines)} lines without a `Long file:` reason in its docs")
    for b in bad:
        print(b)
    print(f"structure: {len(bad)} violation(s)")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
