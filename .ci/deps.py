#!/usr/bin/env python3
"""Fails when the modules of a crate import each other in a cycle.

Reads every `crate::` and `super::` path in the library's and the command line's sources, maps
each to the module it names, and looks for cycles among those modules. A module is a file or folder
directly under `src/`; under `methods/` and `recognize/` each method or recogniser (a folder or
file) is a module of its own, and so is each of the CLI's `cmd/` files. A module's submodules
belong to it: imports inside one module are free.

    python3 .ci/deps.py            # check; prints the modules' edges with --edges
"""
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CRATES = [ROOT / "crates/linpose/src", ROOT / "crates/linpose-cli/src"]
# Folders whose children are modules of their own.
SPLIT = {"methods", "recognize", "cmd", "report"}

PATH_RE = re.compile(r"\b(crate|super)((?:::[A-Za-z_][A-Za-z0-9_]*)+|::\{)")


def module_path(src: Path, file: Path) -> list[str]:
    """The module path of a file: src/a/b/mod.rs -> [a, b]; src/a/c.rs -> [a, c]."""
    parts = list(file.relative_to(src).with_suffix("").parts)
    if parts[-1] in ("mod", "lib", "main"):
        parts = parts[:-1]
    return parts


def unit(parts: list[str], src: Path) -> str | None:
    """The module that a module path belongs to, or None for the crate root."""
    if not parts:
        return None
    if parts[0] in SPLIT and len(parts) >= 2:
        return "/".join(parts[:2])
    return parts[0]


def strip_comments(text: str) -> str:
    text = re.sub(r"//[^\n]*", "", text)
    return re.sub(r"/\*.*?\*/", "", text, flags=re.S)


def strip_tests(text: str) -> str:
    """Drops `#[cfg(test)]` items (test modules, test-only helpers): tests are not dependencies."""
    out, i = [], 0
    for m in re.finditer(r"#\[cfg\(test\)\]", text):
        if m.start() < i:
            continue
        out.append(text[i : m.start()])
        j = m.end()
        # The item ends at the `;` before any brace, or at its matching `}`.
        depth, k = 0, j
        while k < len(text):
            c = text[k]
            if c == ";" and depth == 0:
                k += 1
                break
            if c == "{":
                depth += 1
            elif c == "}":
                depth -= 1
                if depth == 0:
                    k += 1
                    break
            k += 1
        i = k
    out.append(text[i:])
    return "".join(out)


def is_test_file(src: Path, f: Path) -> bool:
    parts = f.relative_to(src).parts
    return any(p in ("tests", "tests.rs", "test_support.rs") for p in parts)


def edges_of(src: Path) -> dict[str, set[str]]:
    known = set()
    for f in src.rglob("*.rs"):
        if is_test_file(src, f):
            continue
        u = unit(module_path(src, f), src)
        if u:
            known.add(u)
    edges: dict[str, set[str]] = {}
    for f in sorted(src.rglob("*.rs")):
        here = module_path(src, f)
        # A file's own module path; for a non-mod file its items live in that path too.
        me = unit(here, src)
        if me is None or is_test_file(src, f):
            continue
        text = strip_tests(strip_comments(f.read_text()))
        # `use crate::{a, b::c}` groups: expand the first level.
        for m in re.finditer(r"\bcrate::\{([^}]*)\}", text):
            for item in m.group(1).split(","):
                name = item.strip().split("::")[0].strip()
                if name:
                    add(edges, me, resolve([name], src, known))
        for m in PATH_RE.finditer(text):
            kind, rest = m.group(1), m.group(2)
            if rest == "::{":
                continue
            names = rest.strip(":").split("::")
            if kind == "crate":
                target = names
            else:
                # super:: counts from the file's module's parent (mod.rs files are the module).
                base = here[:-1]
                while names and names[0] == "super":
                    base = base[:-1]
                    names = names[1:]
                target = base + names
            add(edges, me, resolve(target, src, known))
    return edges


def resolve(parts: list[str], src: Path, known: set[str]) -> str | None:
    if not parts:
        return None
    if parts[0] in SPLIT and len(parts) >= 2 and "/".join(parts[:2]) in known:
        return "/".join(parts[:2])
    return parts[0] if parts[0] in known else None


def add(edges, a, b):
    if b is not None and b != a:
        edges.setdefault(a, set()).add(b)


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index, low, stack, on, out = {}, {}, [], set(), []
    counter = [0]
    nodes = set(edges) | {b for bs in edges.values() for b in bs}

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
            if len(comp) > 1:
                out.append(sorted(comp))

    sys.setrecursionlimit(10000)
    for v in sorted(nodes):
        if v not in index:
            visit(v)
    return out


def main() -> int:
    show = "--edges" in sys.argv
    bad = 0
    for src in CRATES:
        edges = edges_of(src)
        name = src.parent.name
        if show:
            for a in sorted(edges):
                print(f"{name}: {a} -> {', '.join(sorted(edges[a]))}")
        for comp in cycles(edges):
            bad += 1
            inner = {a: sorted(b for b in edges.get(a, ()) if b in comp) for a in comp}
            print(f"{name}: import cycle among {', '.join(comp)}")
            for a in comp:
                print(f"    {a} -> {', '.join(inner[a])}")
    if bad:
        print(f"{bad} import cycle(s)")
        return 1
    print("no import cycles between modules")
    return 0


if __name__ == "__main__":
    sys.exit(main())
