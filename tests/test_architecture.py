"""The package layout stays a pipeline: no import cycles between modules or between packages,
also through imports inside functions, and no private name imported across packages."""

from __future__ import annotations

import ast
from collections import defaultdict

from judgeopt.files import REPO

ROOT = REPO / "judgeopt"


def _graph() -> tuple[dict[str, set[str]], list[tuple[str, str, str]]]:
    modules = {}
    for path in ROOT.rglob("*.py"):
        name = ".".join(path.relative_to(REPO).with_suffix("").parts)
        modules[name.removesuffix(".__init__")] = path
    edges: dict[str, set[str]] = defaultdict(set)
    private: list[tuple[str, str, str]] = []
    for module, path in modules.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("judgeopt"):
                for alias in node.names:
                    target = f"{node.module}.{alias.name}"
                    edges[module].add(target if target in modules else node.module)
                    hidden = [part for part in (*node.module.split("."), alias.name)
                              if part.startswith("_") and not part.endswith("__")]
                    if hidden and _package(node.module) != _package(module):
                        private.append((module, node.module, alias.name))
            elif isinstance(node, ast.Import):
                edges[module] |= {a.name for a in node.names if a.name in modules}
    return {m: {t for t in ts if t in modules and t != m} for m, ts in edges.items()}, private


def _package(module: str) -> str:
    parts = module.split(".")
    return ".".join(parts[:2]) if len(parts) > 2 else module


def _cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    index, low, stack, on, found, counter = {}, {}, [], set(), [], [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in edges.get(v, ()):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def test_no_import_cycles_between_modules_or_packages():
    edges, _ = _graph()
    assert _cycles(edges) == []
    packages: dict[str, set[str]] = defaultdict(set)
    for a, targets in edges.items():
        for b in targets:
            if _package(a) != _package(b) and _package(b) != "judgeopt":
                packages[_package(a)].add(_package(b))
    assert _cycles(packages) == []


def test_no_private_name_is_imported_across_packages():
    _, private = _graph()
    assert private == []
