"""A chain of grips (twig_ecs/store.py, ``rebuild_colliders``): a hand that holds someone's
hand passes what that hand holds, as it passes the body it holds.

In the goal melee a dragger took a man by both wrists while the man's right hand held a third
person: the dragger's forearm, held at that wrist, sat 14 cm inside the third one's chest, and
the contact solver pushed the three apart against the grips every step.
"""

from __future__ import annotations

import numpy as np

from twig_ecs import Scene
from twig_ecs.grabs import RELEASE_GRACE_STEPS


def _arm_colliders(scene, name: str, hand: str) -> np.ndarray:
    """Rows of the colliders of ``name``'s arm on the side of ``hand`` (its forearm and upper arm)."""
    st = scene.state
    body = scene.entity(name).body
    side = hand[0]
    arm = {body.node_start + body.node_names.index(f"{side}_{part}") for part in ("hand", "elbow")}
    col = st.colliders
    rows = np.arange(col.count)
    return rows[[int(col.a[c]) in arm or int(col.b[c]) in arm for c in rows]]


def _three_in_a_row(scenes) -> Scene:
    """Ann, Bob and Cat side by side in the empty scene, settled."""
    scene = Scene.load("empty")
    scenes.append(scene)
    for name, x in (("ann", -0.8), ("bob", 0.0), ("cat", 0.8)):
        scene.spawn("humanoid", name=name, position=(x, 0, 0), facing=90, character=True)
    scene.run(0.2)
    return scene


def test_a_hand_holding_a_hand_passes_what_that_hand_holds(scenes):
    scene = _three_in_a_row(scenes)
    scene.grab("bob", "r_hand", "cat", "spine")  # bob holds cat
    scene.grab("ann", "l_hand", "bob", "r_hand")  # ann takes the wrist of that hand
    scene.step()  # (the collider table is made again at the next step)
    ignore = scene.state.colliders.ignore
    cat, bob = scene.entity("cat").body.index, scene.entity("bob").body.index
    arm = _arm_colliders(scene, "ann", "l_hand")
    assert len(arm) >= 2
    for c in arm:
        assert bob in ignore[c] and cat in ignore[c], "ann's arm passes bob, and cat whom bob's hand holds"
    # her other arm holds nothing: it meets both
    for c in _arm_colliders(scene, "ann", "r_hand"):
        assert bob not in ignore[c] and cat not in ignore[c]
    # and a chain of one: bob's arm passes cat only, not ann
    for c in _arm_colliders(scene, "bob", "r_hand"):
        assert cat in ignore[c]


def test_letting_go_of_the_first_grip_ends_the_chain(scenes):
    scene = _three_in_a_row(scenes)
    held = scene.grab("bob", "r_hand", "cat", "spine")
    scene.grab("ann", "l_hand", "bob", "r_hand")
    scene.step()
    scene.release(held)
    for _ in range(RELEASE_GRACE_STEPS + 2):  # (a grip let go of passes a few steps longer)
        scene.step()
    cat = scene.entity("cat").body.index
    for c in _arm_colliders(scene, "ann", "l_hand"):
        assert cat not in scene.state.colliders.ignore[c], "bob let go of cat: ann's arm meets cat again"
