"""How a report of planner results reads to a person: a few lines for `print(report)`, a table
(`summary()`) and the plot of its plans (`plot()`), for any report that holds a problem, the
environment planned for and PlanResults (the session's SolveReport).

Why: the dataclass's own repr prints every sample of every plan and the planners it holds, about
100 KB; a notebook user wants the verdict, and the numbers as a table.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from judgeopt.planners.problem import Problem
from judgeopt.planners.result import PlanResult
from judgeopt.verdict.rules import overall_verdict, recommended
from judgeopt.planners.summary import SummaryTable

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#: the columns `print(report)` shows (`summary()` has every one)
SHORT_COLUMNS = ("method", "verdict", "success_probability", "probability_source", "simulated_success", "status",
                 "solve_time_s")


class ReportViews:
    """Mixed into a report dataclass (declared with repr=False, so this repr is the one used)."""

    problem: Problem
    env: dict[str, float]
    results: Sequence[PlanResult]

    def summary(self) -> SummaryTable:
        """One row per planner's result (PlanResult.row): a list of dicts, aligned text when printed."""
        return SummaryTable(r.row() for r in self.results)

    def plot(self, path: str | Path | None = None) -> Figure:
        """Each channel of every plan against time, with the problem's limits and, where a plan was
        replayed, the simulated response (what `judgeopt solve --plot FILE` draws); saved to `path`
        where given (PNG, PDF or SVG by suffix)."""
        from judgeopt.planners.plots import plot_plans

        fig = plot_plans(self.problem, list(self.results))
        if path is not None:
            from judgeopt.files import save_figure

            save_figure(fig, path)
        return fig

    def __repr__(self) -> str:
        verdict = overall_verdict(self.results)
        top = recommended(self.results)
        run = f", run the {top.method} plan" if top is not None and verdict != "infeasible" else ""
        env = ", ".join(f"{k} = {v:g}" for k, v in self.env.items())
        lines = [f"{type(self).__name__} {self.problem.name} (task {self.problem.motion.task}): {verdict}{run}",
                 f"  environment: {env}"]
        lines += ["  " + line for line in self.summary().text(SHORT_COLUMNS).splitlines()]
        return "\n".join(lines)
