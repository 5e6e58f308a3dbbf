"""Problems and the planners for them; importing the package registers the built-in planners
(judgeopt.planners.builtin) before any planner of your own."""

from judgeopt.planners import builtin  # noqa: F401
