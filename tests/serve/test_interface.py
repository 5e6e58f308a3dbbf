"""What a client reads about the service: the OpenAPI schema (checked against the guide's table and
the problem's own fields), the models, the metrics in Prometheus' format, and a log a request
cannot write into."""

from __future__ import annotations

import re
import time

from serving import QUICK

from judgeopt.files import REPO
from judgeopt.planners.base import planner_names
from judgeopt.planners.problem import LIMIT_NAMES, SECTIONS

GUIDE = REPO / "docs" / "guides" / "service.md"


def documented(section: str) -> list[str]:
    """The fields a table of the guide lists under `section` (its rows: | `name` | ...)."""
    text = GUIDE.read_text().split(f"\n{section}\n", 1)[1].split("\n#", 1)[0]
    return re.findall(r"^\| `(\w+)` \|", text, re.MULTILINE)


def test_the_schema_has_the_documented_fields_and_refuses_others(service):
    schema = service.call("GET", "/openapi.json").body
    assert {"/v1/plan", "/v1/health", "/v1/ready", "/v1/models", "/metrics"} <= set(schema["paths"])
    assert set(schema["paths"]["/v1/plan"]) == {"post"}
    models = schema["components"]["schemas"]
    request = models["PlanRequest"]
    assert list(request["properties"]) == documented("### The request") and len(request["properties"]) == 9
    assert list(models["Limits"]["properties"]) == list(LIMIT_NAMES) == documented("### Limits")
    assert list(models["Constraints"]["properties"]) == list(SECTIONS["constraints"])
    for name in ("PlanRequest", "Limits", "Constraints"):
        assert models[name]["additionalProperties"] is False, name
    assert set(request["properties"]["objective"]["anyOf"][0]["enum"]) == {"target", "log_p", "min_time"}
    answer = schema["paths"]["/v1/plan"]["post"]["responses"]
    assert {"200", "413", "422", "503", "504"} <= set(answer)
    assert schema["components"]["securitySchemes"]["HTTPBearer"]["scheme"] == "bearer"  # this one has a token


def test_the_models_route_lists_what_a_request_may_name(service):
    models = service.call("GET", "/v1/models").body
    names = {p["name"] for p in models["problems"]}
    shipped = {p.stem for p in (REPO / "judgeopt" / "tasks").glob("*/problems/*.toml")}
    assert names == shipped and "paper_sim" in names
    assert set(models["methods"]["planners"]) == set(planner_names())
    from judgeopt.robots import robot_names

    assert models["robots"] == list(robot_names()) and "kinova" in models["robots"]
    assert models["loaded"]["paper_sim"]["judge_sha256"] == service.plan(QUICK).body["judge_sha256"]


def counts(service) -> dict:
    """Every sample of GET /metrics, parsed as Prometheus parses it: (name, labels) -> value."""
    from prometheus_client.parser import text_string_to_metric_families

    return {(s.name, tuple(sorted(s.labels.items()))): s.value
            for family in text_string_to_metric_families(service.call("GET", "/metrics").text) for s in family.samples}


def test_the_metrics_are_prometheus_text_and_count_what_was_answered(service):
    before = counts(service)
    assert service.plan(QUICK).status == 200 and service.plan({"limitz": 1}).status == 422
    after = counts(service)
    for status in ("200", "422"):
        key = ("judgeopt_requests_total", (("route", "/v1/plan"), ("status", status)))
        assert after[key] == before.get(key, 0) + 1
    for planner in ("amortized", "direct"):
        key = ("judgeopt_planner_seconds_count", (("planner", planner),))
        assert after[key] == before.get(key, 0) + 1
    assert after[("judgeopt_request_seconds_count", (("route", "/v1/plan"),))] >= 2
    assert after[("judgeopt_queue_depth", ())] == 0 and after[("judgeopt_workers_ready", ())] == 1


def test_nothing_a_request_sends_reaches_the_log(service):
    marker = "INJECTED-LINE"
    service.plan({"problem": f"x{marker}", "environment": {marker: 1.0}})
    service.plan(None, raw=f'{{"{marker}": "\\n{marker}"}}'.encode())
    service.call("GET", f"/v1/{marker}?{marker}=1")
    service.call("POST", "/v1/plan", QUICK, headers={"User-Agent": marker, "X-Request-Id": marker})
    service.call("GET", "/v1/health")  # a line after them all: once it is written, theirs are
    t0 = time.monotonic()
    while "GET /v1/health 200" not in service.log.read_text() and time.monotonic() - t0 < 10:
        time.sleep(0.05)
    log = service.log.read_text()
    assert "GET /v1/health 200" in log and "POST /v1/plan 422" in log
    assert marker not in log


def test_a_bug_is_a_500_with_one_line_and_the_request_is_counted():
    """The app raising (a bug) reaches the client as a one-line 500, never a traceback."""
    import asyncio
    import json

    from judgeopt.serve.app import Guard
    from judgeopt.serve.metrics import Metrics

    async def broken(scope, receive, send):
        raise KeyError("a bug\nwith a second line")

    sent: list[dict] = []

    async def send(message):
        sent.append(message)

    async def receive():
        return {"type": "http.request", "body": b"", "more_body": False}

    metrics = Metrics(lambda: 0, lambda: 0, lambda: 0, lambda: 0)
    scope = {"type": "http", "method": "GET", "path": "/v1/models", "headers": []}
    asyncio.run(Guard(broken, None, 100, metrics)(scope, receive, send))
    assert sent[0]["status"] == 500
    body = json.loads(b"".join(m.get("body", b"") for m in sent[1:]))
    assert body["error"].startswith("internal error") and "\n" not in body["error"] and "a bug" not in body["error"]
    assert b'judgeopt_requests_total{route="/v1/models",status="500"} 1.0' in metrics.text()
