# The types of what judgeopt/__init__.py loads on first use (its module __getattr__): without this
# stub a type checker sees every top-level name as Any. tests/test_api.py keeps it in step with _API.
from judgeopt.api import get_task as get_task
from judgeopt.api import load_judge as load_judge
from judgeopt.api import load_planners as load_planners
from judgeopt.api import load_problem as load_problem
from judgeopt.api import simulator as simulator
from judgeopt.api import solve as solve
from judgeopt.planners.problem import Problem as Problem
from judgeopt.planners.result import PlanResult as PlanResult
from judgeopt.session.solve import SolveReport as SolveReport
from judgeopt.serve.client import Client as Client
from judgeopt.trajectory import Plan as Plan

__version__: str
__all__: list[str]
