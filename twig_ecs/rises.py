"""Rise figures of a run: does anyone who went down get up like a person, not pop up like a puppet?

:class:`RiseRecorder` watches each character's pelvis height as a share of its standing
height (``CharacterHandle.stand_height``). A character is *down* once its pelvis is below
:data:`DOWN` of standing (fallen, folded at a rim, kneeling low); the rise that follows
lasts from the last frame below :data:`DOWN` to the first frame back above :data:`UP`. A
person getting up from the ground goes through a kneel or a hand on the ground and takes
about a second or more (issue 34: at least :data:`SHORTEST` s); a puppet snapped upright by
its posture takes 0.2 s. ``twig run --report json`` gives the figures as its ``rises``
section.
"""

from __future__ import annotations

from twig_ecs.components import Character
from twig_ecs.scene import Scene

DOWN = 0.40  # pelvis below this share of standing height: down
UP = 0.90  # ... back above this share: up again
SHORTEST = 0.8  # s: a rise quicker than this reads as a pop (issue 34)


class RiseRecorder:
    """Every rise from a pelvis below :data:`DOWN` of standing height back above :data:`UP`,
    per character: when it started, how low the pelvis had been and how long it took."""

    def __init__(self, scene: Scene) -> None:
        self.scene = scene
        self.rises: dict[str, list[dict]] = {}
        # per character: None while up; else [time of the last frame below DOWN, lowest share]
        self._down: dict[str, list[float] | None] = {}

    def step(self) -> None:
        """Measure every character's pelvis after one step."""
        scene = self.scene
        for entity, _ in scene.world.get_component(Character):
            me = scene.character_handle(entity)
            share = float(me.position[1]) / max(me.stand_height, 1e-6)
            down = self._down.get(me.name)
            if share < DOWN:
                if down is None:
                    self._down[me.name] = [scene.time, share]
                else:
                    down[0], down[1] = scene.time, min(down[1], share)
            elif down is not None and share > UP:
                self.rises.setdefault(me.name, []).append({
                    "at_s": round(down[0], 3), "lowest": round(down[1], 3),
                    "seconds": round(scene.time - down[0], 3),
                })  # fmt: skip
                self._down[me.name] = None

    def report(self) -> dict:
        """JSON-ready: the thresholds, and per character that rose its rises and the quickest."""
        return {
            "down_share": DOWN,
            "up_share": UP,
            "shortest_expected_s": SHORTEST,
            "characters": {
                name: {"rises": rises, "quickest_s": min(r["seconds"] for r in rises)}
                for name, rises in sorted(self.rises.items())
            },
        }


def getup_sheet(output, height: float = 1.75, frames: int = 12, every: float = 0.15,
                size: tuple[int, int] = (240, 240), columns: int = 6):  # fmt: skip
    """A contact sheet PNG of a ``height`` m character getting up: a ragdoll for 2 s, then
    told to :meth:`~twig_ecs.character.CharacterHandle.stand`, a frame every ``every`` s from
    then. Returns the path written."""
    from twig_ecs.graphics.camera import OrbitCamera
    from twig_ecs.graphics.offscreen import check_output, contact_sheet

    path = check_output(output)
    scene = Scene.load("empty")
    try:
        person = scene.spawn("humanoid", name="riser", character=True, height=height)
        person.go_limp()
        scene.run(2.0)
        person.stand()

        def three_quarter_view() -> OrbitCamera:
            target = person.position.copy()
            target[1] = 0.45 * height
            return OrbitCamera(target, yaw=60.0, pitch=10.0, distance=1.8 * height)

        return contact_sheet(scene, path, three_quarter_view, frames, every, size, columns)
    finally:
        scene.close()


if __name__ == "__main__":  # python -m twig_ecs.rises FILE.png [HEIGHT]
    import sys

    print(getup_sheet(sys.argv[1], *(float(a) for a in sys.argv[2:3])))
