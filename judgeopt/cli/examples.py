"""Examples in help texts and messages, built from the default task's own names and ranges: the
command line shows real variables while its code names no task's."""

from __future__ import annotations

from judgeopt.tasks import DEFAULT_TASK, EnvVar, get_task


def example_variable() -> EnvVar:
    """The default task's first environment variable."""
    return get_task(DEFAULT_TASK).env_vars[0]


def option(name: str) -> str:
    """The command-line option of a variable or field (`--qdot-max` for qdot_max)."""
    return f"--{name.replace('_', '-')}"


def example_assignment() -> str:
    """NAME=VALUE with the example variable at its nominal value (`--env`, `--simulate-env`)."""
    v = example_variable()
    return f"{v.name}={v.default:g}"


def example_shift() -> str:
    """NAME=DELTA with the example variable, a sixth of its sampled range (`--margin`)."""
    v = example_variable()
    return f"{v.name}={(v.sampled[1] - v.sampled[0]) / 6:.1g}"


def example_range() -> str:
    """`--NAME LO,HI` with the example variable's sampled range."""
    v = example_variable()
    return f"{option(v.name)} {v.sampled[0]:g},{v.sampled[1]:g}"


def example_perturbation() -> str:
    """NAME=LO,HI with the default task's first perturbation over the values it is replayed at
    (`collect --randomize`); "NAME=LO,HI" where the task declares none."""
    ps = get_task(DEFAULT_TASK).perturbations
    if not ps:
        return "NAME=LO,HI"
    return f"{ps[0].name}={min(ps[0].values):g},{max(ps[0].values):g}"
