#!/usr/bin/env python3
"""Finds import cycles between the top-level modules of each crate.

A module (src/NAME.rs or src/NAME/) uses another when its code names `crate::OTHER`,
or an item the crate root re-exports from OTHER (`pub use OTHER::{...}` in lib.rs).
Children naming `super::` stay inside their own top-level module. The crate root only
declares and re-exports, so it is no node. Prints each cycle and exits 1 if there is one.
"""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent


def crate_roots():
    # The command line's crate is the workspace's root package, with its sources in
    # crates/bw4t-cli/ and no Cargo.toml of its own there.
    for crate in sorted(p for p in ROOT.glob("crates/*") if p.is_dir()):
        for lib in (crate / "src" / "lib.rs", crate / "lib.rs"):
            if lib.exists():
                yield crate.name, lib


def strip_comments(text):
    text = re.sub(r"/\*.*?\*/", "", text, flags=re.S)
    return re.sub(r"//[^\n]*", "", text)


def top_modules(lib):
    """Top-level module name -> its files."""
    base = lib.parent
    names = re.findall(r"^\s*(?:pub(?:\([^)]*\))?\s+)?mod\s+(\w+)\s*;", strip_comments(lib.read_text()), re.M)
    modules = {}
    for name in names:
        files = []
        if (base / f"{name}.rs").exists():
            files.append(base / f"{name}.rs")
        if (base / name).is_dir():
            files.extend(sorted((base / name).rglob("*.rs")))
        modules[name] = files
    return modules


def reexports(lib, modules):
    """Item name -> the top-level module the crate root re-exports it from."""
    items = {}
    text = strip_comments(lib.read_text())
    for module, body in re.findall(r"pub(?:\([^)]*\))?\s+use\s+(\w+)::(\{[^}]*\}|\w+)\s*;", text, re.S):
        if module not in modules:
            continue
        for item in re.findall(r"\w+", body):
            if item not in ("self", "as"):
                items[item] = module
    return items


def cycles_of(graph):
    """Every elementary cycle's nodes, found by a depth-first walk (graphs here are small)."""
    found = set()
    def walk(start, node, path):
        for nxt in sorted(graph.get(node, ())):
            if nxt == start:
                found.add(tuple(path))
            elif nxt not in path and nxt > start:
                walk(start, nxt, path + [nxt])
    for start in sorted(graph):
        walk(start, start, [start])
    return sorted(found)


def main():
    broken = False
    for crate, lib in crate_roots():
        modules = top_modules(lib)
        items = reexports(lib, modules)
        graph = {}
        for name, files in modules.items():
            uses = set()
            for f in files:
                text = strip_comments(f.read_text())
                for path in re.findall(r"crate::(\{[^}]*\}|\w+)", text):
                    for word in re.findall(r"\w+", path):
                        target = word if word in modules else items.get(word)
                        if target and target != name:
                            uses.add(target)
                        if not path.startswith("{"):
                            break
            graph[name] = uses
        for cycle in cycles_of(graph):
            broken = True
            print(f"{crate}: modules import each other: {' -> '.join(cycle + (cycle[0],))}")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
