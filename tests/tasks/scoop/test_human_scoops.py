"""Human-like strokes: from rest to rest at the drawn places, the force let go at both ends."""

from __future__ import annotations

import numpy as np

from judgeopt.tasks.scoop.human_scoops import HumanScoopConfig, draw_scoop, scoop_command


def test_strokes_go_rest_to_rest_within_their_ranges():
    cfg = HumanScoopConfig()
    for i in range(20):
        s = draw_scoop(np.random.default_rng([0, i]), 0.246, cfg)
        plan = scoop_command(s)
        assert plan.dt == 1e-3 and abs(plan.t[-1] - s.duration) < 1e-9
        assert cfg.duration[0] <= s.duration <= cfg.duration[1]
        assert plan.y[0] == s.start and abs(plan.y[-1] - s.end) < 1e-12
        assert plan.ydot[0] == 0 and abs(plan.ydot[-1]) < 1e-12
        assert np.allclose(np.gradient(plan.y, plan.dt)[1:-1], plan.ydot[1:-1], atol=1e-3)  # velocity is y's rate
        assert plan.f[0] == 0 and abs(plan.f[-1]) < 1e-12 and plan.f.min() >= 0 and plan.f.max() <= s.peak_force + 1e-9
