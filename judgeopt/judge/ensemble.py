"""A deep ensemble of judges and the pessimistic score planners can optimise.

Why: one judge is confidently wrong off its data, and a planner that maximises it goes there.
K judges trained from different seeds on bootstrap resamples agree where the data pin them
down and disagree where they do not; planning against mean - k * std of their logits (or
their minimum) prefers plans they all accept.

An ensemble is a folder: member_0.{pt,json} ... member_{K-1}.{pt,json}, each an ordinary
judge file, plus ensemble.json naming them with their weights hashes. Training is resumable
member by member.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from judgeopt.judge.model import Judge, JudgeConfig, JudgeError
from judgeopt.files import atomic_write
from judgeopt.formats.header import check_header, header
from judgeopt.judge.store import load_judge, save_judge

FORMAT = "judgeopt-judge-ensemble"
VERSION = 1


@dataclass(frozen=True)
class EnsembleConfig:
    k: int = 5
    epochs: int = 20  # per member: validation accuracy plateaus around 20-40 (docs/judge.md)
    seed: int = 0
    bootstrap: bool = True
    arch: str = "lstm"  # each member's architecture (judgeopt.judge.archs), with its default fields


def pessimistic(logits, k: float, sqrt=np.sqrt, minimum=np.minimum, eps: float = 0.0):
    """mean - k * std over the members' logits (a sequence, one per member); k = inf: their
    minimum. Element-wise operations only, so the same score serves numpy arrays, torch tensors
    (torch.sqrt, torch.minimum) and CasADi expressions (cs.sqrt, cs.fmin; eps keeps the
    gradient of the square root finite)."""
    logits = list(logits)
    if np.isinf(k):
        out = logits[0]
        for z in logits[1:]:
            out = minimum(out, z)
        return out
    mean = sum(logits) / len(logits)
    var = sum((z - mean) ** 2 for z in logits) / len(logits)
    return mean - k * sqrt(var + eps)


class PessimisticJudge:
    """The members' pessimistic logit as one differentiable judge (same call as a Judge), so the
    generator can be trained against it exactly as against a single judge."""

    def __init__(self, members: list[Judge], k: float):
        import torch

        self.members, self.k = members, float(k)
        self.config = members[0].config
        self._torch = torch

    def __call__(self, x, env):
        torch = self._torch
        return pessimistic([m(x, env) for m in self.members], self.k, torch.sqrt, torch.minimum)

    def eval(self) -> "PessimisticJudge":
        for m in self.members:
            m.eval()
        return self

    def parameters(self):
        return (p for m in self.members for p in m.parameters())


def is_ensemble(path: str | Path) -> bool:
    return (Path(path) / "ensemble.json").exists()


def load_ensemble(path: str | Path) -> tuple[list[Judge], dict]:
    """The members, checked against the hashes the manifest recorded."""
    path = Path(path)
    manifest = path / "ensemble.json"
    if not manifest.exists():
        raise JudgeError(f"{path}: not a judge ensemble (no ensemble.json; make one with `judgeopt train-ensemble`)")
    try:
        meta = json.loads(manifest.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise JudgeError(f"{manifest}: corrupt ensemble manifest ({exc})") from None
    check_header(meta, str(manifest), FORMAT, VERSION, JudgeError, "ensemble manifest")
    if not meta.get("members"):
        raise JudgeError(f"{manifest}: the ensemble manifest lists no members")
    members = []
    for m in meta["members"]:
        judge, jmeta = load_judge(path / m["name"])
        if jmeta["weights_sha256"] != m["weights_sha256"]:
            raise JudgeError(f"{path / m['name']}: replaced after the ensemble was assembled (hash differs from "
                             f"{manifest.name}); retrain it with `judgeopt train-ensemble`")
        members.append(judge)
    return members, meta


def train_ensemble(train_path: str | Path, test_path: str | Path | None, out: str | Path,
                   cfg: EnsembleConfig, threads: int | None = None, progress: bool = True) -> Path:
    """Train (or finish training) the K members; member i: seed + i, its own bootstrap sample."""
    from judgeopt.data.dataset import load
    from judgeopt.judge.data_ranges import env_ranges_of
    from judgeopt.judge.evaluate import evaluate_judge
    from judgeopt.files import sha256_file
    from judgeopt.judge.train import TrainConfig, train_judge

    out = Path(out)
    train, test = load(train_path), (load(test_path) if test_path else None)
    members = []
    for i in range(cfg.k):
        name = f"member_{i}"
        if not (out / f"{name}.json").exists():
            data = train
            if cfg.bootstrap:
                data = train.subset(np.random.default_rng([cfg.seed, i]).integers(0, train.n, train.n))
            tc = TrainConfig(epochs=cfg.epochs, seed=cfg.seed + i, threads=threads, progress=progress)
            model, result = train_judge(data, test, JudgeConfig(arch=cfg.arch), tc=tc)
            metrics = {"val_accuracy": result.best["val_accuracy"], "best_epoch": result.best_epoch}
            if test is not None:
                metrics["test_accuracy"] = evaluate_judge(model, test)["accuracy"]
            save_judge(model, out / name, {"source": f"ensemble member {i} of {cfg.k}", "ensemble": asdict(cfg),
                                           "train_data": {"path": str(train_path), "sha256": sha256_file(train_path),
                                                          "bootstrap_seed": [cfg.seed, i] if cfg.bootstrap else None,
                                                          "env_ranges": env_ranges_of(data)},  # its own sample's
                                           "training_seconds": result.seconds, "metrics": metrics})
        meta = json.loads((out / f"{name}.json").read_text())
        members.append({"name": name, "weights_sha256": meta["weights_sha256"], "metrics": meta.get("metrics", {})})
    manifest = {**header(FORMAT, VERSION), "config": asdict(cfg), "members": members,
                "train_data": str(train_path)}
    atomic_write(out / "ensemble.json", (json.dumps(manifest, indent=2) + "\n").encode())
    return out
