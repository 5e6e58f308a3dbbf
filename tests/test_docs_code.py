"""Every code block in README.md and docs/**/*.md that is meant to run is run, so a guide cannot
drift from the code.

- ```python blocks: each file's run in order, in one namespace, in a fresh working directory (on
  sys.path). A block whose first line is `# NAME.py` is a file of the page's: it is written there
  instead of run, and the blocks after it import it. Tracebacks name the Markdown file and line.
- Shell blocks (```bash, and the `$ ...` lines of plain blocks): every `judgeopt` command is parsed
  by the command line's own parser (`build_parser().parse_args`, as `main` calls it), so an option
  that no longer exists fails; a `python FILE.py` names a file that exists; a `make TARGET` a target
  of the Makefile. In docs/guides/ the judgeopt commands also run, in order, beside the python
  blocks. `[--opt]` (optional) is parsed as given, `...` (the options above) dropped, `NAME="..."`
  lines substituted in the file's later commands, `NAME=value judgeopt ...` set for that command.
- `<!-- not-run: why -->` right before a block: it is not run (a shell block is still parsed);
  the reason is required. ```pycon, ```toml and the like are never run.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator

import pytest

from judgeopt.files import REPO

DOCS = [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]
#: files whose code plans with simulation: still run, marked slow
SLOW = {"README.md": "solves twice, each plan replayed in PyBullet",
        "docs/index.md": "solves, each plan replayed in PyBullet",
        "docs/quickstart.md": "solves twice, each plan replayed in PyBullet",
        "docs/guides/planner.md": "solves with a planner of its own beside the direct solve, each plan replayed",
        "docs/guides/real-robot.md": "solves three times, each plan replayed in PyBullet"}
#: the folder whose judgeopt commands are run (in order, beside its python blocks); elsewhere they are parsed
GUIDES = "docs/guides/"
#: a command that ran: done, or plans made that the judge calls unlikely (a verdict, not drift), or an
#: optional extra this environment lacks (ROS bags)
RAN = (0, 4, 7)
PYTHON = ("python", "py")
#: the info strings of shell blocks (a plain block: only its `$ ` lines are commands, the rest is output)
SHELL = ("bash", "sh", "shell", "console", "")
FENCE = re.compile(r"^(?P<indent>[ \t]*)(?P<fence>```+)(?P<info>[^\n`]*)\n(?P<body>.*?)^(?P=indent)(?P=fence)[ \t]*$",
                   re.M | re.S)
NOT_RUN = re.compile(r"<!--\s*not-run\s*:?(?P<why>.*?)-->\s*\Z", re.S)
MODULE_FILE = re.compile(r"\A#\s*(?P<name>[\w/]+\.py)\s*\n")


@dataclass(frozen=True)
class Block:
    path: Path
    line: int  # of the block's first line of code, 1-based
    lang: str
    code: str
    not_run: str | None  # the reason given, where the block is marked not to run

    @property
    def where(self) -> str:
        return f"{rel(self.path)}:{self.line}"


def rel(path: Path) -> str:
    return path.relative_to(REPO).as_posix()


def blocks(path: Path) -> list[Block]:
    """The fenced blocks of a Markdown file, in order, with their not-run marks."""
    text = path.read_text(encoding="utf-8")
    out, end = [], 0
    for m in FENCE.finditer(text):
        mark = NOT_RUN.search(text[end:m.start()])
        indent = len(m.group("indent"))
        code = "".join(line[indent:] for line in m.group("body").splitlines(keepends=True))
        info = m.group("info").split()
        out.append(Block(path, text.count("\n", 0, m.start("body")) + 1, info[0] if info else "", code,
                         mark.group("why").strip() if mark else None))
        end = m.end()
    return out


@dataclass(frozen=True)
class Command:
    where: str
    argv: list[str]
    env: dict[str, str] = field(default_factory=dict)


def commands(b: Block, variables: dict[str, str]) -> list[Command]:
    """The commands of a shell block: continuations joined, comments dropped, `NAME="..."` lines
    recorded in `variables` (the file's, shared by its blocks) and substituted, `&&` split,
    `[--opt]` kept as `--opt`, `...` dropped, leading `NAME=value` words the command's environment."""
    out = []
    text = re.sub(r"\\\n", " ", b.code)
    for offset, line in enumerate(text.splitlines()):
        if b.lang in ("", "console") and not line.startswith("$ "):
            continue
        line = line.removeprefix("$ ")
        assignment = re.match(r"^(\w+)=(\"[^\"]*\"|'[^']*'|\S*)\s*(#.*)?$", line)
        if assignment:
            variables[assignment.group(1)] = shlex.split(assignment.group(2))[0] if assignment.group(2) else ""
            continue
        line = re.sub(r"\$(\w+)|\$\{(\w+)\}", lambda m: variables.get(m.group(1) or m.group(2), m.group(0)), line)
        line = re.sub(r"\[(--[^\]]*)\]", r"\1", line)
        words = shlex.split(line, comments=True)
        while words:
            cut = words.index("&&") if "&&" in words else len(words)
            argv = [w for w in words[:cut] if w != "..."]
            env = {}
            while argv and re.match(r"^\w+=", argv[0]):
                key, _, value = argv.pop(0).partition("=")
                env[key] = value
            if argv:
                out.append(Command(f"{b.where}+{offset}", argv, env))
            words = words[cut + 1:]
    return out


def shell_commands(path: Path, not_run: bool = True) -> list[Command]:
    """A file's shell commands, in order (`not_run`: those of blocks marked not to run too)."""
    variables: dict[str, str] = {}
    return [c for b in blocks(path) if b.lang in SHELL and (not_run or b.not_run is None)
            for c in commands(b, variables)]


def runs(path: Path) -> bool:
    return any(b.lang in PYTHON and b.not_run is None for b in blocks(path)) or (
        rel(path).startswith(GUIDES) and any(c.argv[0].endswith("judgeopt") for c in shell_commands(path, False)))


@contextlib.contextmanager
def page_folder(path: Path, folder: Path, monkeypatch) -> Iterator[None]:
    """`folder` as the working directory and on sys.path, with the page's `# NAME.py` files written
    in it; the planners and modules they add are gone afterwards."""
    from judgeopt.planners.base import REGISTRY

    monkeypatch.chdir(folder)
    monkeypatch.syspath_prepend(str(folder))
    monkeypatch.setenv("MPLBACKEND", "Agg")
    for b in blocks(path):
        written = MODULE_FILE.match(b.code) if b.lang in PYTHON and b.not_run is None else None
        if written:
            target = folder / written.group("name")
            target.parent.mkdir(parents=True, exist_ok=True)
            target.write_text(b.code, encoding="utf-8")
    before, registered = set(sys.modules), set(REGISTRY)
    try:
        yield
    finally:
        for name in set(REGISTRY) - registered:
            REGISTRY.pop(name)
        for name in set(sys.modules) - before:
            if str(folder) in str(getattr(sys.modules[name], "__file__", None)):
                del sys.modules[name]


def test_every_not_run_mark_gives_its_reason_right_before_a_block():
    for path in DOCS:
        text = path.read_text(encoding="utf-8")
        marks = list(re.finditer(r"<!--\s*not-run\b(.*?)-->", text, re.S))
        for m in marks:
            where = f"{rel(path)}:{text.count(chr(10), 0, m.start()) + 1}"
            assert m.group(1).strip(" :\n"), f"{where}: <!-- not-run: why --> must say why the block does not run"
        assert len(marks) == sum(b.not_run is not None for b in blocks(path)), \
            f"{rel(path)}: a not-run mark that is not right before a code block"
    assert set(SLOW) <= {rel(p) for p in DOCS if runs(p)}, "a SLOW entry names no file with code that runs"


# -- python, and the guides' commands -----------------------------------------------------
@pytest.mark.parametrize("path", [pytest.param(p, id=rel(p), marks=[pytest.mark.slow] if rel(p) in SLOW else [])
                                  for p in DOCS if runs(p)])
def test_blocks_run(path, tmp_path, monkeypatch):
    """The file's python blocks (and a guide's judgeopt commands), in order, in one namespace and folder."""
    from judgeopt.cli import main

    namespace: dict = {"__name__": "__main__"}
    variables: dict[str, str] = {}
    with page_folder(path, tmp_path, monkeypatch):
        for b in blocks(path):
            if b.not_run is not None or (b.lang in PYTHON and MODULE_FILE.match(b.code)):
                continue
            if b.lang in PYTHON:  # padded so that a traceback's line numbers are the Markdown file's
                exec(compile("\n" * (b.line - 1) + b.code, str(path), "exec"), namespace)  # noqa: S102
            elif rel(path).startswith(GUIDES) and b.lang in SHELL:
                for c in commands(b, variables):
                    if c.argv[0].endswith("judgeopt"):
                        with monkeypatch.context() as env:
                            for k, v in c.env.items():
                                env.setenv(k, v)
                            code = main(c.argv[1:])
                        assert code in RAN, f"{c.where}: {' '.join(c.argv)} exited {code}"


# -- every shell command parses -----------------------------------------------------------
def make_targets() -> set[str]:
    return set(re.findall(r"^([\w.-]+):", (REPO / "Makefile").read_text(), re.M))


@pytest.fixture(scope="module")
def parser():
    from judgeopt.cli.main import build_parser

    return build_parser()


def parse(parser, argv: list[str]) -> str | None:
    """None where the parser takes `argv`; else its error line."""
    from judgeopt.cli.common import set_argv

    set_argv(argv)  # as main does: the options read before the parser reaches them (--plugin, --json)
    err, out = io.StringIO(), io.StringIO()
    try:
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
            parser.parse_args(argv)
    except SystemExit as exc:
        if exc.code:  # under --json the error is one object on stdout
            return (err.getvalue() or out.getvalue()).strip()
    return None


@pytest.mark.parametrize("path", [pytest.param(p, id=rel(p)) for p in DOCS if shell_commands(p)])
def test_shell_commands_parse(path, parser, tmp_path, monkeypatch):
    failures = []
    # an --out is checked against what exists: in an empty folder (with the page's own module files)
    with page_folder(path, tmp_path, monkeypatch):
        for c in shell_commands(path):
            program, args = os.path.basename(c.argv[0]), c.argv[1:]
            unset = [w for w in c.argv if re.search(r"\$\{?\w", w)]
            if unset:
                failures.append(f"{c.where}: {', '.join(unset)}: a variable no block of the file sets")
            elif program == "judgeopt":
                with monkeypatch.context() as env:
                    for k, v in c.env.items():
                        env.setenv(k, v)
                    said = parse(parser, args)
                if said is not None:
                    failures.append(f"{c.where}: judgeopt {' '.join(args)}\n    {said}")
            elif program in ("python", "python3") and args and args[0].endswith(".py"):
                if not (REPO / args[0]).is_file():
                    failures.append(f"{c.where}: {args[0]}: no such file in the repository")
            elif program == "make":
                missing = [t for t in args if not t.startswith("-") and t not in make_targets()]
                if missing:
                    failures.append(f"{c.where}: make {' '.join(missing)}: no such target in the Makefile")
    assert not failures, "commands in the docs the code no longer takes:\n" + "\n".join(failures)


def test_the_shell_check_catches_a_removed_option_and_reads_the_shell(parser):
    """What the check above reads of a block, and that it fails on an option the parser does not know."""
    b = Block(REPO / "README.md", 1, "bash", 'R="--n 3"\njudgeopt solve --qdot-max 0.4 [--json] \\\n  --no-such-option\n'
              "X=1 judgeopt evaluate planners $R ... && judgeopt models  # a comment\n", None)
    cs = commands(b, {})
    assert [(c.argv, c.env) for c in cs] == [
        (["judgeopt", "solve", "--qdot-max", "0.4", "--json", "--no-such-option"], {}),
        (["judgeopt", "evaluate", "planners", "--n", "3"], {"X": "1"}), (["judgeopt", "models"], {})]
    assert "unrecognized arguments: --no-such-option" in parse(parser, cs[0].argv[1:])
    assert parse(parser, cs[1].argv[1:]) is None
    assert "invalid choice: 'nowhere'" in parse(parser, ["solve", "--method", "nowhere"])
    assert "run" in make_targets() and "nowhere" not in make_targets()
