"""A grip pulled too hard gives way (twig_ecs/grabs.py, ``slip``), measured in plain floats as
numpy measured it: the same tensions, bit for bit, so the same grips let go."""

from __future__ import annotations

import numpy as np

from twig_ecs import Scene
from twig_ecs.grabs import GRIP_SLIP, grip_tensions
from twig_ecs.store import LINK_GRAB, LINK_OFF, gripped_nodes


def _numpy_tensions(state) -> list[tuple[int, float]]:
    """The rule written over arrays, as ``slip`` computed it before (the reference)."""
    links, pos = state.links, state.nodes.pos
    count = links.count
    a, b, flags = links.a[:count], links.b[:count], links.flags[:count]
    rows = np.flatnonzero(flags & LINK_GRAB)
    stretch = np.linalg.norm(pos[a[rows]] - pos[b[rows]], axis=1) - links.rest[rows]
    gripped = gripped_nodes(state)
    own = np.flatnonzero((gripped[a] | gripped[b]) & ((flags & (LINK_GRAB | LINK_OFF)) == 0)
                         & (links.rest[:count] > 0))  # fmt: skip
    pull = np.zeros(state.nodes.count)
    own_stretch = np.linalg.norm(pos[a[own]] - pos[b[own]], axis=1) - links.rest[own]
    np.maximum.at(pull, a[own], own_stretch)
    np.maximum.at(pull, b[own], own_stretch)
    tension = np.maximum(stretch, np.maximum(pull[a[rows]], pull[b[rows]]))
    return list(zip(rows.tolist(), tension.tolist(), strict=True))


def _holders(scenes) -> Scene:
    """Ann holds a ragdoll's wrist in her right hand; Bob holds Ann's left wrist."""
    scene = Scene.load("empty")
    scenes.append(scene)
    scene.spawn("humanoid", name="ann", position=(0.0, 0, 0), facing=90, character=True)
    scene.spawn("humanoid", name="bob", position=(-0.7, 0, 0), facing=90, character=True)
    scene.spawn("ragdoll", name="doll", position=(0.45, 0.0, 0.0))
    scene.run(0.2)
    scene.grab("ann", "r_hand", "doll", "l_hand")
    scene.grab("bob", "r_hand", "ann", "l_hand")
    return scene


def test_grip_tensions_are_numpys_bit_for_bit_however_the_nodes_lie(scenes):
    scene = _holders(scenes)
    state = scene.state
    rng = np.random.default_rng(3)
    n = state.nodes.count
    start = state.nodes.pos[:n].copy()
    pulled = 0
    for _ in range(300):
        state.nodes.pos[:n] = start + rng.normal(scale=rng.choice([0.001, 0.02, 0.2]), size=(n, 3))
        mine, theirs = grip_tensions(state), _numpy_tensions(state)
        assert len(mine) == 2
        assert mine == theirs  # the same rows and the same floats (== on floats: bit for bit)
        pulled += sum(t > GRIP_SLIP for _, t in mine)
    assert 0 < pulled < 600  # both sides of the limit were met


def test_a_grip_pulled_past_its_limit_lets_go_and_one_within_holds(scenes):
    scene = _holders(scenes)
    released = []
    scene.on("release", lambda event: released.append(event))
    scene.step(5)
    assert not released  # standing still: both grips hold
    scene.entity("doll").translate((0.6, 0.0, 0.0))  # the doll yanked 0.6 m out of ann's hand
    scene.step(1)
    assert len(released) == 1
    assert scene.name_of(released[0].holder) == "ann" and scene.name_of(released[0].held) == "doll"
    assert len(grip_tensions(scene.state)) == 1  # bob's grip on ann holds
