"""judgeopt: plan contact-rich motions against a learned success judge.

The top-level API (judgeopt.api), loaded on first use so that `import judgeopt` stays light:
`load_problem`, `load_planners`, `solve`, `load_judge`, `get_task`, `simulator`; the types
`Problem`, `Plan`, `PlanResult`, `SolveReport`; and `Client`, a planning service's (`judgeopt serve`).
"""

from __future__ import annotations

from typing import Any

__version__ = "0.1.0"

_API = {
    "load_problem": "judgeopt.api", "load_planners": "judgeopt.api", "solve": "judgeopt.api",
    "load_judge": "judgeopt.api", "get_task": "judgeopt.api", "simulator": "judgeopt.api",
    "Problem": "judgeopt.planners.problem", "Plan": "judgeopt.trajectory", "PlanResult": "judgeopt.planners.result",
    "SolveReport": "judgeopt.session.solve", "Client": "judgeopt.serve.client",
}
__all__ = [*_API, "__version__"]


def __getattr__(name: str) -> Any:
    if name not in _API:
        raise AttributeError(f"module 'judgeopt' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(_API[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(__all__)
