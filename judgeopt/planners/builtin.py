"""The built-in planners, registered as a planner of your own is: one `register` line each.

Imported with `judgeopt.planners`, so the built-ins come first in the registry (and in every list
of planners), then the planners installed packages declare (entry-point group "judgeopt.planners").
Each class lives in its own module, imported only when the planner is first built.
"""

from __future__ import annotations

from judgeopt.planners.base import PlannerSpec, register, register_installed

register(PlannerSpec(
    "amortized", "the paper's generator (eqs. 2-4): a plan in a millisecond, limits held softly",
    "judgeopt.planners.amortized:AmortizedPlanner", needs=("judge", "generator"), models=("judge", "generator"),
    default=True, paper=True))
register(PlannerSpec(
    "direct", "Ipopt over the judge's CasADi function, every limit and the terminal state hard, warm-started from "
    "the generator's plan", "judgeopt.planners.direct:DirectPlanner", warm_start="amortized",
    models=("judge", "generator", "ensemble", "trust_model"), reads=("objective", "p_target"), default=True,
    paper=True))
register(PlannerSpec(
    "cem", "the sampling baseline: cross-entropy search over spline commands, the same judge",
    "judgeopt.planners.cem:CEMPlanner", baseline=True))
register(PlannerSpec(
    "receding", "the direct solve re-run during execution, every [solver] replan_period, from what the arm measured",
    "judgeopt.planners.receding:RecedingPlanner", needs=("judge", "simulator"), uses=("direct",),
    models=("judge", "generator", "ensemble", "trust_model"), reads=("replan_period", "replan_trigger")))
register(PlannerSpec(
    "cmaes", "the sampling baseline's search by the cmaes library (CMA-ES), the CEM's space, score and budget: "
    "measured beside it (benchmarks/bench_sampling.py), not run by default",
    "judgeopt.planners.cmaes_search:CMAESPlanner"))

register(PlannerSpec(
    "held", "the generator's plan made to hold every hard limit: the nearest plan that does (one Ipopt solve, the "
    "judge free)", "judgeopt.planners.held:HeldPlanner", warm_start="amortized", models=("judge", "generator")))

register_installed()  # after the built-ins: installed packages' planners (entry-point group judgeopt.planners)
