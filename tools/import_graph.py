"""The package's module import graph, and its cycles.

Run: .venv/bin/python tools/import_graph.py [--all]
Counts imports at module level; with --all also those inside functions
(deferred imports still tie modules together). Prints each strongly
connected group of more than one module, and exits 1 if there is one.
"""

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent / "python"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def resolve(current: str, is_package: bool, node: ast.ImportFrom) -> list:
    base = current.split(".") if is_package else current.split(".")[:-1]
    if node.level:
        base = base[: len(base) - (node.level - 1)] if node.level > 1 else base
        prefix = ".".join(base + ([node.module] if node.module else []))
    else:
        prefix = node.module or ""
    # `from X import name`: the module X.name where there is one, else X.
    full = [f"{prefix}.{a.name}" for a in node.names]
    return [f if f in FILES or f in LEAVES else prefix for f in full]


FILES = {module_name(p): p for p in ROOT.rglob("*.py")}
# Extension modules: leaves of the graph.
LEAVES = {"pyvr._core"}


def graph(all_levels: bool) -> dict:
    files = FILES
    edges = {m: set() for m in files}
    for mod, path in files.items():
        tree = ast.parse(path.read_text())
        nodes = ast.walk(tree) if all_levels else tree.body
        for node in nodes:
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                targets = resolve(mod, path.name == "__init__.py", node)
            for t in targets:
                if t in LEAVES:
                    continue
                # The module itself, or the package whose attribute it is.
                while t and t not in files:
                    t = t.rpartition(".")[0]
                if t and t != mod and t.startswith("pyvr"):
                    edges[mod].add(t)
    return edges


def cycles(edges: dict) -> list:
    index, low, stack, on, out, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            group = []
            while True:
                w = stack.pop()
                on.discard(w)
                group.append(w)
                if w == v:
                    break
            if len(group) > 1:
                out.append(sorted(group))

    sys.setrecursionlimit(10000)
    for v in edges:
        if v not in index:
            visit(v)
    return out


if __name__ == "__main__":
    found = cycles(graph("--all" in sys.argv))
    for g in found:
        print(f"{len(g)} modules: {', '.join(g)}")
    sys.exit(1 if found else 0)
