#!/usr/bin/env python3
"""The source tree's layering and its documentation.

1. No include cycle between folders: the folders of service/, sim/, tools/ and train/ (a folder's
   subfolders count as the folder: service/engine/strategies is service/engine), linked by the
   #include "..." lines of their sources, form a graph without cycles. tests/ may include
   anything and is not a node.
2. docs/architecture.md's folder table and the README's "Layout" section name every such folder
   and every top-level folder, and docs/architecture.md names no source folder that is gone.

usage: layout_test.py SOURCE_DIR
"""
import os
import re
import sys

SOURCE_ROOTS = ["service", "sim", "tools", "train"]
# Top-level folders that hold no sources of a library but are part of the product.
TOP_LEVEL = ["api", "cmake", "docker", "docs", "models", "scripts", "tests", "web", "clients"]
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def node_of(path):
    """'service/engine/strategies/gqcnn.cpp' -> 'service/engine'; 'sim/main.cpp' -> 'sim'."""
    parts = path.split("/")
    if parts[0] not in SOURCE_ROOTS:
        return None
    return "/".join(parts[:2]) if len(parts) > 2 else parts[0]


def source_files(root):
    for top in SOURCE_ROOTS:
        for dirpath, _, names in os.walk(os.path.join(root, top)):
            for name in names:
                if name.endswith((".cpp", ".h", ".cc", ".hpp")):
                    yield os.path.relpath(os.path.join(dirpath, name), root)


def folder_graph(root):
    edges = {}
    for path in source_files(root):
        src = node_of(path)
        with open(os.path.join(root, path), encoding="utf-8", errors="replace") as f:
            text = f.read()
        for included in INCLUDE.findall(text):
            dst = node_of(included)
            if dst and dst != src:
                edges.setdefault(src, {}).setdefault(dst, path)
    return edges


def find_cycle(edges):
    """One cycle as a list of nodes, or None."""
    state = {}
    stack = []

    def visit(n):
        state[n] = "open"
        stack.append(n)
        for m in sorted(edges.get(n, {})):
            if state.get(m) == "open":
                return stack[stack.index(m):] + [m]
            if m not in state:
                found = visit(m)
                if found:
                    return found
        stack.pop()
        state[n] = "done"
        return None

    for n in sorted(edges):
        if n not in state:
            found = visit(n)
            if found:
                return found
    return None


def library_folders(root):
    """service/X, sim/X, tools/X, train (the folders that hold sources), sorted."""
    out = set()
    for path in source_files(root):
        out.add(node_of(path))
    return sorted(out)


def readme_layout(root):
    with open(os.path.join(root, "README.md"), encoding="utf-8") as f:
        text = f.read()
    match = re.search(r"^## Layout\n(.*?)(?=^## )", text, re.M | re.S)
    return match.group(1) if match else ""


def main():
    root = sys.argv[1]
    problems = []
    edges = folder_graph(root)
    cycle = find_cycle(edges)
    if cycle:
        steps = [f"{a} -> {b} ({edges[a][b]})" for a, b in zip(cycle, cycle[1:])]
        problems.append("folders include each other: " + "; ".join(steps))

    with open(os.path.join(root, "docs", "architecture.md"), encoding="utf-8") as f:
        architecture = f.read()
    layout = readme_layout(root)
    if not layout:
        problems.append("README.md has no '## Layout' section")
    present = [d for d in TOP_LEVEL if os.path.isdir(os.path.join(root, d))]
    for folder in library_folders(root) + present:
        # `sim`, `sim/` or a path inside it such as `service/main.cpp`.
        named = re.compile(r"`" + re.escape(folder) + r"(/[^`]*)?`")
        if not named.search(architecture):
            problems.append(f"docs/architecture.md does not name `{folder}`")
        if not named.search(layout):
            problems.append(f"README.md's Layout does not name `{folder}`")
    for named in sorted(set(re.findall(r"\| `((?:service|sim|tools|train)(?:/[a-z_]+)?)/?` \|",
                                        architecture))):
        if not os.path.isdir(os.path.join(root, named)):
            problems.append(f"docs/architecture.md names `{named}`, which does not exist")

    for p in problems:
        print("layout: " + p)
    if problems:
        return 1
    print(f"layout: {len(edges)} folders, no include cycle; every folder documented")
    return 0


if __name__ == "__main__":
    sys.exit(main())
