"""What an evaluation table is made of, in the task interface: a task declares its own tables
(the scoop: the paper's) as rows, and judgeopt.evaluate runs them."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, NamedTuple


class PlannerNames(NamedTuple):
    """The registered planners a table's rows name, by what their entries say they are
    (judgeopt.planners.base reads the registry; judgeopt.evaluate hands them to `Table.rows`)."""

    every: tuple[str, ...]
    paper: tuple[str, ...]  # the paper's planners (PlannerSpec.paper)
    baselines: tuple[str, ...]  # compared beside them (PlannerSpec.baseline)


class Table(NamedTuple):
    rows: Callable[[PlannerNames], list]  # -> list[Row]
    title: str  # formatted with the problem's name, task, qdot_max, f_min, f_max, env
    problem: str = "problems/paper_sim.toml"  # the default problem


@dataclass(frozen=True)
class Row:
    """One line of a table: `method` a registered planner or random | nojudge | search, with
    `judge` (a model path; None: the problem's); `vary`: one environment variable's range this row
    draws from instead of the problem's (rows with the same range share their environments);
    `overrides` change problem fields for this row only (an ablation, a limit set)."""

    name: str
    method: str
    judge: str | None
    vary: tuple[str, tuple[float, float]] | None = None
    paper: float | None = None  # the paper's success rate for this row, in %
    overrides: tuple[tuple[str, object], ...] = ()

    @property
    def key(self) -> str:
        slug = "".join(c if c.isalnum() else "_" for c in self.name)
        if self.vary is None:
            return f"{slug}__{self.method}__env"
        name, (lo, hi) = self.vary
        return f"{slug}__{self.method}__{name}{lo:g}-{hi:g}"

    @property
    def env_label(self) -> str:
        return "the problem's" if self.vary is None else f"{self.vary[0]} in [{self.vary[1][0]:g}, {self.vary[1][1]:g}]"
