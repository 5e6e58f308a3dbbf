"""Plot functions return Figures and leave matplotlib's backend to the user; the plan plot shows a
replayed plan's measured response beside its command; the reliability plot zooms to its points."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap

import numpy as np
import pytest
from matplotlib.figure import Figure

from judgeopt.evaluate.report import plot_reliability, zoomed_range
from judgeopt.files import resolve, save_figure
from judgeopt.planners.plots import plot_plans
from judgeopt.planners.problem import load_problem
from judgeopt.planners.result import PlanResult
from judgeopt.tasks.scoop.tables import compare
from judgeopt.trajectory import Plan


def test_plot_functions_return_figures_and_never_choose_the_backend(tmp_path):
    """In a fresh interpreter whose backend the user chose (svg here, inline in a notebook):
    every plot function builds its Figure without pyplot and without switching the backend."""
    code = textwrap.dedent(f"""
        import sys
        import matplotlib
        from matplotlib.figure import Figure
        from judgeopt.cli.refine import plot
        from judgeopt.data.dataset import load
        from judgeopt.data.plots import plot_velocity_force
        from judgeopt.evaluate.report import plot as plot_summary
        from judgeopt.evaluate.sweep import plot_sweep
        from judgeopt.files import resolve, save_figure
        from judgeopt.judge.train import TrainResult, plot_history

        ds = load(resolve("data/test.h5"))
        history = [{{"epoch": e, "train_accuracy": 0.5 + 0.1 * e, "val_accuracy": 0.5 + 0.09 * e}} for e in (1, 2, 3)]
        summary = [{{"row": "a", "method": "direct", "success_pct": 80.0, "ci95_low_pct": 70.0, "ci95_high_pct": 88.0,
                     "paper_pct": 90.0}}]
        sweep = [{{"limit_set": "s", "method": m, "success_where_feasible_pct": 50.0, "unlikely_where_none_found_pct": 0.0,
                   "nojudge_success_pct": 10.0}} for m in ("amortized", "direct", "cem")]
        figures = [plot_velocity_force(ds, "t"), plot_history(TrainResult(history, 2, history[1], 1.0, 10, 2, 0, {{}})),
                   plot_summary(summary, "t"), plot_sweep(sweep, "t"),
                   plot([{{"round": 1, "method": "direct", "success_pct": 80.0, "predicted_mean": 0.9}}])]
        assert all(isinstance(f, Figure) for f in figures), figures
        for i, f in enumerate(figures):
            save_figure(f, r"{tmp_path}" + f"/{{i}}.png")
        print(matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules)
        """)
    env = {**os.environ, "MPLBACKEND": "svg"}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    assert out.stdout.split()[-2:] == ["svg", "False"]
    assert len(list(tmp_path.glob("*.png"))) == 5


def _result(problem, method: str, response: np.ndarray | None, success: bool | None) -> PlanResult:
    t = np.arange(problem.steps + 1) * problem.dt
    plan = Plan.from_columns(problem.dt, problem.channel_spec, 0.2 * t / t[-1], np.full_like(t, 0.2), np.full_like(t, 15.0))
    return PlanResult(method, {"y_obj": 0.2, "mu": 2.0}, plan, 0.9, "solved", 0.1, simulated_success=success,
                      success_probability=0.9, probability_source="judge", response=response)


def test_plan_plot_shows_the_simulated_response_beside_the_command(tmp_path):
    problem = load_problem(resolve("problems/paper_sim.toml"))
    commanded = _result(problem, "direct", None, None)
    measured = commanded.plan.values + np.array([0.0, 0.0, 30.0])  # a force far above the command
    replayed = _result(problem, "direct", measured, False)

    def lines(fig: Figure) -> dict[str, np.ndarray]:
        return {ln.get_label(): ln.get_ydata() for ax in fig.axes for ln in ax.get_lines()}

    fig = plot_plans(problem, [replayed])
    force = fig.axes[2]
    drawn = {ln.get_label(): ln.get_ydata() for ln in force.get_lines()}
    response = [k for k in drawn if "simulated response (failure)" in k]
    assert len(response) == 1 and np.allclose(drawn[response[0]], measured[:, 2])
    assert force.get_ylim()[1] >= measured[:, 2].max()  # the response is inside the axes, not clipped
    assert not any("simulated" in k for k in lines(plot_plans(problem, [commanded])))
    # a response that does not match the plan's samples is not drawn (nothing misaligned)
    short = _result(problem, "direct", measured[:-1], False)
    assert not any("simulated" in k for k in lines(plot_plans(problem, [short])))
    assert save_figure(fig, tmp_path / "plan.png").stat().st_size > 10_000


def test_reliability_axes_zoom_to_the_points():
    assert zoomed_range([0.95, 0.97, 0.99, 1.0])[0] == pytest.approx(0.9 - 0.002, abs=1e-9)
    assert zoomed_range([0.95, 1.0])[1] == pytest.approx(1.002, abs=1e-9)
    assert zoomed_range([0.2, 0.7]) == pytest.approx((0.15 - 0.012, 0.75 + 0.012))
    from judgeopt.evaluate.tables import table_planners

    rows = compare(table_planners())[:2]
    results = {r.key: [{"predicted_success": p, "simulated_success": i % 10 != 5}  # 90 % observed
                       for i, p in enumerate(np.linspace(0.951, 1.0, 40))] for r in rows}
    fig = plot_reliability(rows, results, "t")
    lo, hi = fig.axes[0].get_xlim()
    assert 0.8 <= lo <= 0.9 and 1.0 <= hi <= 1.01 and fig.axes[0].get_ylim() == (lo, hi)  # not 0-1
    points = [v for ln in fig.axes[0].get_lines() if ln.get_label() != "calibrated"
              for v in (*ln.get_xdata(), *ln.get_ydata())]
    assert points and all(lo <= v <= hi for v in points)


def test_solve_plot_draws_the_replay_beside_the_command(tmp_path, monkeypatch):
    """`judgeopt solve --plot` (simulating, its default) puts the simulated response in the figure;
    with --no-simulate there is none to draw."""
    import judgeopt.files
    from judgeopt.cli.main import main

    saved: list[Figure] = []

    def keep(fig, path, dpi=120):
        saved.append(fig)
        return save_figure(fig, path, dpi)

    monkeypatch.setattr(judgeopt.files, "save_figure", keep)
    for flag, expected in (("--simulate", True), ("--no-simulate", False)):
        png = tmp_path / f"plan{flag}.png"
        assert main(["solve", "--qdot-max", "0.4", "--method", "direct", "--y-obj", "0.2", flag, "--plot", str(png)]) == 0
        labels = [ln.get_label() for ax in saved[-1].axes for ln in ax.get_lines()]
        assert any("simulated response" in k for k in labels) == expected, labels
        assert png.stat().st_size > 10_000
