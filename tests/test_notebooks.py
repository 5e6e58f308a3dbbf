"""The notebooks are committed executed, so a reader on the web sees every figure and table; CI
checks that those outputs are the ones the notebooks give now.

Each notebook is executed here (in notebooks/, as Jupyter would, writing its files to a temporary
folder) and its outputs are compared with the committed ones, cell by cell:
- printed text (stdout), Markdown and plain-text results must match after masking what differs
  between runs without meaning anything: durations ("12 s", "3.1 ms"), the output folder (the
  default out/notebook when committed, a temporary one here), the checkout's path and memory
  addresses; numbers must then agree to their first 2 significant
  digits (floating-point results of torch, Ipopt and PyBullet may differ in the last digits on
  another CPU), every word and every success/failure exactly;
- figures must be where they were (their pixels are not compared);
- stderr is not compared (library banners and the one-off "building the judge library" line
  depend on the machine's caches).

Regenerate the committed outputs after changing a notebook or what it shows:
    .venv/bin/python tests/test_notebooks.py [notebooks/NAME.ipynb ...]
"""

from __future__ import annotations

import math
import os
import re
import sys
from pathlib import Path

import nbclient
import nbformat
import pytest

REPO = Path(__file__).resolve().parents[1]
NOTEBOOK_DIR = REPO / "notebooks"
NOTEBOOKS = sorted(NOTEBOOK_DIR.glob("*.ipynb"))
#: the notebooks' output folder when JUDGEOPT_NOTEBOOK_OUT is unset (relative to notebooks/)
DEFAULT_OUT = "out/notebook"
DURATION = re.compile(r"\b\d+(?:\.\d+)?(?:e[-+]?\d+)? ?(?:ms|s)\b")
ADDRESS = re.compile(r"0x[0-9a-fA-F]{6,}")
#: an absolute path up to a folder of a checkout (whichever checkout executed the notebook)
CHECKOUT = re.compile(r"(?:/[\w.+-]+)+(?=/(?:judgeopt|notebooks|data|models|docs|tests)/)")
NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def execute(path: Path, out: Path | None = None, timeout: int = 900):
    """The notebook at `path`, executed in notebooks/ (its files under `out`, or the default)."""
    nb = nbformat.read(path, as_version=4)
    env_before = os.environ.get("JUDGEOPT_NOTEBOOK_OUT")
    if out is not None:
        os.environ["JUDGEOPT_NOTEBOOK_OUT"] = str(out)
    else:
        os.environ.pop("JUDGEOPT_NOTEBOOK_OUT", None)
    try:  # the kernel inherits this process's environment
        nbclient.NotebookClient(nb, timeout=timeout, kernel_name="python3", record_timing=False,
                                resources={"metadata": {"path": str(path.parent)}}).execute()
    finally:
        if env_before is None:
            os.environ.pop("JUDGEOPT_NOTEBOOK_OUT", None)
        else:
            os.environ["JUDGEOPT_NOTEBOOK_OUT"] = env_before
    return nb


def mask(text: str, out: Path | None = None) -> str:
    """`text` without what legitimately differs between two runs (see the module docstring)."""
    if out is not None:
        text = text.replace(str(out.resolve()), "<out>").replace(str(out), "<out>")
    text = CHECKOUT.sub("<repo>", text).replace(f"<repo>/notebooks/{DEFAULT_OUT}", "<out>")
    if out is None:
        text = text.replace(DEFAULT_OUT, "<out>")
    return ADDRESS.sub("<address>", DURATION.sub("<duration>", text))


def outputs(nb, out: Path | None = None) -> list[list[tuple[str, str]]]:
    """Per code cell: (kind, masked text) of its stdout, Markdown and plain-text results; ("figure", "")
    for an image."""
    cells = []
    for cell in nb.cells:
        if cell.cell_type != "code":
            continue
        shown: list[tuple[str, str]] = []
        stdout = "".join(o.get("text", "") for o in cell.outputs if o.output_type == "stream" and o.name == "stdout")
        if stdout:
            shown.append(("stdout", mask(stdout, out)))
        for o in cell.outputs:
            if o.output_type == "error":
                shown.append(("error", f"{o.ename}: {o.evalue}"))
            data = o.get("data", {})
            if any(k.startswith("image/") for k in data):
                shown.append(("figure", ""))
            elif "text/markdown" in data:
                shown.append(("markdown", mask(data["text/markdown"], out)))
            elif "text/plain" in data:
                shown.append(("text", mask(data["text/plain"], out)))
        cells.append(shown)
    return cells


def close(a: str, b: str) -> bool:
    """Equal to the first 2 significant digits (one unit of the second digit of the larger)."""
    x, y = float(a), float(b)
    if x == y:
        return True
    scale = max(abs(x), abs(y))
    return abs(x - y) <= 10 ** (math.floor(math.log10(scale)) - 1) + 1e-12


def differences(committed: list, fresh: list) -> list[str]:
    """What differs between two `outputs` lists, one line each (empty: the same)."""
    if len(committed) != len(fresh):
        return [f"{len(committed)} code cells committed, {len(fresh)} now"]
    found = []
    for k, (old, new) in enumerate(zip(committed, fresh), start=1):
        if [kind for kind, _ in old] != [kind for kind, _ in new]:
            found.append(f"code cell {k}: outputs {[kind for kind, _ in old]} committed, {[kind for kind, _ in new]} now")
            continue
        for (kind, a), (_, b) in zip(old, new):
            words_a, words_b = NUMBER.split(a), NUMBER.split(b)
            nums_a, nums_b = NUMBER.findall(a), NUMBER.findall(b)
            bad = [(x, y) for x, y in zip(nums_a, nums_b) if not close(x, y)]
            if words_a != words_b or len(nums_a) != len(nums_b) or bad:
                line = next((f"{x!r} -> {y!r}" for x, y in zip(a.splitlines(), b.splitlines()) if x != y), "")
                found.append(f"code cell {k} ({kind}): {bad[:3] if bad and words_a == words_b else line}")
    return found


def test_differences_ignore_durations_and_paths_and_catch_everything_else(tmp_path):
    committed = [[("stdout", mask("solved in 12 s at 0x7f00aa11bb22; p = 0.7413, 43 successes, wrote out/notebook/x.png"))],
                 [("figure", "")]]
    same = [[("stdout", mask(f"solved in 9.5 s at 0x7f00cc33dd44; p = 0.7452, 43 successes, wrote {tmp_path}/x.png",
                             tmp_path))], [("figure", "")]]
    assert differences(committed, same) == []
    elsewhere = [[("stdout", mask("read /home/ci/judgeopt/judgeopt/tasks/a.toml, wrote /home/ci/judgeopt/notebooks/"
                                  "out/notebook/x.png"))]]
    here = [[("stdout", mask(f"read {REPO}/judgeopt/tasks/a.toml, wrote {tmp_path.resolve()}/x.png", tmp_path))]]
    assert differences(elsewhere, here) == []
    assert differences(committed, [[("stdout", committed[0][0][1].replace("0.7413", "0.7613"))], [("figure", "")]])
    assert differences(committed, [[("stdout", committed[0][0][1].replace("successes", "failures"))], [("figure", "")]])
    assert differences(committed, [[("stdout", committed[0][0][1].replace("43", "52"))], [("figure", "")]])
    assert differences(committed, [committed[0], []])  # a figure gone
    assert differences(committed, committed[:1])


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_is_committed_executed_in_order(path):
    """What a reader on the web sees: every code cell run once, top to bottom, without an error,
    and at least one figure."""
    nb = nbformat.read(path, as_version=4)
    code = [c for c in nb.cells if c.cell_type == "code"]
    assert [c.execution_count for c in code] == list(range(1, len(code) + 1)), \
        f"{path.name}: not executed top to bottom (run: .venv/bin/python tests/test_notebooks.py {path.relative_to(REPO)})"
    assert not [o for c in code for o in c.outputs if o.output_type == "error"], f"{path.name}: committed with an error"
    assert any(kind == "figure" for cell in outputs(nb) for kind, _ in cell), f"{path.name}: no figure"


@pytest.mark.slow
@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_committed_outputs_are_what_the_notebook_gives_now(path, tmp_path):
    committed = outputs(nbformat.read(path, as_version=4))
    fresh = outputs(execute(path, tmp_path), tmp_path)
    found = differences(committed, fresh)
    assert not found, (f"{path.name}: the committed outputs are not what it gives now (regenerate with "
                       f".venv/bin/python tests/test_notebooks.py {path.relative_to(REPO)}):\n" + "\n".join(found))


if __name__ == "__main__":  # regenerate the committed outputs
    for name in sys.argv[1:] or [str(p) for p in NOTEBOOKS]:
        p = Path(name).resolve()
        nbformat.write(execute(p), p)
        print(f"executed {p.relative_to(REPO)}")
