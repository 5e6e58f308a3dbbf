"""Ground truth: the PyBullet scooping scene, its hybrid controller and plan replay."""
