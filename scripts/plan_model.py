"""A success model of the plans themselves, tried offline on replayed band plans (issue 43, item 1).

The shipped calibrators map the judge's p and the limits and environment to a calibrated p, one per
planner; at the edge they cannot tell a plan that ends 3.3 cm off the blade's centre from one that ends
3.8 cm off (docs/verdict.md, "Where the confident failures lie"). This script fits one gradient-boosted
classifier (scikit-learn) over every planner's replayed plans: the judge's logit, the limits, the
environment, the constraint set drawn, the planner, and the plan's samples (its channels at every
knot). Its thresholds are set as judgeopt sets them (the lowest of the risk grid whose 95 % Clopper-Pearson
bound is <= the risk) on out-of-fold p: each band folder scored by a model fitted on the others. The
model fitted on every folder then scores the held-out folders, and the same table judgeopt's band
report gives is printed per planner and for the plan to run (the highest p among the plans that hold
their limits; the default planners and with `held`).

    python scripts/plan_model.py out/band/fit_s101 out/band/fit_s808_constrained ... --heldout out/band/heldout_s202

The shipped form is `judgeopt calibrate --plan-model` (judgeopt.verdict.plan_model); this script is
where a feature set is tried first (`--no-plan`: without the plan's samples). docs/verdict.md, "A model
of the plans", has what both measured.
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np

from judgeopt.evaluate.stored import StoredRowsError, read_rows
from judgeopt.verdict.calibration import inputs
from judgeopt.verdict.plan_model import PlanModel
from judgeopt.verdict.risk import GRID, HOLD_TOL, RISK, upper_bound

PLANNERS = ("amortized", "direct", "held")


def features(rows: list[dict], names: list[str], plan: bool = True) -> np.ndarray:
    """The plans as judgeopt's plan model reads them (PlanModel.features); `names`: the limits and
    environment variables, in order; without the plan's samples where not `plan`."""
    channels = list(rows[0]["channels"]) if plan else []
    return PlanModel(names, [], [], list(PLANNERS), channels, 0, 0.0, [], 0, {}).features(
        [{**r, "band_constraints": r.get("band_constraints") or {}} for r in rows])


def holds(r: dict) -> bool:
    return (r.get("max_constraint_violation") or 0.0) <= HOLD_TOL


def threshold(p: np.ndarray, success: np.ndarray, risk: float) -> tuple[float, int, int, float] | None:
    """The lowest grid threshold whose bound on the failure rate above it is <= risk: (t, n, failures, bound)."""
    for t in GRID:
        s = p >= t
        n, k = int(s.sum()), int((~success[s]).sum())
        if n and upper_bound(k, n) <= risk:
            return t, n, k, upper_bound(k, n)
    return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+", help="band folders to fit on (each one fold of the out-of-fold p)")
    ap.add_argument("--heldout", nargs="+", required=True, help="band folders to score, never fitted on")
    ap.add_argument("--risk", type=float, default=RISK)
    ap.add_argument("--no-plan", action="store_true", help="leave the plan's samples out (the ablation)")
    ap.add_argument("--trees", type=int, default=300)
    args = ap.parse_args()
    if len(args.folders) < 2:
        raise SystemExit("plan_model.py: give at least two folders to fit on (each is scored by a model of the others)")
    from sklearn.ensemble import HistGradientBoostingClassifier

    def replayed(folder: str) -> list[dict]:
        try:
            rows = read_rows([folder])
        except StoredRowsError as exc:
            raise SystemExit(f"plan_model.py: {exc}") from None
        return [r for r in rows if r.get("method") in PLANNERS and r.get("predicted_success") is not None
                and r.get("simulated_success") is not None]

    folds = {f: replayed(f) for f in args.folders}
    names = sorted({k for rs in folds.values() for r in rs for k in inputs(r.get("limits", {}), r["environment"])})

    def fitted(rows: list[dict]):
        X = features(rows, names, not args.no_plan)
        y = np.array([bool(r["simulated_success"]) for r in rows])
        return HistGradientBoostingClassifier(max_iter=args.trees, learning_rate=0.05, early_stopping=False,
                                              random_state=0).fit(X, y)

    def score(model, rows: list[dict]) -> None:
        p = model.predict_proba(features(rows, names, not args.no_plan))[:, 1]
        for r, v in zip(rows, p):
            r["_p"] = float(v)

    for f, rows in folds.items():  # out of fold: each folder by a model of the others
        score(fitted([r for g, rs in folds.items() if g != f for r in rs]), rows)
    pooled = [r for rs in folds.values() for r in rs if holds(r)]
    at = {}
    for m in PLANNERS:
        rs = [r for r in pooled if r["method"] == m]
        found = threshold(np.array([r["_p"] for r in rs]), np.array([bool(r["simulated_success"]) for r in rs]),
                          args.risk) if rs else None
        if found:
            at[m] = found[0]
        print(f"{m}: " + (f"likely at p >= {found[0]:g} ({found[1]} out-of-fold plans, {found[2]} failed, bound "
                          f"{100 * found[3]:.1f} %)" if found else "no threshold holds the risk"))
    model = fitted([r for rs in folds.values() for r in rs])
    print(f"fitted on {sum(map(len, folds.values()))} plans of {len(folds)} folders; scored on the held-out folders:")
    print("| held-out | planners | called likely / failed (bound) | some plan succeeded: plan to run likely and succeeded |")
    print("|---|---|---|---|")
    for folder in args.heldout:
        rows = replayed(folder)
        score(model, rows)
        for planners in (PLANNERS[:2], PLANNERS):
            per = []
            for m in planners:
                called = [r for r in rows if r["method"] == m and holds(r) and m in at and r["_p"] >= at[m]]
                failed = sum(not r["simulated_success"] for r in called)
                per.append(f"{m} {len(called)} / {failed}")
            by = defaultdict(list)
            for r in rows:
                if r["method"] in planners:
                    by[r["env_index"]].append(r)
            with_success = likely = failed = good = 0
            for plans in by.values():
                with_success += any(r["simulated_success"] for r in plans)
                run = max((r for r in plans if holds(r)), key=lambda r: r["_p"], default=None)
                if run is not None and run["method"] in at and run["_p"] >= at[run["method"]]:
                    likely += 1
                    failed += not run["simulated_success"]
                    good += bool(run["simulated_success"])
            print(f"| {folder} | {' '.join(planners)} | {', '.join(per)}; plan to run {likely} / {failed} "
                  f"({100 * upper_bound(failed, likely):.1f} %) | {good} of {with_success} "
                  f"({100 * good / max(with_success, 1):.0f} %) |")


if __name__ == "__main__":
    main()
