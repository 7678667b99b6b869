#!/usr/bin/env python3
"""Whether a crate's top-level modules depend on each other in a cycle.

Reads every non-test source file under each SRC folder (default:
nerf-train/src and nerf-infer/src), takes each `crate::MODULE` a file names
outside comments (in `use` lines, braced `use crate::{..}` lists and paths)
as its top-level module depending on MODULE, and prints each cycle with the
files that make its edges. Exits 1 when a crate has a cycle.

    scripts/check/module_cycles.py [SRC...]
"""
import collections
import os
import re
import sys


def edges(src):
    mods = {m[:-3] if m.endswith(".rs") else m for m in os.listdir(src) if m not in ("lib.rs", "main.rs")}
    graph, why = collections.defaultdict(set), collections.defaultdict(set)
    for root, _, files in os.walk(src):
        for f in files:
            if not f.endswith(".rs") or "tests" in f:
                continue
            path = os.path.join(root, f)
            top = os.path.relpath(path, src).split(os.sep)[0].removesuffix(".rs")
            if top not in mods:
                continue
            text = open(path, encoding="utf-8").read()
            text = re.sub(r"#\[cfg\(test\)\]\s*mod tests \{.*", "", text, flags=re.S)
            text = "\n".join(l for l in text.split("\n") if not l.strip().startswith("//"))
            text = re.sub(r"use crate::\{([^}]*)\}",
                          lambda m: " ".join("crate::" + x for x in re.findall(r"(\w+)::", m.group(1))), text, flags=re.S)
            for m in re.findall(r"crate::(\w+)", text):
                if m != top and m in mods:
                    graph[top].add(m)
                    why[(top, m)].add(os.path.relpath(path, src))
    return mods, graph, why


def cycles(mods, graph):
    """Strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []

    def visit(v):
        index[v] = low[v] = len(index)
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
                out.append(sorted(comp))

    for v in sorted(mods):
        if v not in index:
            visit(v)
    return out


def main():
    os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."))
    found = False
    for src in sys.argv[1:] or ["nerf-train/src", "nerf-infer/src"]:
        mods, graph, why = edges(src)
        for comp in cycles(mods, graph):
            found = True
            print(f"{src}: modules in a cycle: {', '.join(comp)}")
            for a in comp:
                for b in sorted(graph[a] & set(comp)):
                    print(f"  {a} -> {b} ({', '.join(sorted(why[(a, b)]))})")
        if not found:
            print(f"{src}: {len(mods)} modules, no cycle")
    sys.exit(1 if found else 0)


if __name__ == "__main__":
    main()
