"""A worker's start without torch's Python package (judgeopt.judge.compiled): once a solve has left the
judge library's record and the generator's weights copy, every process of the service runs with
torch's import made to fail, and a worker still loads its models, gets ready and plans."""

from __future__ import annotations

import os
import subprocess
import sys

from serving import QUICK, start

#: on PYTHONPATH as sitecustomize.py: imported by every Python process started with it, the spawned workers too
NO_TORCH = '''
import sys

class NoTorch:
    def find_spec(self, name, path=None, target=None):
        if name == "torch" or name.startswith("torch."):
            raise ImportError(f"{name}: blocked by the worker fast-start test")
        return None

sys.meta_path.insert(0, NoTorch())
'''


def test_a_worker_loads_its_models_and_plans_without_torch(tmp_path):
    subprocess.run([sys.executable, "-m", "judgeopt", "solve", "--qdot-max", "0.4", "--no-simulate"], check=True,
                   capture_output=True)  # leaves the artefacts (a run that finds them changes nothing)
    (tmp_path / "sitecustomize.py").write_text(NO_TORCH)
    path = os.pathsep.join(p for p in (str(tmp_path), os.environ.get("PYTHONPATH")) if p)
    service = start(tmp_path, "--workers", "1", env={"PYTHONPATH": path})
    try:
        answer = service.plan({**QUICK, "simulate": False})
        assert answer.status == 200, answer.text
        assert [r["method"] for r in answer.body["results"]] == ["amortized", "direct"]
        assert answer.body["verdict"] == "likely"
    finally:
        assert service.stop() == 0
    assert "blocked" not in service.log.read_text()
