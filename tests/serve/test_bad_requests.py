"""Every bad request is a 4xx with one line saying what is wrong, the command line's words where it
has words for the same value, and the server answers the next request as before."""

from __future__ import annotations

import json
import pickle

import pytest
from serving import QUICK, TOKEN

from judgeopt.cli.main import main
from judgeopt.planners.problem import LIMIT_NAMES

PLAN = ("POST", "/v1/plan")


def body(text: str) -> dict:
    return {"raw": text.encode()}


#: name -> (method and path, what is sent, expected status, a phrase the message must hold)
BAD = {
    "malformed JSON": (PLAN, body('{"limits": '), 400, "not valid JSON"),
    "not an object": (PLAN, body("[1, 2]"), 422, "one JSON object"),
    "unknown field": (PLAN, {"json": {"limitz": {}}}, 422, "limitz: unknown field; a request takes problem, robot, limits"),
    "unknown limit": (PLAN, {"json": {"limits": {"qdot": 1.0}}}, 422, "limits.qdot: unknown field; limits takes"),
    "NaN limit": (PLAN, body('{"limits": {"qdot_max": NaN}}'), 422, "expected a finite number"),
    "infinite limit": (PLAN, body('{"limits": {"f_max": Infinity}}'), 422, "expected a finite number"),
    "text for a number": (PLAN, {"json": {"limits": {"qdot_max": "fast"}}}, 422, "limits.qdot_max"),
    "true for a number": (PLAN, {"json": {"limits": {"qdot_max": True}}}, 422, "limits.qdot_max"),
    "a limit below its partner": (PLAN, {"json": {"limits": {"qdot_max": -1.0}}}, 422, "must be below qdot_max"),
    "a pulling force": (PLAN, {"json": {"limits": {"f_min": -1.0}}}, 422, "must not be negative"),
    "one value per missing axis": (PLAN, {"json": {"limits": {"q_min": [0.0, 0.0, 0.0]}}}, 422, "has 3 values"),
    "a huge array": (PLAN, {"json": {"limits": {"q_min": [0.0] * 100}}}, 422, "at most 8"),
    "a body over the limit": (PLAN, {"json": {"limits": {"q_min": [0.0] * 20000}}}, 413, "bytes"),
    "infeasible limits": (PLAN, {"json": {"limits": {"qdot_max": 0.1}}}, 422, "out of reach"),
    "an unknown variable": (PLAN, {"json": {"environment": {"wind": 1.0}}}, 422, "not an environment variable"),
    "a NaN variable": (PLAN, body('{"environment": {"y_obj": NaN}}'), 422, "must be a finite number"),
    "a reversed range": (PLAN, {"json": {"environment": {"y_obj": [0.3, 0.1]}}}, 422, "lo <= hi"),
    "a range of three": (PLAN, {"json": {"environment": {"y_obj": [0.1, 0.2, 0.3]}}}, 422, "environment.y_obj"),
    "an unknown problem": (PLAN, {"json": {"problem": "nope"}}, 422, "not one this server plans"),
    "a relative path": (PLAN, {"json": {"problem": "../../etc/passwd"}}, 422, "problem: String should match"),
    "an absolute path": (PLAN, {"json": {"problem": "/etc/passwd"}}, 422, "problem: String should match"),
    "an unknown planner": (PLAN, {"json": {"methods": ["fastest"]}}, 422, "'fastest' is no planner"),
    "a group with planners": (PLAN, {"json": {"methods": ["default", "direct"]}}, 422, "stands alone"),
    "a closed loop without simulation": (PLAN, {"json": {"methods": ["receding"]}}, 422, "set simulate to true"),
    "an unknown objective": (PLAN, {"json": {"objective": "fastest"}}, 422, "objective"),
    "an unknown arm": (PLAN, {"json": {"robot": "r2d2"}}, 422, "r2d2"),
    "a negative deadline": (PLAN, {"json": {"timeout_s": -1.0}}, 422, "timeout_s"),
    "a deadline over the most": (PLAN, {"json": {"timeout_s": 1e6}}, 422, "at most 300"),
    "text for a flag": (PLAN, {"json": {"simulate": "yes"}}, 422, "simulate"),
    "a malformed bound": (PLAN, {"json": {"constraints": {"bounds": ["f:0"]}}}, 422, "bound"),
    "a pickle": (PLAN, {"raw": pickle.dumps({"limits": {}}), "headers": {"Content-Type": "application/octet-stream"}},
                 415, "send the body as JSON"),
    "no content type": (PLAN, {"raw": json.dumps(QUICK).encode(), "headers": {"Content-Type": ""}}, 415, "JSON"),
    "a lying content length": (PLAN, {"raw": b"{}", "headers": {"Content-Length": "99999999"}}, 413, "bytes"),
    "no such route": (("GET", "/v1/plans"), {}, 404, "no such route"),
    "the wrong method": (("GET", "/v1/plan"), {}, 405, "does not take that method"),
}


def send(service, route, what):
    method, path = route
    if "json" in what:
        return service.call(method, path, what["json"])
    return service.call(method, path, raw=what.get("raw"), headers=what.get("headers"))


def test_there_are_thirty_kinds():
    assert len(BAD) >= 30


@pytest.mark.parametrize("name", list(BAD))
def test_a_bad_request_is_a_4xx_with_one_line(service, name):
    route, what, status, phrase = BAD[name]
    answer = send(service, route, what)
    assert answer.status == status, (answer.status, answer.text)
    message = answer.body["error"]
    assert phrase in message and "\n" not in message and len(message) < 1000, message
    assert "Traceback" not in answer.text


def test_the_server_answers_as_before_after_every_bad_request(service):
    for name, (route, what, _, _) in BAD.items():
        send(service, route, what)
    assert service.plan(QUICK).status == 200
    assert len(service.health()["workers"]) == 1


def cli_error(argv: list[str], capsys) -> str:
    capsys.readouterr()
    try:
        main(["solve", *argv, "--no-simulate", "--json"])
    except SystemExit:  # the parser refused a value: its one line is printed all the same
        pass
    out = json.loads(capsys.readouterr().out)
    return out.get("error") or out["message"]  # an infeasible request: its message


@pytest.mark.parametrize("request_, argv", [
    ({"limits": {"qdot_max": -1.0}}, ["--qdot-max", "-1"]),
    ({"limits": {"f_min": -1.0}}, ["--f-min", "-1"]),
    ({"limits": {"q_min": [0.0, 0.0, 0.0]}}, ["--q-min", "0,0,0"]),
    ({"environment": {"y_obj": [0.3, 0.1]}}, ["--y-obj", "0.3,0.1"]),
    ({"limits": {"qdot_max": 0.1}}, ["--qdot-max", "0.1"]),
    ({"constraints": {"bounds": ["f:0"]}}, ["--bound", "f:0"]),
])
def test_a_bad_value_gets_the_command_lines_message(service, request_, argv, capsys):
    assert service.plan(request_).body["error"] == cli_error(argv, capsys)


@pytest.mark.parametrize("limit", ["qdot_max", "f_max"])
@pytest.mark.parametrize("value", ["NaN", "Infinity"])
def test_a_value_no_limit_can_have_gets_the_command_lines_words(service, limit, value, capsys):
    """The option's type refuses it on the command line: its words after the option's name."""
    served = service.plan(None, raw=f'{{"limits": {{"{limit}": {value}}}}}'.encode()).body["error"]
    said = cli_error([f"--{limit.replace('_', '-')}", {"NaN": "nan", "Infinity": "inf"}[value]], capsys)
    assert said.startswith(f"argument --{limit.replace('_', '-')}: ")
    assert served == f"limits.{limit}: " + said.split(": ", 1)[1]


def test_every_limit_is_checked_by_the_command_lines_type(service):
    for name in LIMIT_NAMES:
        answer = service.plan(None, raw=f'{{"limits": {{"{name}": NaN}}}}'.encode())
        assert answer.status == 422 and answer.body["error"].startswith(f"limits.{name}: expected a finite number")


def test_the_token_is_needed_everywhere_but_health(service):
    assert service.call("GET", "/v1/health", token=None).status == 200
    for method, path, sent in (("POST", "/v1/plan", QUICK), ("GET", "/v1/ready", None), ("GET", "/v1/models", None),
                               ("GET", "/metrics", None), ("GET", "/openapi.json", None), ("GET", "/docs", None)):
        for token in (None, "wrong", TOKEN[:-1], TOKEN + "x"):
            answer = service.call(method, path, sent, token=token)
            assert answer.status == 401 and answer.headers["www-authenticate"] == "Bearer", (path, token)
            assert "bearer token" in answer.body["error"]
        assert service.call(method, path, sent).status == 200, path
