"""Franka Emika Panda: 7 joints, the research lab's arm; its hand is replaced by the sensor and spatula."""

from judgeopt.robots.spec import RobotSpec

ARM = RobotSpec(
    name="panda",
    title="Franka Emika Panda",
    description="panda_description/urdf/panda.urdf",
    flange="panda_link8",
    joints=tuple(f"panda_joint{i}" for i in range(1, 8)),
    home=(0.023, 0.564, -0.239, -1.967, 0.216, 2.508, -0.354),  # scripts/place_arm.py panda
    base_xyz=(-0.3, 0.0, 0.0),
    remove=("panda_hand",),
    notes="velocity, effort and position limits match Franka's (frankaemika docs, control-parameters-joint-panda.csv)",
)
