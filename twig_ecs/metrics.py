"""Per-character metrics of a run (the schoolyard's story in numbers), traces and plots.

:class:`StoryRecorder` watches a scene step by step: time per winning behaviour, hugs,
ball touches, look-backs, fights, withdrawals, distance from the caregiver, what each
hand holds, the peak angular speed of anything that turns on an axle, and the contact
figures of :mod:`twig_ecs.interactions` (kicks, pushes, hugs, carried things) and the
torso figures of :mod:`twig_ecs.torso` (no fold beyond 35 degrees but right after a blow) and
the rises of :mod:`twig_ecs.rises` (getting up takes a person's time) and the knocks of
:mod:`twig_ecs.knocks` (a child's kick or bump barely moves its caregiver). It can also write a
per-step CSV trace and draw distance and anxiety over time with behaviour bands.
"""

from __future__ import annotations

import csv
import math
from collections import Counter, defaultdict
from pathlib import Path

import numpy as np

from twig_ecs.components import Attachment, Character, Memory
from twig_ecs.interactions import InteractionRecorder
from twig_ecs.knocks import KnockRecorder
from twig_ecs.rises import RiseRecorder
from twig_ecs.scene import Scene
from twig_ecs.steering import ground_distance
from twig_ecs.systems.behaviours.fight import Feisty
from twig_ecs.systems.behaviours.play import Playful
from twig_ecs.systems.behaviours.ride import Rider
from twig_ecs.torso import TorsoRecorder

TRACE_FIELDS = ("time", "character", "x", "z", "behaviour", "focus", "anxiety", "caregiver_distance", "pain")


#: Tick intervals on each y axis of the plot.
TICKS = 5


class StoryRecorder:
    """Collects per-character metrics (and optionally a trace) while a scene runs."""

    def __init__(self, scene: Scene, trace: bool = False) -> None:
        self.scene = scene
        self.trace: list[dict] | None = [] if trace else None
        self.behaviour_time: dict[str, Counter] = defaultdict(Counter)
        self.max_distance: dict[str, float] = defaultdict(float)
        self.held_steps: dict[str, Counter] = defaultdict(Counter)
        self.hugs: Counter = Counter()
        self.withdrawals: Counter = Counter()
        self.steps = 0
        self.peak_spin = 0.0
        scene.on("goal.done", self._goal_done)
        scene.on("behavior.changed", self._changed)
        self.axles = [name for name in scene.entity_names if self._is_axled(name)]
        self.interactions = InteractionRecorder(scene)
        self.torso = TorsoRecorder(scene)
        self.rises = RiseRecorder(scene)
        self.knocks = KnockRecorder(scene)

    def _is_axled(self, name: str) -> bool:
        body = self.scene.entity(name).body
        rows = body.rows
        return bool((self.scene.state.nodes.axle_a[rows] >= 0).any())

    def _goal_done(self, event) -> None:
        if event.behavior == "hug":
            self.hugs[self.scene.name_of(event.character)] += 1

    def _changed(self, event) -> None:
        if event.new == "withdraw":
            self.withdrawals[self.scene.name_of(event.character)] += 1

    def step(self) -> None:
        """Record the state after one step."""
        scene = self.scene
        self.steps += 1
        for entity, _ in self.scene.world.get_component(Character):
            me = scene.character_handle(entity)
            self.behaviour_time[me.name][me.behaviour] += scene.dt
            for held in me.holding.values():
                self.held_steps[me.name][held] += 1
            attachment = self.scene.world.try_component(entity, Attachment)
            distance = anxiety = math.nan
            if attachment is not None and scene.has_entity(attachment.caregiver):
                distance = ground_distance(me.position, scene.entity(attachment.caregiver).position)
                self.max_distance[me.name] = max(self.max_distance[me.name], distance)
                anxiety = attachment.anxiety
            if self.trace is not None:
                memory = self.scene.world.try_component(entity, Memory)
                self.trace.append({
                    "time": round(scene.time, 4), "character": me.name,
                    "x": round(float(me.position[0]), 4), "z": round(float(me.position[2]), 4),
                    "behaviour": me.behaviour, "focus": memory.focus if memory else "",
                    "anxiety": round(anxiety, 4), "caregiver_distance": round(distance, 4),
                    "pain": round(me.pain, 4),
                })  # fmt: skip
        for name in self.axles:
            self.peak_spin = max(self.peak_spin, self._spin(name))
        self.interactions.step()
        self.torso.step()
        self.rises.step()
        self.knocks.step()

    def _spin(self, name: str) -> float:
        """Angular speed (rad/s) of an axled body about its axle, from one free node."""
        st = self.scene.state
        body = self.scene.entity(name).body
        rows = range(body.rows.start, body.rows.stop)
        n = st.nodes
        for i in rows:
            if n.axle_a[i] >= 0 and n.axle_radius[i] > 0.1:
                v = (n.pos[i] - n.prev[i]) / self.scene.dt
                return float(np.linalg.norm(v)) / float(n.axle_radius[i])
        return 0.0

    def report(self) -> dict:
        """Per-character metrics and the scene's peak spin, JSON-ready."""
        scene = self.scene
        characters = {}
        for entity, _ in self.scene.world.get_component(Character):
            name = scene.name_of(entity)
            entry = {
                "time_per_behaviour": {k: round(v, 2) for k, v in sorted(self.behaviour_time[name].items())},
                "hugs": self.hugs[name],
                "withdrawals": self.withdrawals[name],
                "held_fraction": {
                    k: round(v / max(self.steps, 1), 3) for k, v in self.held_steps[name].items()
                },
            }
            playful = self.scene.world.try_component(entity, Playful)
            if playful is not None:
                entry["ball_touches"] = playful.touches
            attachment = self.scene.world.try_component(entity, Attachment)
            if attachment is not None:
                entry["look_backs"] = attachment.look_backs
                entry["max_distance_from_caregiver"] = round(self.max_distance[name], 2)
            feisty = self.scene.world.try_component(entity, Feisty)
            if feisty is not None:
                entry["fights"] = feisty.fights
            rider = self.scene.world.try_component(entity, Rider)
            if rider is not None:
                entry["spins"] = rider.spins
            characters[name] = entry
        return {
            "characters": characters,
            "merry_go_round_peak_rad_s": round(self.peak_spin, 3),
            "interactions": self.interactions.report(),
            "torso": self.torso.report(),
            "rises": self.rises.report(),
            "knocks": self.knocks.report(),
        }

    def write_trace(self, path: str | Path) -> None:
        """The per-step trace as CSV (one row per character per step)."""
        with open(path, "w", newline="") as f:
            writer = csv.DictWriter(f, fieldnames=TRACE_FIELDS)
            writer.writeheader()
            writer.writerows(self.trace or [])

    def plot(self, path: str | Path, size: tuple[int, int] = (1200, 500)) -> None:
        """Distance to the caregiver and anxiety over time, with behaviour bands, as a PNG."""
        from twig_ecs.chart import canvas

        rows = [r for r in (self.trace or []) if not math.isnan(r["anxiety"])]
        width, height = size
        image, draw, title_font, label_font = canvas(size)
        # room for the title above, distance ticks left, anxiety ticks and the legend right
        left, right, top, bottom = 70, width - 190, 56, height - 50
        draw.rectangle((left, top, right, bottom), outline=(120, 120, 120))
        if not rows:
            draw.text((left + 10, top + 10), "no attached character to plot", fill=(0, 0, 0))
            image.save(path)
            return
        name = rows[0]["character"]
        rows = [r for r in rows if r["character"] == name]
        t_end = rows[-1]["time"] or 1.0
        d_max = max(max(r["caregiver_distance"] for r in rows), 1.0)
        palette = [(255, 214, 170), (190, 225, 190), (200, 210, 245), (245, 200, 220), (230, 230, 170),
                   (210, 200, 235), (200, 235, 235)]  # fmt: skip
        colours: dict[str, tuple] = {}

        def x(t: float) -> float:
            return left + (right - left) * t / t_end

        start = 0
        for k in range(1, len(rows) + 1):
            if k == len(rows) or rows[k]["behaviour"] != rows[start]["behaviour"]:
                b = rows[start]["behaviour"]
                colour = colours.setdefault(b, palette[len(colours) % len(palette)])
                draw.rectangle(
                    (x(rows[start]["time"]), top + 1, x(rows[k - 1]["time"]), bottom - 1), fill=colour
                )
                start = k
        for series, scale, colour in (
            ("caregiver_distance", d_max, (30, 60, 160)),
            ("anxiety", 1.0, (200, 40, 40)),
        ):
            pts = [(x(r["time"]), bottom - (bottom - top) * r[series] / scale) for r in rows]
            draw.line(pts, fill=colour, width=2)
        draw.text((left, 12), f"{name}: distance to caregiver and anxiety over time", font=title_font,
                  fill=(0, 0, 0))  # fmt: skip
        for k in range(TICKS + 1):  # y ticks: metres on the left (blue), anxiety on the right (red)
            y = bottom - (bottom - top) * k / TICKS
            draw.line((left - 5, y, left, y), fill=(30, 60, 160))
            draw.line((right, y, right + 5, y), fill=(200, 40, 40))
            metres, anxiety = f"{d_max * k / TICKS:.1f} m", f"{k / TICKS:.1f}"
            draw.text((left - 8, y), metres, font=label_font, fill=(30, 60, 160), anchor="rm")
            draw.text((right + 8, y), anxiety, font=label_font, fill=(200, 40, 40), anchor="lm")
        for k, (b, colour) in enumerate(colours.items()):
            draw.rectangle((right + 50, top + 20 * k, right + 65, top + 20 * k + 12), fill=colour)
            draw.text((right + 71, top + 20 * k), b, font=label_font, fill=(0, 0, 0))
        for t in range(0, int(t_end) + 1, max(1, int(t_end) // 10)):
            draw.text((x(t), bottom + 8), f"{t} s", font=label_font, fill=(60, 60, 60), anchor="mt")
        image.save(path)
