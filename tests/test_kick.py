"""Kicks that read (issue 34): a ball that rolls as on a playground, a kick with a backswing
that sends it off fast, and a run-up that neither circles nor straddles the ball."""

from __future__ import annotations

import numpy as np

from twig_ecs import Scene


def roll(speed: float, seconds: float = 30.0) -> tuple[float, float]:
    """A ball sent rolling at ``speed`` m/s on open ground: (metres it went, seconds until it stopped)."""
    with Scene.load("empty") as scene:
        ball = scene.spawn("ball", name="ball")
        scene.run(0.5)
        nodes, i = scene.state.nodes, ball.body.node_start
        nodes.prev[i] = nodes.pos[i] - np.array([speed, 0.0, 0.0]) * scene.dt
        start, stopped = nodes.pos[i].copy(), None
        for _ in range(round(seconds / scene.dt)):
            scene.step()
            if stopped is None and np.linalg.norm(nodes.pos[i] - nodes.prev[i]) / scene.dt < 0.01:
                stopped = scene.time - 0.5
        return float(np.hypot(*(nodes.pos[i] - start)[[0, 2]])), stopped


def test_a_ball_rolling_at_3_m_s_goes_several_metres_and_then_stops():
    went, stopped = roll(3.0)
    assert 4.0 <= went <= 15.0, f"a 3 m/s roll went {went:.2f} m"
    assert stopped is not None and stopped < 12.0, "rolling resistance brings it to rest"
    # a playground's deceleration: 0.2-0.6 m/s^2 on average
    assert 0.2 <= 3.0 / stopped <= 0.7, f"it slowed at {3.0 / stopped:.2f} m/s^2 on average"


def test_a_ball_given_rolling_resistance_in_a_scene_file_rolls_that_far(tmp_path):
    path = tmp_path / "scene.yaml"
    path.write_text(
        "twig: 1\nentities:\n  - {name: ball, body: ball, damping: {air: 0.0, ground: 0.0, rolling: 1.0}}\n"
    )
    with Scene.load(path) as scene:
        scene.run(0.5)
        nodes, i = scene.state.nodes, scene.entity("ball").body.node_start
        nodes.prev[i] = nodes.pos[i] - np.array([0.0, 0.0, 2.0]) * scene.dt
        start = nodes.pos[i].copy()
        scene.run(4.0)
        went = float(np.hypot(*(nodes.pos[i] - start)[[0, 2]]))
    assert abs(went - 2.0**2 / (2 * 1.0)) < 0.1, f"v^2 / 2a = 2 m at 1 m/s^2; it went {went:.2f} m"
