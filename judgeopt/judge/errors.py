"""The judge's errors, in a module of their own so that the architectures (judgeopt.judge.archs)
and the model (judgeopt.judge.model, which re-exports them) can both raise them."""

from judgeopt.errors import BadInput


class JudgeError(BadInput, ValueError):
    """Base class of every judge error (a ValueError, so generic handlers catch it)."""


class TrajectoryError(JudgeError):
    """A trajectory or environment the judge cannot score: wrong shape or horizon, NaN."""
