"""Atomic writes: the new file replaces the old one whole, with the mode an ordinary new file gets."""

from __future__ import annotations

import ast
import os
import stat

import numpy as np
import pytest

from judgeopt.data import dataset as D
from judgeopt.files import REPO, atomic_path, atomic_write


def _mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture(params=[0o022, 0o027])
def umask(request):
    old = os.umask(request.param)
    yield request.param
    os.umask(old)


def test_written_files_get_the_mode_of_an_ordinary_new_file(tmp_path, umask):
    with open(tmp_path / "plain", "w") as fh:  # what the OS gives any new file under this umask
        fh.write("x")
    atomic_write(tmp_path / "a.json", "{}")
    ds = D.Dataset(np.zeros((2, 3, 3)), np.zeros((2, 3, 3)), np.array([0, 1]), np.zeros((2, 1)), 0.05, ("y_obj",))
    D.save(ds, tmp_path / "d.h5")
    assert _mode(tmp_path / "a.json") == _mode(tmp_path / "d.h5") == _mode(tmp_path / "plain")


def test_a_failed_write_keeps_the_old_file_and_leaves_nothing_behind(tmp_path):
    target = tmp_path / "model.json"
    target.write_text("old")
    with pytest.raises(RuntimeError):
        with atomic_path(target) as tmp:
            tmp.write_text("half of the new")
            raise RuntimeError("crash while writing")
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["model.json"]


def test_temporary_files_are_made_in_one_place():
    """A writer that makes its own temporary file skips the rename and the mode: use atomic_path."""
    makers = {"mkstemp", "NamedTemporaryFile", "mktemp"}
    found = []
    for path in (REPO / "judgeopt").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and node.attr in makers and path.name != "files.py":
                found.append(f"{path.relative_to(REPO)}:{node.lineno}")
    assert not found
