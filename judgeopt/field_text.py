"""A problem field's value as text, the way the command line takes it (`--qdot-max 0.4`, `--q-min
0.3,0`) and a planning service checks it (judgeopt.serve.schema): one parser per field, one line
when the text is wrong. Here, below both, so that each reads the same field the same way.
"""

from __future__ import annotations

import argparse
import math
from typing import Any, Callable


def finite(text: str) -> float:
    """A number, never nan or inf (a ValueError, as float's, so each option's message holds)."""
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(text)
    return value


def number_or_name(text: str) -> float | str:
    try:
        return float(text)
    except ValueError:
        return text  # "free" or an environment variable; the problem checks which


def per_axis(convert: Callable[[str], Any]) -> Callable[[str], Any]:
    """One value for every axis, or a comma-separated value per axis."""
    def parse(text: str):
        try:
            values = [convert(v) for v in text.split(",")]
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected a finite number or comma-separated numbers, got {text!r}") from None
        return values[0] if len(values) == 1 else values
    return parse


def field_type(name: str) -> Callable[[str], Any]:
    """The parser of problem field `name`'s text (an argparse type: its errors are one line)."""
    from judgeopt.planners.problem import AXIS_FIELDS, FIELD_TYPES, FORCE_FIELDS, SECTIONS

    if name in ("a_max", "jerk_max", "fdot_max"):
        return per_axis(float)  # inf allowed: no limit; the problem checks > 0
    if name == "q_end":
        return per_axis(number_or_name)
    if name in AXIS_FIELDS + FORCE_FIELDS:
        return per_axis(finite)
    if name in SECTIONS["models"] or str(FIELD_TYPES[name]) == "str":
        return str
    return int if str(FIELD_TYPES[name]) == "int" else float
