"""What a judge can read of a demonstration, in a module that imports nothing heavy (`judgeopt
test-judge --view` lists it at start-up; judge.evaluate scores either)."""

from __future__ import annotations

#: the measured trajectory (the paper's judge) or the commanded one (what a planner hands the judge: its plan)
VIEWS: tuple[str, ...] = ("response", "command")
