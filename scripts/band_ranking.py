"""How far any threshold on a score can go on replayed band plans: ranked by the score, how many plans
that succeeded come before the first, second and third failure. At a 2 % risk a threshold admits
about one failure in 200, so the count before the first failure bounds how many successful plans
can be called likely (issue 43's "likely and succeeded" target), whatever the evidence.

    python scripts/band_ranking.py out/band/heldout_s202 --method direct

Scores: the p judgeopt stands behind (the calibration of --calibration, else the judge's), the
judge's own p, and the mean and the minimum of the ensemble members' p where the rows carry them
(`evaluate band --ensemble`). With `--fit FOLDER...`, also a calibrator of the project's form (the judge's
logit, the limits and the environment as inputs; judgeopt.verdict.calibration.fit) fitted on those folders'
plans of the method and applied to these: a cross-fit, to try a calibration before shipping one.

    python scripts/band_ranking.py out/band/heldout_s404_constrained --method held --fit out/band/fit_s808_constrained
"""

from __future__ import annotations

import argparse

import numpy as np

from judgeopt.evaluate.stored import StoredRowsError, read_rows


def ranked_successes(score: np.ndarray, success: np.ndarray, failures: int = 3) -> list[int]:
    """Successes ranked above the 1st, 2nd, ... failure (ties broken against the score: a failure
    tied with successes comes first)."""
    order = np.lexsort((success, -score))  # highest score first; within a tie, failures first
    ranked = success[order]
    out = []
    for k in range(1, failures + 1):
        failed = np.flatnonzero(~ranked)
        out.append(int(ranked[:failed[k - 1]].sum()) if len(failed) >= k else int(ranked.sum()))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("folders", nargs="+")
    ap.add_argument("--method", default="direct")
    ap.add_argument("--calibration", default="models/calibration_default.json")
    ap.add_argument("--fit", nargs="+", metavar="FOLDER", help="also rank by a calibrator fitted on these folders' plans")
    ap.add_argument("--constraint-sets", choices=("all", "with", "without"), default="all",
                    help="only the plans drawn with (or without) a constraint set, in both the ranked and the fitted folders")
    args = ap.parse_args()
    from judgeopt.files import resolve
    from judgeopt.verdict.calibration import calibrate_rows, fit, inputs, load_calibration_file
    from judgeopt.verdict.risk import HOLD_TOL, capped

    def plans(folders: list[str]) -> list[dict]:
        try:
            stored = read_rows(folders)
        except StoredRowsError as exc:  # a folder with no evaluation: one line, not a traceback
            raise SystemExit(f"band_ranking.py: {exc}") from None
        rows = [r for r in stored
                if r.get("method") == args.method and r.get("predicted_success") is not None
                and r.get("simulated_success") is not None and (r.get("max_constraint_violation") or 0.0) <= HOLD_TOL
                and args.constraint_sets in ("all", "with" if r.get("band_constraints") else "without")]
        if not rows:
            raise SystemExit(f"{folders}: no replayed {args.method} plans that hold their limits")
        return rows

    rows = plans(args.folders)
    calibrators, evidence = load_calibration_file(resolve(args.calibration))
    calibrate_rows(rows, calibrators)
    # a raise of a judge's p below 0.5 goes no higher than the evidence backs (as solve prints it)
    floor = next((e.raise_floor for e in evidence.values() if e.method == args.method), 0.0)
    y = np.array([bool(r["simulated_success"]) for r in rows])
    judge = np.array([r["predicted_success"] for r in rows])
    scores = {"p stood behind": np.array([capped(j, r["calibrated_success"], floor) if r.get("calibration_covers")
                                          else j for r, j in zip(rows, judge)]),
              "judge's own p": judge}
    if args.fit:
        fitted = plans(args.fit)
        names = list(inputs(fitted[0].get("limits", {}), fitted[0]["environment"]))

        def values(rs: list[dict]) -> np.ndarray:
            return np.array([[inputs(r.get("limits", {}), r["environment"])[k] for k in names] for r in rs])

        cal = fit("cross-fit", args.method, "cross-fit", names, values(fitted),
                  np.array([r["predicted_success"] for r in fitted]), np.array([float(r["simulated_success"]) for r in fitted]))
        scores[f"calibrated, fitted on {len(fitted)} plans of {' '.join(args.fit)}"] = cal.predict(values(rows), judge)
    if all(r.get("ensemble_p") for r in rows):
        members = np.array([r["ensemble_p"] for r in rows])
        scores |= {"ensemble mean": members.mean(axis=1), "ensemble min": members.min(axis=1)}
    which = {"all": "", "with": ", drawn with a constraint set", "without": ", drawn without a constraint set"}[args.constraint_sets]
    print(f"{len(rows)} {args.method} plans that hold their limits{which}, {int(y.sum())} succeeded ({' '.join(args.folders)})")
    print("| score | successes ranked above failure 1 / 2 / 3 |")
    print("|---|---|")
    for name, s in scores.items():
        print(f"| {name} | {' / '.join(map(str, ranked_successes(s, y)))} |")


if __name__ == "__main__":
    main()
