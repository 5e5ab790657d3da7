"""Setting off at a run (issue 35): a child turns and runs, its doll in hand, and stays on its feet."""

from __future__ import annotations

import numpy as np
import pytest

from twig_ecs import Scene
from twig_ecs.store import NODE_CARRIED

CHILD = "  - name: child\n    body: humanoid\n    height: 1.05\n    position: [0, 0, 0]\n    facing: 150\n"
DOLL = "  - name: doll\n    body: ragdoll\n    position: [-0.125, 0.117, -0.069]\n    facing: 150\n"


def child_scene(tmp_path, doll: bool) -> Scene:
    """A 1.05 m child facing 150 degrees away from +z, holding a doll by its head or not."""
    text = "twig: 1\nentities:\n" + CHILD
    text += "    character:\n      hold: doll\n" + DOLL if doll else "    character: true\n"
    path = tmp_path / "child.yaml"
    path.write_text(text)
    return Scene.load(path)


@pytest.mark.parametrize("doll", [False, True], ids=["empty-handed", "with-doll"])
@pytest.mark.parametrize("speed", [2.0, 2.4])
def test_a_child_turning_to_run_off_stays_on_its_feet(tmp_path, speed, doll):
    # before: the pelvis fell to 13-51% of standing height - a run's long flight as the first
    # step, the stance foot left far behind, the other hanging in the air, then a split
    with child_scene(tmp_path, doll) as scene:
        child = scene.entity("child")
        scene.run(1.0)
        assert not doll or child.holding == {"left": "doll"}
        child.walk((0.0, 0.0, speed))
        start = child.position.copy()
        lowest = 1.0
        while scene.time < 4.0:
            scene.step()
            lowest = min(lowest, child.position[1] / child.stand_height)
        assert lowest > 0.7, f"its pelvis sank to {lowest:.0%} of standing height"
        assert child.position[2] - start[2] > 0.5 * speed * 3.0, "it ran off"


def test_a_carried_thing_is_no_ground_for_its_carriers_feet(tmp_path):
    # before: the running child's knee lifted its foot into the doll it carried; the foot
    # planted there and was left standing on air as the doll swung on
    with child_scene(tmp_path, doll=True) as scene:
        doll = scene.entity("doll").body
        rows = np.arange(doll.rows.start, doll.rows.stop)
        scene.run(0.2)
        assert (scene.state.nodes.flags[rows] & NODE_CARRIED).all(), "a held doll is marked carried"
        scene.entity("child").release("left")
        scene.run(0.2)
        assert not (scene.state.nodes.flags[rows] & NODE_CARRIED).any(), "let go, it is ground again"
