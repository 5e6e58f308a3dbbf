"""Active collection: keep only the random demonstrations a judge is unsure about.

Why: a judge's errors sit near its decision boundary (on the scoop, 80-90 % of the errors of the
demonstrations-only LSTM judge of docs/judge.md fall where its probability lies in (0.02, 0.98), a
fifth of random demonstrations).
Simulating a demonstration costs ~0.2 s and judging its command ~1 ms, so drawing candidates
until the judge is unsure puts several times more of the simulation budget where a judge
learns (`judgeopt collect --focus JUDGE`).

Before simulating there is no response, so the judge reads the COMMAND in its place: the
response is the command tracked (y within millimetres, f within newtons), and on the scoop's
test set the judge's decision on the command agrees with its decision on the response 95 % of
the time. A judge trained with `train-judge --with-commands` reads commands about as well as
responses (docs/judge.md, "Commands as a second view").

A focused collection is not a sample of the task's distribution: its success ratio, and the
calibration of a judge trained on it alone, differ from the random set's. Add it to random
demonstrations; never measure accuracy on it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from judgeopt.judge.errors import JudgeError
from judgeopt.parallel import worker_cache


@dataclass(frozen=True)
class JudgeFocus:
    """Accept a candidate demonstration when `judge`'s probability of success on its command
    lies strictly inside `band`. Pickles as its path (workers load the judge once each)."""

    judge: str
    weights_sha256: str
    band: tuple[float, float] = (0.02, 0.98)
    #: candidates drawn per demonstration before the last one is kept anyway (counted as a miss)
    tries: int = 50

    def __post_init__(self) -> None:
        lo, hi = self.band
        if not 0.0 <= lo < hi <= 1.0:
            raise JudgeError(f"focus band {lo},{hi} must satisfy 0 <= LO < HI <= 1, e.g. 0.02,0.98")
        if self.tries < 1:
            raise JudgeError(f"focus tries {self.tries} must be >= 1")

    @classmethod
    def of(cls, path: str, band: tuple[float, float] | None = None, tries: int | None = None,
           env_names: tuple[str, ...] | None = None, horizon: int | None = None, dt: float | None = None) -> "JudgeFocus":
        """Load and check the judge now (a bad file is one line here, not in every worker);
        band and tries None: the defaults above."""
        from judgeopt.judge.store import check_compatible, load_judge

        judge, meta = load_judge(path)
        check_compatible(judge.config, horizon=horizon, dt=dt, env_names=env_names)
        given = {k: v for k, v in (("band", None if band is None else tuple(band)), ("tries", tries)) if v is not None}
        focus = cls(judge=str(path), weights_sha256=meta["weights_sha256"], **given)
        worker_cache(focus._key, lambda: judge)  # this process needs no second load
        return focus

    @property
    def _key(self) -> str:
        return f"focus judge {self.weights_sha256}"

    def _load(self) -> Any:
        from judgeopt.judge.store import load_judge

        judge, meta = load_judge(self.judge)
        if meta["weights_sha256"] != self.weights_sha256:
            raise JudgeError(f"{self.judge} changed since the collection started (weights sha256 differs)")
        return judge

    def probability(self, command: np.ndarray, env: dict[str, float]) -> float:
        """The judge's probability on one command. Sets torch to one thread for the process: a
        collection runs one process per core, and a second thread costs 10x here (1 ms -> 12 ms
        per call on a busy 2-core machine); one thread also makes the band test bit-reproducible."""
        import torch

        if torch.get_num_threads() != 1:
            torch.set_num_threads(1)
        judge = worker_cache(self._key, self._load)
        e = np.array([env[k] for k in judge.config.env_names])
        return float(judge.predict_proba(np.asarray(command), e)[0])

    def accepts(self, command: np.ndarray, env: dict[str, float]) -> bool:
        lo, hi = self.band
        return lo < self.probability(command, env) < hi
