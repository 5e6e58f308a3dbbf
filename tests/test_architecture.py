"""The package layout stays a pipeline: no import cycles between modules or between packages,
also through imports inside functions, and no private name imported across packages; and the
core stays task-agnostic: no task's variable is named outside judgeopt/tasks/."""

from __future__ import annotations

import ast
import re
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


def _task_names() -> set[str]:
    """Every built-in task's environment variables and perturbations (the scoop's y_obj, mu,
    mu_factor, ...), read from the tasks themselves."""
    from judgeopt.tasks import BUILTIN, get_task

    return {n for t in map(get_task, BUILTIN) for n in (*t.env_names, *(p.name for p in t.perturbations))}


def _named(text: str, names: set[str]) -> list[str]:
    """The lines of `text` naming any of `names` as a word, in any case and with - for _ (the
    option --y-obj, the constant Y_OBJ): code, strings, docstrings and comments alike."""
    alternatives = "|".join(re.escape(n).replace("_", "[_-]") for n in sorted(names, key=len, reverse=True))
    word = re.compile(rf"(?<![A-Za-z0-9_])(?:{alternatives})(?![A-Za-z0-9_])", re.IGNORECASE)
    return [f"{i}: {line.strip()}" for i, line in enumerate(text.splitlines(), 1) if word.search(line)]


def test_the_name_check_finds_a_planted_name_and_only_whole_words():
    names = _task_names()
    assert {"y_obj", "mu", "mu_factor", "sensor_noise"} <= names
    planted = 'Y_OBJ = "x"\nfriction = env["mu"]\nhelp = "--y-obj 0.2"\n# a mass-factor of 2\n'
    assert [line[0] for line in _named(planted, names)] == ["1", "2", "3", "4"]
    assert _named("mutable = emu + y_object + mu_x + env_names\n", names) == []


def test_no_task_variable_is_named_outside_the_tasks():
    """The core works through the Task interface, so a task's environment variables and
    perturbations are named only under judgeopt/tasks/ (the tasks, and what the built-in ones
    share): anything else that needs them reads them from the task (Task.default_q_end,
    demo_panels, trial_spread), and help texts build their examples from the default task
    (judgeopt.cli.examples). Docstrings and comments count too: they explain the core in its own
    terms (NAME=VALUE)."""
    names, found = _task_names(), {}
    for path in sorted(ROOT.rglob("*.py")):
        if path.relative_to(ROOT).parts[0] == "tasks":
            continue
        lines = _named(path.read_text(), names)
        if lines:
            found[str(path.relative_to(REPO))] = lines
    assert found == {}
