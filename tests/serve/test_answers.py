"""The service's answer is the object `judgeopt solve --json` prints for the same request, from a
worker that has answered other requests before (its loaded planners reused), and the client and
`solve --server` give what a local solve gives."""

from __future__ import annotations

import json
import math
import re

import pytest

from judgeopt.cli.main import main

from serving import QUICK, SLOW, TOKEN

#: (request, the same on the command line): a default request, another problem's limits with the
#: environment and one planner, an environment range (planned over a grid), [constraints], an
#: unlikely one (its suggestions searched), an infeasible one
CASES = {
    "limit": (QUICK, ["--qdot-max", "0.4"]),
    "environment and planner": ({"limits": {"qdot_max": 0.3, "f_min": 8.0}, "environment": {"y_obj": 0.22, "mu": 2.5},
                                 "methods": ["direct"]},
                                ["--qdot-max", "0.3", "--f-min", "8", "--y-obj", "0.22", "--mu", "2.5", "--method",
                                 "direct"]),
    "range": ({"environment": {"y_obj": [0.16, 0.22]}}, ["--y-obj", "0.16,0.22"]),
    "constraints": ({"constraints": {"a_max": 2.0, "bounds": ["f:0:20@0:0.4"]}},
                    ["--a-max", "2", "--bound", "f:0:20@0:0.4"]),
    "unlikely": (SLOW, ["--f-max", "11", "--mu", "3"]),
    "infeasible": ({"limits": {"qdot_max": 0.1}}, ["--qdot-max", "0.1"]),
    "simulated": ({**QUICK, "simulate": True}, ["--qdot-max", "0.4", "--simulate"]),
    "another arm": ({"robot": "kinova", "methods": ["direct"]}, ["--robot", "kinova", "--method", "direct"]),
}
#: what differs between two runs of the same solve: how long it took
TIMING = {"solve_time_s"}


def solve_json(argv: list[str], capsys) -> dict:
    """`judgeopt solve ... --json` (--no-simulate unless --simulate), in this process: the object it prints."""
    capsys.readouterr()
    main(["solve", *argv, *([] if "--simulate" in argv else ["--no-simulate"]), "--json"])
    return json.loads(capsys.readouterr().out)


def assert_same(served, local, where: str = "answer") -> None:
    """Equal but for timings; numbers to 1e-6 relative (the same solve in another process)."""
    if isinstance(local, dict):
        assert isinstance(served, dict) and set(served) == set(local), (where, set(served) ^ set(local))
        for k in local:
            if k not in TIMING:
                assert_same(served[k], local[k], f"{where}.{k}")
    elif isinstance(local, list):
        assert isinstance(served, list) and len(served) == len(local), where
        for i, (a, b) in enumerate(zip(served, local)):
            assert_same(a, b, f"{where}[{i}]")
    elif isinstance(local, float) and not isinstance(served, bool):
        assert math.isclose(served, local, rel_tol=1e-6, abs_tol=1e-9), (where, served, local)
    else:
        assert served == local, (where, served, local)


LOCAL: dict[str, dict] = {}


@pytest.mark.parametrize("case", list(CASES))
def test_the_answer_is_what_solve_json_prints(service, case, capsys):
    request, argv = CASES[case]
    answer = service.plan(request)
    local = LOCAL[case] = solve_json(argv, capsys)
    if local["status"] == "infeasible":  # 422, the command line's object with its message as the error
        assert answer.status == 422 and answer.body.pop("error") == local["message"]
    else:
        assert answer.status == 200, answer.text
        assert len(local["results"]) >= 1 and local["results"][0]["t"]  # a plan is compared, not an empty list
        assert (local["results"][0]["simulated_success"] is None) == (not request.get("simulate"))
    assert_same(answer.body, local)


def test_a_worker_that_planned_others_gives_the_same_answer_again(service, capsys):
    """Its planners are reused (loaded once per problem and limits): nothing of one request leaks
    into the next (notes, warm starts, the range's grid)."""
    for case in ("range", "limit", "simulated", "range", "environment and planner", "simulated"):
        local = LOCAL.get(case) or solve_json(CASES[case][1], capsys)
        assert_same(service.plan(CASES[case][0]).body, local, case)


def test_a_new_environment_is_answered_as_solve_answers_it(service, capsys):
    """A robot re-plans with the object elsewhere: the worker plans with the planners it loaded for
    these limits (Planners.in_environment), and each answer is the command line's for that environment,
    the suggestions re-planned under relaxed limits included."""
    for env in ({"y_obj": 0.13, "mu": 1.4}, {"y_obj": 0.25, "mu": 2.6}):
        argv = ["--qdot-max", "0.4", "--y-obj", str(env["y_obj"]), "--mu", str(env["mu"])]
        assert_same(service.plan({**QUICK, "environment": env}).body, solve_json(argv, capsys), str(env))
    moved = {**SLOW, "environment": {"mu": 2.9, "y_obj": 0.21}}
    local = solve_json(["--f-max", "11", "--mu", "2.9", "--y-obj", "0.21"], capsys)
    assert local["suggestions"], "unlikely there, with a relaxation that makes a plan likely"
    assert_same(service.plan(moved).body, local, "suggestions")


def test_the_client_gets_the_http_answer(service):
    import judgeopt
    from judgeopt.serve.client import ServiceError

    with judgeopt.Client(service.url, TOKEN) as client:
        assert_same(client.plan(limits={"qdot_max": 0.4}), service.plan(QUICK).body)
        assert client.ready()["ready"] is True
        with pytest.raises(ServiceError) as exc:
            client.plan(limits={"qdot_max": -1.0})
    assert exc.value.status == 422 and "qdot_max" in str(exc.value) and "\n" not in str(exc.value)
    with pytest.raises(ServiceError, match="cannot reach the planning service"):
        judgeopt.Client("http://127.0.0.1:9", timeout_s=2).health()


def without_times(text: str) -> list[str]:
    """Printed lines without what depends on how long it took: the time column (its values, and
    its header's and rule's width, which follow the longest value) and the total."""
    lines = [re.sub(r"\s+\d+(\.\d+)? (ms|s)\s*$", "", line) for line in text.splitlines()
             if not line.startswith("total ")]
    return [re.sub(r"\s+(time|-+)\s*$", "", line) if line.startswith(("method ", "---")) else line
            for line in lines]


@pytest.mark.parametrize("case", ["limit", "unlikely"])
def test_solve_server_prints_what_a_local_solve_prints(service, case, tmp_path, capsys):
    argv = ["solve", *CASES[case][1], "--no-simulate"]
    (tmp_path / "token").write_text(TOKEN)
    remote = ["--server", service.url, "--token-file", str(tmp_path / "token")]
    capsys.readouterr()
    local_code = main(argv)
    local = capsys.readouterr().out
    assert main([*argv, *remote]) == local_code
    served = capsys.readouterr().out
    lines = [line for line in without_times(local) if not line.startswith("  (searched by re-planning")]
    assert without_times(served) == lines
    assert any(line.startswith("direct ") for line in lines)  # the table was compared
    assert main([*argv, *remote, "--json"]) == local_code
    assert_same(json.loads(capsys.readouterr().out), LOCAL.get(case) or solve_json(CASES[case][1], capsys))


def test_solve_server_refuses_what_it_does_not_send(service, capsys):
    assert main(["solve", "--server", service.url, "--plot", "plan.png"]) == 2
    assert "--plot: not sent to a planning service" in capsys.readouterr().err
    assert main(["solve", "--server", service.url, "--p-target", "0.9"]) == 2
    assert "--p-target" in capsys.readouterr().err


def test_solve_server_imports_no_torch(service, tmp_path):
    """The client's side of a plan loads no model and never imports torch (seconds on its own)."""
    import subprocess
    import sys

    from judgeopt.files import REPO

    (tmp_path / "token").write_text(TOKEN)
    code = ("import sys; from judgeopt.cli.main import main; "
            f"rc = main(['solve', '--qdot-max', '0.4', '--no-simulate', '--server', {service.url!r}, "
            f"'--token-file', {str(tmp_path / 'token')!r}]); print('torch' in sys.modules, rc)")
    r = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, timeout=120)
    assert r.stdout.splitlines()[-1] == "False 0", r.stdout + r.stderr
    assert "direct" in r.stdout


@pytest.mark.parametrize("case", ["unlikely", "range"])
def test_a_report_read_back_from_its_json_writes_the_same_json(case, capsys):
    """What `solve --server` prints from: the answer read back (plans, verdicts, suggestions)."""
    from judgeopt.session.solve import SolveReport

    local = LOCAL.get(case) or solve_json(CASES[case][1], capsys)
    report = SolveReport.from_json(local)
    assert report.verdict == local["verdict"] and len(report.suggestions) == len(local["suggestions"])
    assert_same(report.to_json(), local)
