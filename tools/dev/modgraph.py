#!/usr/bin/env python3
"""Draws Brume's module graph from the `use` paths in src/ and checks its shape.

Prints the top-level modules by level (a module sits one level above the highest module it
uses), every dependency that runs upward (an edge on a cycle between top-level modules), and
the cycles between files inside one top-level module. Exit status 1 if any dependency runs
upward.

    tools/dev/modgraph.py [--dot FILE]
"""
import os
import re
import sys

SRC = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "src")


def module_of(path):
    rel = os.path.relpath(path, SRC)[:-3].split(os.sep)
    if rel[-1] == "mod":
        rel = rel[:-1]
    if rel in (["lib"], ["main"]):
        return []
    return rel


def expand(tree):
    """`a::{b, c::{d, e}}` -> ["a::b", "a::c::d", "a::c::e"]."""
    tree = tree.strip()
    depth = 0
    for i, ch in enumerate(tree):
        if ch == "{" and depth == 0:
            prefix = tree[:i]
            inner = tree[i + 1:tree.rindex("}")]
            parts, depth2, start = [], 0, 0
            for j, c in enumerate(inner):
                if c == "{":
                    depth2 += 1
                elif c == "}":
                    depth2 -= 1
                elif c == "," and depth2 == 0:
                    parts.append(inner[start:j])
                    start = j + 1
            parts.append(inner[start:])
            out = []
            for p in parts:
                if p.strip():
                    out += [prefix + q for q in expand(p)]
            return out
    return [re.sub(r"\s+as\s+\w+$", "", tree)]


def strip_comments(text):
    # Unit tests (an inline `mod tests` at the end of a file) are not part of the graph, and
    # `super` inside them names the file's own module.
    m = re.search(r"#\[cfg\(test\)\]\s*(pub\s+)?mod\s+\w+\s*\{", text)
    if m:
        text = text[: m.start()]
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r"/\*.*?\*/", "", text, flags=re.S)


def references(path, mod, children=()):
    """Absolute module paths (lists) that the file at `path` (module `mod`) names."""
    text = strip_comments(open(path).read())
    paths = []
    for m in re.finditer(r"(\bpub(?:\([\w:]+\))?\s+)?\buse\s+([^;]+);", text):
        tree = expand(m.group(2))
        if m.group(1) and children:
            # A parent's `pub use child::Item` is its facade, not a use of the child.
            tree = [t for t in tree if t.split("::")[0] not in children]
        paths += tree
    text = re.sub(r"\bpub(?:\([\w:]+\))?\s+use\s+[^;]+;", "", text) if children else text
    paths += re.findall(r"\b((?:crate|super|brume)(?:::\w+)+)", text)
    # A file's own module is `mod`; `super` is its parent (for mod.rs files, the
    # module itself is the directory, so super is one up from that).
    # Paths relative to the file's own module: its children (`child::item`).
    for child in children:
        paths += re.findall(r"(?<![\w:])(" + child + r"(?:::\w+)+)", text)
    out = []
    for p in paths:
        segs = [s for s in p.split("::") if s]
        if not segs:
            continue
        if segs[0] in ("crate", "brume"):
            out.append(segs[1:])
        elif segs[0] in children:
            out.append(list(mod) + segs)
        elif segs[0] in ("super", "self"):
            base = list(mod)
            while segs and segs[0] in ("super", "self"):
                if segs[0] == "super":
                    base = base[:-1]
                segs = segs[1:]
            out.append(base + segs)
    return out


def files():
    for root, _, names in os.walk(SRC):
        for n in sorted(names):
            if n.endswith(".rs"):
                yield os.path.join(root, n)


def file_modules():
    mods = {}
    for f in files():
        mods[tuple(module_of(f))] = f
    return mods


def resolve(ref, mods):
    """The longest existing module prefix of `ref`."""
    for n in range(len(ref), 0, -1):
        if tuple(ref[:n]) in mods:
            return tuple(ref[:n])
    return None


def sccs(nodes, edges):
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
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
            out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return out


def main():
    mods = file_modules()
    top_edges, file_edges = {}, {}
    for mod, path in mods.items():
        if not mod:
            continue
        children = [m[-1] for m in mods if len(m) == len(mod) + 1 and m[:-1] == mod]
        if not os.path.basename(path) == "mod.rs":
            children = []
        for ref in references(path, list(mod), children):
            target = resolve(ref, mods)
            if target is None or target == mod or not target:
                continue
            if target[0] != mod[0]:
                top_edges.setdefault(mod[0], {}).setdefault(target[0], set()).add(
                    "/".join(os.path.relpath(path, SRC).split(os.sep)))
            elif len(target) > 1:
                # A file using another file of its own top-level module (a parent's mod.rs
                # included: a child and its parent using each other is a cycle too).
                file_edges.setdefault(mod, set()).add(target)
    tops = sorted({m[0] for m in mods if m})
    comps = sccs(tops, {k: set(v) for k, v in top_edges.items()})
    comp_of = {v: i for i, c in enumerate(comps) for v in c}
    level = {}
    for c in comps:  # Tarjan emits components in reverse topological order.
        lv = 0
        for v in c:
            for w in top_edges.get(v, {}):
                if comp_of[w] != comp_of[v]:
                    lv = max(lv, level[comp_of[w]] + 1)
        level[comp_of[c[0]]] = lv
    print("Top-level modules by level (each uses only modules on lower levels):")
    for lv in sorted(set(level.values())):
        names = [", ".join(c) for i, c in enumerate(comps) if level[i] == lv]
        print(f"  {lv}: {'; '.join(names)}")
    n_edges = sum(len(v) for v in top_edges.values())
    print(f"{len(tops)} modules, {n_edges} dependencies")
    upward = []
    for c in comps:
        if len(c) > 1:
            for v in c:
                for w, where in sorted(top_edges.get(v, {}).items()):
                    if w in c:
                        upward.append((v, w, sorted(where)))
    print(f"Dependencies on a cycle between top-level modules: {len(upward)}")
    for v, w, where in upward:
        print(f"  {v} -> {w} ({', '.join(where)})")
    fnodes = set(file_edges) | {t for v in file_edges.values() for t in v}
    fcycles = [c for c in sccs(fnodes, file_edges) if len(c) > 1]
    print(f"Cycles between files inside a module: {len(fcycles)}")
    for c in fcycles:
        print("  " + " <-> ".join("::".join(m) for m in c))
    if "--dot" in sys.argv:
        with open(sys.argv[sys.argv.index("--dot") + 1], "w") as f:
            f.write("digraph brume {\n")
            for v, ws in sorted(top_edges.items()):
                for w in sorted(ws):
                    f.write(f'  "{v}" -> "{w}";\n')
            f.write("}\n")
    return 1 if upward else 0


if __name__ == "__main__":
    sys.exit(main())
