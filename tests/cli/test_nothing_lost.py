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


def _chunks(out, command):
    return list((out.with_name(out.name + ".partial") if command == "collect" else out / "partial").glob("*"))


@pytest.mark.slow
@pytest.mark.parametrize("command, signum", [
    ("collect", signal.SIGTERM), ("collect", signal.SIGINT), ("evaluate", signal.SIGTERM), ("evaluate", signal.SIGINT),
])
def test_an_interrupt_stops_a_parallel_commands_workers(command, signum, tmp_path):
    """Ctrl-C (SIGINT) or SIGTERM: exit 130, no worker left running, finished chunks kept for the rerun."""
    psutil = pytest.importorskip("psutil")
    out = tmp_path / ("c.h5" if command == "collect" else "ev")
    argv = {"collect": ["collect", "--out", str(out), "--n", "400", "--chunk", "5"],
            "evaluate": ["evaluate", "planners", "--n", "40", "--chunk", "2", "--methods", "amortized",
                         "--no-baselines", "--out", str(out)]}[command]
    # Ctrl-C as at a terminal: a shell starting the tests in the background (`cmd &`) ignores SIGINT,
    # and a child inherits that, so the command is started with the default disposition
    p = subprocess.Popen([sys.executable, "-m", "judgeopt.cli", *argv, "--jobs", "2", "--quiet"],
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    t0 = time.time()
    while time.time() - t0 < 180 and len(_chunks(out, command)) < 2 and p.poll() is None:
        time.sleep(0.2)
    workers = psutil.Process(p.pid).children(recursive=True)
    assert workers and p.poll() is None, p.stderr.read().decode()[-2000:] if p.poll() is not None else "no workers"
    p.send_signal(signum)
    assert p.wait(60) == 130
    time.sleep(3)
    assert [w for w in workers if w.is_running() and w.status() != psutil.STATUS_ZOMBIE] == []
    assert len(_chunks(out, command)) >= 2  # what was done is kept: a rerun resumes
    p.stdout.close(), p.stderr.close()
