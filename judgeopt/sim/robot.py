"""The UR5 + force sensor + spatula description, written once as one URDF.

PyBullet and Pinocchio both load the file this module writes, so the dynamics the
controller computes (M, Lambda) are those of the robot the simulator integrates.
"""

from __future__ import annotations

import hashlib
import importlib.metadata
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from judgeopt.errors import Missing
from judgeopt.files import atomic_write, cache_dir as default_cache_dir, make_cache_dir


#: Wrist inertia tensors (kg m^2, diagonal in the link frame) replacing example-robot-data's.
#: Its UR5 file computes each wrist's cylinder inertia with a radius of 0.6 m instead of
#: 0.06 m (izz = m r^2 / 2 = 0.219 kg m^2 for a 1.2 kg wrist, about 100x too large; wrist 3
#: likewise). These are Universal Robots' own figures for the UR5, from
#: Universal_Robots_ROS2_Description, config/ur5/physical_parameters.yaml (same masses,
#: cylinders of radius 0.06 m for wrists 1 and 2 and 0.0375 m for wrist 3).
UR5_WRIST_INERTIA = {
    "wrist_1_link": (0.0020138896, 0.0020138896, 0.0021942),
    "wrist_2_link": (0.0018310396, 0.0018310396, 0.0021942),
    "wrist_3_link": (8.0624758e-05, 8.0624758e-05, 1.3211719e-04),
}

#: where the arm's link inertias come from: "universal_robots" (the wrists corrected as above)
#: or "example_robot_data" (the file as shipped, before 2026-11-22)
WRIST_INERTIA_SOURCES = ("universal_robots", "example_robot_data")


class RobotDescriptionError(Missing, RuntimeError):
    """The UR5 description could not be found in the installed example-robot-data."""


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


def _spatula_xml(g: SpatulaGeometry, blade_mesh: Path) -> str:
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
  <joint name="ft_sensor_joint" type="fixed"><parent link="tool0"/><child link="spatula"/>
    <origin xyz="0 0 {g.sensor_length}" rpy="{math.pi:.9f} 0 0"/></joint>
  {blade_link("blade_top", "0.75 0.75 0.78 1")}
  {blade_link("blade_bottom", "0.75 0.75 0.78 1")}
  <link name="tcp"><inertial><mass value="0"/><origin xyz="0 0 0"/>
    <inertia ixx="0" ixy="0" ixz="0" iyy="0" iyz="0" izz="0"/></inertial></link>
  <joint name="tcp_joint" type="fixed"><parent link="spatula"/><child link="tcp"/>
    <origin xyz="{c[0]:.6f} {c[1]:.6f} {c[2]:.6f}" rpy="0 0 0"/></joint>
"""


def correct_wrist_inertia(urdf: str) -> str:
    """The UR5 URDF text with the wrist links' inertia tensors replaced by UR5_WRIST_INERTIA."""
    for link, (ixx, iyy, izz) in UR5_WRIST_INERTIA.items():
        pattern = re.compile(rf'(<link name="{link}">.*?<inertial>.*?)<inertia [^>]*/>', re.S)
        new = f'<inertia ixx="{ixx:.10g}" ixy="0.0" ixz="0.0" iyy="{iyy:.10g}" iyz="0.0" izz="{izz:.10g}"/>'
        urdf, n = pattern.subn(lambda m: m.group(1) + new, urdf, count=1)
        if n != 1:
            raise RobotDescriptionError(f"the installed ur5_robot.urdf has no inertia for {link}")
    return urdf


def robot_urdf(geometry: SpatulaGeometry | None = None, cache_dir: Path | None = None,
               wrist_inertia: str = "universal_robots") -> Path:
    """Write (once, atomically) the UR5 + spatula URDF and return its path.

    Mesh paths are rewritten from `package://` to absolute paths so PyBullet finds them.
    The file name carries a hash of its content: a changed geometry gives a new file.
    """
    if wrist_inertia not in WRIST_INERTIA_SOURCES:
        raise ValueError(f"wrist_inertia = {wrist_inertia!r}; choose one of {WRIST_INERTIA_SOURCES}")
    g = geometry or SpatulaGeometry()
    share = example_robot_data_prefix()
    src = (share / "example-robot-data/robots/ur_description/urdf/ur5_robot.urdf").read_text()
    src = src.replace("package://", str(share) + "/")
    if wrist_inertia == "universal_robots":
        src = correct_wrist_inertia(src)
    cache = make_cache_dir(cache_dir or default_cache_dir())
    verts = blade_vertices(g)
    mesh = cache / f"blade_{hashlib.sha1(verts.tobytes()).hexdigest()[:12]}.obj"
    if not mesh.exists():
        _write_obj(mesh, verts)
    text = src.replace("</robot>", _spatula_xml(g, mesh) + "\n</robot>")
    out = cache / f"ur5_spatula_{hashlib.sha1(text.encode()).hexdigest()[:12]}.urdf"
    if not out.exists():
        atomic_write(out, text)
    return out
