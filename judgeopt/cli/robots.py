"""`judgeopt robots`: the arms judgeopt simulates and plans for, with their limits as the simulator
and the planners read them (the description file, corrected) and where each correction comes from."""

from __future__ import annotations

import argparse
import json
from typing import Any

from judgeopt.cli.commands import HELP


def describe(name: str, reach: bool = False, check: bool = False) -> dict[str, Any]:
    """One arm as a dict: its config, the joints' limits from the written URDF (Pinocchio); with
    `reach` the segment of the scooping line it holds the spatula on (judgeopt.tasks.scoop.placement); with
    `check` the plant = model and compiled = Python step errors (judgeopt.sim.checks)."""
    import pinocchio as pin

    from judgeopt.robots import get_robot
    from judgeopt.sim.robot import robot_urdf

    spec = get_robot(name)
    model = pin.buildModelFromUrdf(str(robot_urdf(robot=name)))
    corrections = [{"kind": kind, "part": part, "value": fix.value, "source": fix.source}
                   for kind, table in (("velocity limit", spec.velocity_limits), ("effort limit", spec.effort_limits),
                                       ("inertia", spec.inertias), ("mass", spec.masses))
                   for part, fix in table.items()]
    d = {"name": spec.name, "title": spec.title, "description": spec.description, "joints": list(spec.joints),
         "velocity_limit": model.velocityLimit.round(4).tolist(), "effort_limit": model.effortLimit.round(3).tolist(),
         "mass": round(sum(i.mass for i in model.inertias), 3), "base_xyz": list(spec.base_xyz),
         "corrections": corrections, "notes": spec.notes}
    if reach:
        from judgeopt.tasks.scoop.placement import scoop_line

        r = scoop_line(name)
        d["reach"] = r.segment()
        d["joint_limit_margin"] = round(float(r.margin[r.reached].min()), 3) if r.reached.any() else None
    if check:
        from judgeopt.sim.checks import compiled_step_error, plant_model_error

        d["plant_model_error"], d["compiled_step_error"] = plant_model_error(name), compiled_step_error(name)
    return d


def text(d: dict[str, Any]) -> str:
    def span(values: list[float]) -> str:
        lo, hi = min(values), max(values)
        return f"{lo:g}" if lo == hi else f"{lo:g}-{hi:g}"

    lines = [f"{d['name']}: {d['title']} ({len(d['joints'])} joints, {d['mass']:g} kg with the spatula)",
             f"  joint velocity limits [rad/s]: {span(d['velocity_limit'])}; effort limits [N m]: "
             f"{', '.join(f'{v:g}' for v in d['effort_limit'])}",
             f"  base at {tuple(d['base_xyz'])} m in the scene; file {d['description']}"]
    if "reach" in d:
        lines.append("  reach on the scooping line: " + ("none" if d["reach"] is None else
                     f"y {d['reach'][0]:g} to {d['reach'][1]:g} m, joints at least {d['joint_limit_margin']:g} rad "
                     "from their limits"))
    if "plant_model_error" in d:
        lines.append(f"  checks: plant = model to {d['plant_model_error']:.1e} (mass matrices), compiled step = Python "
                     f"step to {d['compiled_step_error']:.1e} (torques); both must be below 1e-9")
    by: dict[tuple[str, str], list[str]] = {}  # (kind, source) -> "part value", in the config's order
    for c in d["corrections"]:
        by.setdefault((c["kind"], c["source"]), []).append(f"{c['part']} {c['value']}")
    lines += [f"  corrected {kind}: {', '.join(items)} (from {source})" for (kind, source), items in by.items()]
    if d["notes"]:
        lines.append(f"  note: {d['notes']}")
    return "\n".join(lines)


def cmd_robots(args: argparse.Namespace) -> int:
    from judgeopt.robots import get_robot, robot_names

    names = [args.robot] if args.robot else robot_names()
    for n in names:
        get_robot(n)  # an unknown arm: one line naming the known ones
    found = [describe(n, args.reach, args.check) for n in names]
    print(json.dumps(found) if args.json else "\n".join(text(d) for d in found))
    return 0


def add_robots_command(sub: argparse._SubParsersAction, parents: list | None = None) -> None:
    """Add `robots` (`parents`: its shared options, default --json)."""
    if parents is None:
        from judgeopt.cli.common import JSON

        parents = [JSON]
    r = sub.add_parser("robots", help=HELP["robots"],
                       description="Each arm (--robot NAME on solve, collect, evaluate, render): its joints' velocity "
                       "and effort limits as the simulator and planners read them, its mass, where its base stands in "
                       "the scene, and every figure of its description file replaced by the maker's, with the source. "
                       "--reach adds the segment of the scooping line it holds the spatula on (IK along the line), --check the "
                       "plant = model and compiled = Python step checks.",
                       parents=parents)
    r.add_argument("robot", nargs="?", help="one arm (default: every arm)")
    r.add_argument("--reach", action="store_true", help="also the reach on the scooping line (about 1 s per arm)")
    r.add_argument("--check", action="store_true", help="also check that PyBullet's mass matrix is Pinocchio's and that "
                   "the compiled control step is the Python one (a few seconds per arm; the first builds its step)")
    r.set_defaults(func=cmd_robots)
