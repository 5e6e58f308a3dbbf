"""An arm (judgeopt.robots) + force sensor + spatula description, written once as one URDF.

PyBullet and Pinocchio both load the file this module writes, so the dynamics the
controller computes (M, Lambda) are those of the robot the simulator integrates.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from judgeopt.errors import Missing
from judgeopt.files import atomic_write, cache_dir as default_cache_dir, make_cache_dir
from judgeopt.robots import DEFAULT_ROBOT, get_robot
from judgeopt.robots.spec import Correction, RobotError, RobotSpec


#: where the arm's link inertias and masses come from: "universal_robots" (the maker's figures where the file is
#: wrong: RobotSpec.inertias and .masses, for the UR5 its wrists, from Universal Robots) or "example_robot_data"
#: (the file as shipped: the scene of every dataset made before 2026-11-22)
WRIST_INERTIA_SOURCES = ("universal_robots", "example_robot_data")


class RobotDescriptionError(Missing, RuntimeError):
    """An arm's description could not be found in the installed example-robot-data."""


@dataclass(frozen=True)
class SpatulaGeometry:
    """Spatula dimensions in metres, kilograms and degrees.

    The spatula frame is world-aligned at the home pose (x sideways, y the scooping
    direction, z up). The blade's front edge is its lowest point, so the blade meets the
    plate along that edge and slides under the object's bevelled rim.
    """

    sensor_length: float = 0.035  # flange to sensor output face
    handle_length: float = 0.16
    handle_angle_deg: float = 60.0  # from horizontal, rising backwards
    blade_width: float = 0.09  # x
    blade_length: float = 0.10  # y
    blade_thickness: float = 0.002
    blade_tilt_deg: float = 8.0  # front edge down
    bevel_length: float = 0.012  # the blade's top is ground to a sharp front edge over this length
    edge_thickness: float = 0.0003
    handle_mass: float = 0.08
    blade_mass: float = 0.05

    def blade_centre(self) -> np.ndarray:
        """Blade centre in the spatula frame (origin at the sensor face)."""
        a = math.radians(self.handle_angle_deg)
        t = math.radians(self.blade_tilt_deg)
        back_edge = np.array([0.0, self.handle_length * math.cos(a), -self.handle_length * math.sin(a)])
        return back_edge + np.array([0.0, 0.5 * self.blade_length * math.cos(t), -0.5 * self.blade_length * math.sin(t)])

    def tcp_height_on_plate(self) -> float:
        """Height of the blade centre (the TCP) when the front edge's underside touches z = 0."""
        t = math.radians(self.blade_tilt_deg)
        return 0.5 * self.blade_length * math.sin(t) + 0.5 * self.blade_thickness * math.cos(t)


def blade_vertices(g: SpatulaGeometry) -> np.ndarray:
    """Convex blade: flat bottom, top bevelled down to a sharp front edge (blade frame, untilted)."""
    w, L, t = g.blade_width / 2, g.blade_length / 2, g.blade_thickness / 2
    y_bevel = L - g.bevel_length
    pts = []
    for x in (-w, w):
        pts += [[x, -L, -t], [x, L, -t], [x, -L, t], [x, y_bevel, t], [x, L, -t + g.edge_thickness]]
    return np.array(pts)


def _write_obj(path: Path, vertices: np.ndarray) -> None:
    """A convex solid as OBJ faces (its hull), for PyBullet's collision and visual shapes."""
    from scipy.spatial import ConvexHull

    hull = ConvexHull(vertices)
    lines = [f"v {x:.7f} {y:.7f} {z:.7f}" for x, y, z in vertices]
    for simplex, eq in zip(hull.simplices, hull.equations):
        a, b, c = simplex
        n = np.cross(vertices[b] - vertices[a], vertices[c] - vertices[a])
        if np.dot(n, eq[:3]) < 0:  # outward winding
            b, c = c, b
        lines.append(f"f {a + 1} {b + 1} {c + 1}")
    atomic_write(path, "\n".join(lines) + "\n")


def example_robot_data_prefix() -> Path:
    """`<prefix>/share` of the installed example-robot-data wheel (it ships no Python module)."""
    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError as exc:
        raise RobotDescriptionError(
            "example-robot-data is not installed; run scripts/setup.sh (or `pip install example-robot-data`)"
        ) from exc
    for f in dist.files or []:
        s = str(f).replace("\\", "/")
        if s.endswith("robots/ur_description/urdf/ur5_robot.urdf"):
            urdf = Path(dist.locate_file(f))
            return urdf.parents[4]  # .../share
    raise RobotDescriptionError("example-robot-data is installed but holds no ur5_robot.urdf")


def _spatula_xml(g: SpatulaGeometry, blade_mesh: Path, flange: str) -> str:
    a = math.radians(g.handle_angle_deg)
    t = math.radians(g.blade_tilt_deg)
    # handle: from the sensor face (0,0,0) down and forward to the blade's back edge
    h_mid = np.array([0.0, 0.5 * g.handle_length * math.cos(a), -0.5 * g.handle_length * math.sin(a)])
    c = g.blade_centre()
    blade_geom = f'<mesh filename="{blade_mesh}"/>'
    blade_origin = f'xyz="{c[0]:.6f} {c[1]:.6f} {c[2]:.6f}" rpy="{-t:.6f} 0 0"'

    def inertia(m: float, sx: float, sy: float, sz: float, roll: float = 0.0) -> str:
        # box inertia rotated about x: PyBullet expresses a link's joint reaction in its
        # inertial frame, so every spatula link keeps an unrotated inertial frame
        box = np.diag([sy**2 + sz**2, sx**2 + sz**2, sx**2 + sy**2]) * m / 12
        cr, sr = math.cos(roll), math.sin(roll)
        R = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
        I = R @ box @ R.T
        return (
            f'<inertia ixx="{I[0, 0]:.4e}" iyy="{I[1, 1]:.4e}" izz="{I[2, 2]:.4e}" '
            f'ixy="{I[0, 1]:.4e}" ixz="{I[0, 2]:.4e}" iyz="{I[1, 2]:.4e}"/>'
        )

    def blade_link(name: str, colour: str) -> str:
        return f"""
  <link name="{name}">
    <inertial><origin xyz="{c[0]:.6f} {c[1]:.6f} {c[2]:.6f}"/><mass value="{g.blade_mass / 2}"/>
      {inertia(g.blade_mass / 2, g.blade_width, g.blade_length, g.blade_thickness, -t)}</inertial>
    <visual><origin {blade_origin}/><geometry>{blade_geom}</geometry>
      <material name="{name}_mat"><color rgba="{colour}"/></material></visual>
    <collision><origin {blade_origin}/><geometry>{blade_geom}</geometry></collision>
  </link>
  <joint name="{name}_joint" type="fixed"><parent link="spatula"/><child link="{name}"/>
    <origin xyz="0 0 0" rpy="0 0 0"/></joint>"""

    return f"""
  <!-- judgeopt: 6-axis force/torque sensor joint and spatula -->
  <link name="spatula">
    <inertial><origin xyz="{h_mid[0]:.6f} {h_mid[1]:.6f} {h_mid[2]:.6f}"/>
      <mass value="{g.handle_mass}"/>{inertia(g.handle_mass, 0.02, g.handle_length, 0.006, -a)}</inertial>
    <visual><origin xyz="0 0 {g.sensor_length / 2:.6f}"/><geometry><cylinder radius="0.035" length="{g.sensor_length}"/></geometry>
      <material name="sensor_mat"><color rgba="0.2 0.2 0.2 1"/></material></visual>
    <visual><origin xyz="{h_mid[0]:.6f} {h_mid[1]:.6f} {h_mid[2]:.6f}" rpy="{-a:.6f} 0 0"/>
      <geometry><box size="0.02 {g.handle_length} 0.006"/></geometry>
      <material name="handle_mat"><color rgba="0.35 0.2 0.1 1"/></material></visual>
    <collision><origin xyz="{h_mid[0]:.6f} {h_mid[1]:.6f} {h_mid[2]:.6f}" rpy="{-a:.6f} 0 0"/>
      <geometry><box size="0.02 {g.handle_length} 0.006"/></geometry></collision>
  </link>
  <joint name="ft_sensor_joint" type="fixed"><parent link="{flange}"/><child link="spatula"/>
    <origin xyz="0 0 {g.sensor_length}" rpy="{math.pi:.9f} 0 0"/></joint>
  {blade_link("blade_top", "0.75 0.75 0.78 1")}
  {blade_link("blade_bottom", "0.75 0.75 0.78 1")}
  <link name="tcp"><inertial><mass value="0"/><origin xyz="0 0 0"/>
    <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <joint name="tcp_joint" type="fixed"><parent link="spatula"/><child link="tcp"/>
    <origin xyz="{c[0]:.6f} {c[1]:.6f} {c[2]:.6f}" rpy="0 0 0"/></joint>
"""


#: the inertial of a frame-only link: PyBullet gives a link without one a mass of 1 kg, Pinocchio none
MASSLESS = ('<inertial><mass value="0"/><origin xyz="0 0 0"/>'
            '<inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial>')


def _replace_in_inertial(urdf: str, link: str, element: str, new: str) -> str:
    """The URDF text with one element (`<mass .../>`, `<inertia .../>`) of this link's `<inertial>` replaced.
    The match stays inside the link (a link without an inertial must not pass the fix on to the next one)."""
    inside = r"(?:(?!</link>).)*?"
    pattern = re.compile(rf'(<link name="{re.escape(link)}">{inside}<inertial>{inside})<{element} [^>]*/>', re.S)
    urdf, n = pattern.subn(lambda m: m.group(1) + new, urdf, count=1)
    if n != 1:
        raise RobotDescriptionError(f"the installed description has no {element} for {link}")
    return urdf


def correct_inertias(urdf: str, inertias: dict[str, Correction]) -> str:
    """The URDF text with these links' inertia tensors replaced (diagonal, in the link's inertial frame)."""
    for link, fix in inertias.items():
        ixx, iyy, izz = fix.value
        new = f'<inertia ixx="{ixx:.10g}" ixy="0.0" ixz="0.0" iyy="{iyy:.10g}" iyz="0.0" izz="{izz:.10g}"/>'
        urdf = _replace_in_inertial(urdf, link, "inertia", new)
    return urdf


def correct_masses(urdf: str, masses: dict[str, Correction]) -> str:
    """The URDF text with these links' masses replaced (centre of mass and inertial frame kept)."""
    for link, fix in masses.items():
        mass = fix.value
        if not isinstance(mass, (int, float)) or not mass > 0:
            raise RobotError(f"the mass correction for {link} is {mass!r}; a link's mass is one positive number [kg]")
        urdf = _replace_in_inertial(urdf, link, "mass", f'<mass value="{float(mass):.10g}"/>')
    return urdf


def undamped(joint: ET.Element) -> bool:
    """Set a joint's `<dynamics damping>` to zero; whether it was not. Why: Pinocchio's model (the controller's
    M and h, the plant = model checks) has no joint damping, and PyBullet applies it as an explicit force,
    which diverges once the time step times an eigenvalue of M^-1 D passes 2: the xArm7 file's 2-10 N m s
    on light wrist joints give 2.8 at 1 ms, and the arm's joint 7 then flips between its speed limits every
    step (docs/guides/arm.md, "Seven joints")."""
    dynamics = joint.find("dynamics")
    if dynamics is None or float(dynamics.get("damping", 0.0)) == 0.0:
        return False
    dynamics.set("damping", "0")
    return True


def _rewrite(urdf: str, spec: RobotSpec) -> str:
    """What an arm other than the plain UR5 needs, on the parsed file: its limits corrected, every
    movable joint that is not an arm joint (fingers, a gripper) fixed, the links `spec.remove`
    names dropped with what hangs on them (a hand the spatula replaces), continuous arm joints
    made revolute over +-2 pi (PyBullet and Pinocchio then agree on one angle per joint), and the
    base placed in the world by a fixed joint from a new root link, and every joint's viscous damping
    removed (`undamped`). Unchanged text where none applies."""
    root = ET.fromstring(urdf)
    joints = {j.get("name"): j for j in root.findall("joint")}
    missing = [j for j in (*spec.joints, *spec.velocity_limits, *spec.effort_limits) if j not in joints]
    if missing:
        raise RobotDescriptionError(f"robot {spec.name!r}: {spec.description} has no joint {', '.join(missing)}")
    changed = False
    drop = set(spec.remove)
    while True:  # everything hanging on a dropped link goes too
        more = {j.find("child").get("link") for j in joints.values() if j.find("parent").get("link") in drop} - drop
        if not more:
            break
        drop |= more
    for name, j in joints.items():
        if j.find("child").get("link") in drop:
            root.remove(j)
            changed = True
    for link in root.findall("link"):
        if link.get("name") in drop:
            root.remove(link)
    for name, j in joints.items():
        if j.find("child").get("link") in drop:
            continue
        kind = j.get("type")
        if kind in ("revolute", "continuous", "prismatic") and name not in spec.joints:
            j.set("type", "fixed")
            changed = True
        elif kind == "continuous":
            j.set("type", "revolute")
            limit = j.find("limit")
            if limit is None:  # a continuous joint may omit it; a revolute one may not
                raise RobotDescriptionError(f"robot {spec.name!r}: continuous joint {name} in {spec.description} has no "
                                            "<limit effort velocity>: the controller and planners need its drive's limits")
            limit.set("lower", f"{-2 * math.pi:.9f}")
            limit.set("upper", f"{2 * math.pi:.9f}")
            changed = True
        changed |= undamped(j)
        for table, attribute in ((spec.velocity_limits, "velocity"), (spec.effort_limits, "effort")):
            if name in table:
                j.find("limit").set(attribute, f"{float(table[name].value):g}")
                changed = True
    children = {j.find("child").get("link") for j in root.findall("joint")}
    for link in root.findall("link"):  # a frame-only link: PyBullet would give it 1 kg (the fixed root moves nothing)
        if link.find("inertial") is None and link.get("name") in children:
            link.append(ET.fromstring(MASSLESS))
            changed = True
    if spec.placed:
        base = next(link.get("name") for link in root.findall("link") if link.get("name") not in children)
        world = ET.fromstring(f'<link name="judgeopt_world">{MASSLESS}</link>')
        mount = ET.Element("joint", name="judgeopt_base_joint", type="fixed")
        ET.SubElement(mount, "parent", link="judgeopt_world")
        ET.SubElement(mount, "child", link=base)
        x, y, z = spec.base_xyz
        ET.SubElement(mount, "origin", xyz=f"{x:g} {y:g} {z:g}", rpy=f"0 0 {spec.base_yaw:g}")
        root.insert(0, mount)
        root.insert(0, world)
        changed = True
    return ET.tostring(root, encoding="unicode") if changed else urdf


def robot_urdf(geometry: SpatulaGeometry | None = None, cache_dir: Path | None = None,
               wrist_inertia: str = "universal_robots", robot: str = DEFAULT_ROBOT) -> Path:
    """Write (once, atomically) the arm + spatula URDF and return its path.

    Mesh paths are rewritten from `package://` to absolute paths so PyBullet finds them.
    The file name carries a hash of its content: a changed geometry gives a new file.
    """
    if wrist_inertia not in WRIST_INERTIA_SOURCES:
        raise ValueError(f"wrist_inertia = {wrist_inertia!r}; choose one of {WRIST_INERTIA_SOURCES}")
    spec = get_robot(robot)
    g = geometry or SpatulaGeometry()
    share = example_robot_data_prefix()
    path = share / "example-robot-data/robots" / spec.description
    if not path.is_file():
        raise RobotDescriptionError(f"robot {spec.name!r}: example-robot-data holds no {spec.description} "
                                    "(pip install -U example-robot-data)")
    src = path.read_text().replace("package://", str(share) + "/")
    if wrist_inertia == "universal_robots":
        src = correct_masses(correct_inertias(src, spec.inertias), spec.masses)
    src = _rewrite(src, spec)
    cache = make_cache_dir(cache_dir or default_cache_dir())
    verts = blade_vertices(g)
    mesh = cache / f"blade_{hashlib.sha1(verts.tobytes()).hexdigest()[:12]}.obj"
    if not mesh.exists():
        _write_obj(mesh, verts)
    flange, mount = spec.flange, ""
    if any(spec.mount_xyz) or any(spec.mount_rpy):  # a frame whose +z leaves the flange
        flange = "judgeopt_mount"
        mount = (f'\n  <link name="{flange}">{MASSLESS}</link>\n  <joint name="judgeopt_mount_joint" type="fixed"><parent link="{spec.flange}"/>'
                 f'<child link="{flange}"/>\n    <origin xyz="{" ".join(f"{v:g}" for v in spec.mount_xyz)}" '
                 f'rpy="{" ".join(f"{v:.9f}" for v in spec.mount_rpy)}"/></joint>')
    text = src.replace("</robot>", mount + _spatula_xml(g, mesh, flange) + "\n</robot>")
    out = cache / f"{spec.name}_spatula_{hashlib.sha1(text.encode()).hexdigest()[:12]}.urdf"
    if not out.exists():
        atomic_write(out, text)
    return out
