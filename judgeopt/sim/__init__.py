"""Ground truth: the PyBullet scooping scene, its hybrid controller and plan replay."""

#: set to 1 (by `judgeopt --quiet`) to discard PyBullet's banner and URDF warnings instead of
#: printing them on stderr; an environment variable so that worker processes inherit it
QUIET_ENV = "JUDGEOPT_QUIET"
