"""Nothing already written is replaced without --overwrite; SIGTERM stops a parallel command's workers."""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import pytest

from judgeopt.cli import main


@pytest.mark.parametrize("argv", [
    ["collect", "--out", "{f}", "--n", "2"],
    ["train-judge", "--train", "x.h5", "--out", "{m}"],
    ["solve", "--no-simulate", "--method", "amortized", "--out", "{f}"],
])
def test_an_existing_file_is_refused_without_overwrite(argv, tmp_path, capsys):
    f, m = tmp_path / "exists.h5", tmp_path / "model"
    f.write_text("keep me")
    m.with_suffix(".json").write_text("keep me")
    argv = [a.format(f=f, d=tmp_path, m=m) for a in argv]
    if argv[0] == "solve":
        f = f.with_suffix(".csv")
        f.write_text("keep me")
        argv[-1] = str(f)
    assert main(argv) == 6  # ExitCode.EXISTS
    assert "exists: pass --overwrite to replace it" in capsys.readouterr().err
    assert f.read_text() == "keep me" and m.with_suffix(".json").read_text() == "keep me"


@pytest.mark.slow
def test_sigterm_stops_a_collections_workers(tmp_path):
    psutil = pytest.importorskip("psutil")
    out = tmp_path / "c.h5"
    p = subprocess.Popen([sys.executable, "-m", "judgeopt.cli", "collect", "--out", str(out), "--n", "400",
                          "--jobs", "2", "--chunk", "5", "--quiet"], stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    partial = tmp_path / "c.h5.partial"
    t0 = time.time()
    while time.time() - t0 < 120 and len(list(partial.glob("chunk_*"))) < 2:
        time.sleep(0.2)
    workers = psutil.Process(p.pid).children(recursive=True)
    assert workers
    p.send_signal(signal.SIGTERM)
    assert p.wait(60) == 130
    time.sleep(3)
    assert [w for w in workers if w.is_running() and w.status() != psutil.STATUS_ZOMBIE] == []
    assert len(list(partial.glob("chunk_*"))) >= 2  # what was done is kept: a rerun resumes
    p.stdout.close(), p.stderr.close()
