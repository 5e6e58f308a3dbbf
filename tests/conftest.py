import os

# one BLAS thread, in this process and the commands tests start: the 2-core runners are shared with
# worker processes, and an oversubscribed OpenBLAS made a calibration fit 8-10 s instead of 0.3 s.
# Set before numpy loads; threadpoolctl for when a pytest plugin loaded it first.
os.environ.setdefault("OMP_NUM_THREADS", "1")

import numpy as np  # noqa: E402
import pytest  # noqa: E402
from threadpoolctl import threadpool_limits  # noqa: E402

threadpool_limits(int(os.environ["OMP_NUM_THREADS"]))


@pytest.fixture(scope="session", autouse=True)
def _fresh_joint_maps():
    """Each session tabulates its arms' joint maps itself (judgeopt.planners.joint_limits caches them per
    process): a session started in a process that ran one before (mutmut's forked runs) tests the code as it
    is now, not maps an earlier session left behind."""
    import sys

    module = sys.modules.get("judgeopt.planners.joint_limits")
    if module is not None:
        module._CACHE.clear()


@pytest.fixture(scope="session")
def sim():
    """One simulator for the whole session: building the scene costs a fraction of a second,
    and rollouts are independent of each other (tested)."""
    from judgeopt.tasks.scoop.rollout import Simulator

    s = Simulator()
    yield s
    s.close()


def min_jerk_plan(y0: float, y1: float, t_move: float, force: float, horizon: int = 30, dt: float = 0.05):
    from judgeopt.tasks.scoop import scoop_plan

    t = np.arange(horizon + 1) * dt
    s = np.clip(t / t_move, 0, 1)
    y = y0 + (y1 - y0) * (10 * s**3 - 15 * s**4 + 6 * s**5)
    yd = (y1 - y0) * (30 * s**2 - 60 * s**3 + 30 * s**4) / t_move * (t <= t_move)
    return scoop_plan(dt, y, yd, np.full(horizon + 1, force))


@pytest.fixture(scope="session")
def indifferent():
    """A CasADi judge of the scoop's shape (30 steps, 2 environment values) whose logit is 5 (p = 0.993,
    over the default p_target) whatever the plan: under it a planner's answer is the limits' alone."""
    import casadi as cs

    from judgeopt.judge.casadi_fn import CasadiJudge

    traj, env = cs.MX.sym("traj", 31 * 3), cs.MX.sym("env", 2)
    fn = cs.Function("indifferent", [traj, env], [5.0 + 0 * cs.sum1(traj) + 0 * cs.sum1(env)])
    return CasadiJudge(fn, "constant", 0.0, horizon=30, n_env=2)


def direct_result(predicted, **info):
    """A direct plan (a min-jerk scoop) whose judge said `predicted`, with `info` as its planner set it."""
    from judgeopt.planners.result import PlanResult

    return PlanResult("direct", {"y_obj": 0.2, "mu": 2.0}, min_jerk_plan(-0.03, 0.2, 1.2, 12.0), predicted, "solved",
                      0.1, info=dict(info))


@pytest.fixture
def module_copy(tmp_path, monkeypatch):
    """copy(module, old=None, new=None): `module`'s source as a new module of its own (a file in
    tmp_path, registered in sys.modules so inspect.getsource reads it), with `old` replaced by
    `new` where given (it must occur exactly once). Why: the cache-key tests make a real edit to
    the code that generates a library without touching the package."""
    import importlib.util
    import inspect
    import itertools
    import sys

    counter = itertools.count()

    def copy(module, old=None, new=None):
        text = inspect.getsource(module)
        if old is not None:
            assert text.count(old) == 1, f"{old!r} is not in {module.__name__} exactly once"
            text = text.replace(old, new)
        name = f"_copy{next(counter)}_{module.__name__.replace('.', '_')}"
        path = tmp_path / f"{name}.py"
        path.write_text(text)
        spec = importlib.util.spec_from_file_location(name, path)
        mod = importlib.util.module_from_spec(spec)
        monkeypatch.setitem(sys.modules, name, mod)
        spec.loader.exec_module(mod)
        return mod

    return copy


@pytest.fixture(scope="session")
def service(tmp_path_factory):
    """The session's planning service (tests/serve/serving.py starts it): one worker, a queue of one, a
    token; what the answer, input and fault tests share. A test that kills the worker waits for its
    replacement before it ends. Here, not in a tests/serve/conftest.py: a second module named conftest
    would shadow this one for the tests that import min_jerk_plan from it."""
    pytest.importorskip("fastapi")  # the serve extra
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parent / "serve"))
    from serving import TOKEN, start

    s = start(tmp_path_factory.mktemp("service"), "--workers", "1", "--queue", "1", token=TOKEN)
    yield s
    assert s.stop() == 0
