"""ride: a child goes to the merry-go-round now and then and runs it round (SPEC 5).

For each character with a :class:`Rider`: on a whim (``whim``
per second) it walks to the merry-go-round's rim by the nearest bar it can get its
hands on - an overhead handle if its reach is high enough, else the deck's rim, which
it stoops to - reaches for it with its free hands and takes hold (grab joints); then it
runs round alongside for ``PUSH_TIME`` seconds, holding on, lets go and steps back out
from the rim before it does anything else (the deck still turns). The spin comes
only from that hold: the running child's arms pull the bar round (no force is applied
to the merry-go-round by the behaviour).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.character import GRAB_REACH
from twig_ecs.components import Character
from twig_ecs.errors import TwigError
from twig_ecs.steering import ground_distance
from twig_ecs.step import StepContext
from twig_ecs.systems.behaviours.approach import walk_towards


@dataclass(slots=True)
class Rider:
    """Likes to spin the merry-go-round now and then."""

    ride: str = "merry_go_round"
    whim: float = 0.03  # chance per second of going for a spin
    push: float = 220.0  # N of push on a handle
    spins: int = 0


@dataclass(slots=True)
class Spin:
    """A child's go at the merry-go-round: walk there, take hold, run round."""

    since: float  # s it got the urge
    phase: str = "go"  # go -> take -> run -> leave
    bar: str = ""  # the node of the ride it holds
    phase_since: float = 0.0
    hands: tuple = ()  # the hands it takes hold with
    run_out: float = 0.0  # m/s round the rim (signed, counter-clockwise seen from above) when it let go


PUSH_TIME = 3.0  # s of running round holding on
WANT = 0.65  # activation while it wants a spin: above play
GIVE_UP = 12.0  # s to get there
TAKE_TIME = 2.5  # s to get a hand on the bar once there
RUN = 2.4  # m/s (at 1.75 m tall) running round alongside
STOOPED = 0.8  # m/s (at 1.75 m tall) walking round alongside, stooped to the deck's rim
OUTSIDE = 0.22  # m (at 1.75 m tall) outside the rim where it stands by the rim bar
RUN_OUTSIDE = 0.36  # m (at 1.75 m tall) outside the rim where it runs holding a handle: the inner
# foot clear of the rim bar (its feet met the turning bar there and it was thrown)
LEAVE_TIME = 0.8  # s at most stepping back out from the rim after letting go
PUSH_LEAD = 0.6  # m/s (at 1.75 m tall) faster than the held bar moves that it runs: it pushes the deck
ARM = 0.56  # m (at 1.75 m tall): shoulder to hand, straight
LET_GO = 28.0  # degrees: a torso pulled this far from upright by the bar lets go of it


@register
class Ride(Behavior):
    """Spin the merry-go-round by running round holding on to it."""

    name = "ride"
    component = Rider

    def run(self, ctx: StepContext) -> None:
        """Maybe get the urge; then propose."""
        dt = ctx.dt
        scene = self.scene
        for entity, (_, rider) in ctx.world.get_components(Character, Rider):
            if not ctx.world.has_component(entity, Spin) and scene.has_entity(rider.ride):
                if scene.rng.random() < rider.whim * dt:
                    ctx.world.add_component(entity, Spin(since=scene.time))
        super().run(ctx)

    def activation(self, character, mind: Mind, goal) -> float:
        """High while the urge lasts."""
        return WANT if self.world.has_component(character.entity, Spin) else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Go to the rim, take hold, run round."""
        rider = self.settings(character)
        ride = self.scene.entity(rider.ride)
        spin = self.world.component_for_entity(character.entity, Spin)
        now = self.scene.time
        scale = character.scale
        pos = ride.node_positions
        centre = _centre(ride)
        rim = max(ground_distance(p, centre) for p in pos)
        character.look_at(rider.ride)
        if spin.phase == "leave":
            # stand up and step back out, clear of the turning rim, before anything else
            away = ground_distance(character.position, centre) - rim
            if away > 2.0 * RUN_OUTSIDE * scale or now - spin.phase_since > LEAVE_TIME:
                self._done(character)
            else:
                # running on round the rim as it slows to a stop over the leave (a run stopped
                # dead vaulted the body over its planted foot: thrown to 50 degrees), stepping
                # out from the rim all the while
                out = _flat_unit(character.position - centre)
                fade = max(0.0, 1.0 - (now - spin.phase_since) / LEAVE_TIME)
                character.walk(_round(out) * spin.run_out * fade + out * STOOPED * scale)
            return
        if spin.phase == "go":
            spin.bar = self._bar_for(character, ride, centre)
            bar = ride.node(spin.bar)
            out = _flat_unit(bar - centre)
            spot = centre + out * (rim + _outside(spin.bar) * scale)
            if ground_distance(character.position, spot) < 0.3:
                spin.phase, spin.phase_since = "take", now
                spin.hands = tuple(h for h in ("left", "right") if h not in character.holding)
                rider.spins += 1
                if not spin.hands:
                    self._done(character)
            elif now - spin.since > GIVE_UP:
                self._done(character)
            else:
                # round what is within 1.2 m only (the deck it walks up to pushes less far)
                character.walk(walk_towards(character, spot, 1.6, cutoff=1.2))
            return
        bar = ride.node(spin.bar)
        if character.torso_pitch > LET_GO:
            # the bar pulls it over (a low rim it must squat to, a deck turning faster than
            # it can follow): it lets go rather than be dragged down
            self._leave(character, spin, now, centre)
            return
        if spin.phase == "take":
            # step in until the bar is within an arm's length of the shoulders
            shoulders = character.node("neck")
            if ground_distance(shoulders, bar) > 0.6 * ARM * scale:
                character.walk(_flat_unit(bar - shoulders) * 0.4)
            else:
                character.stop()
            character.stoop(tuple(bar))
            for hand in spin.hands:
                if character.holding.get(hand) == rider.ride:
                    continue
                character.reach(rider.ride, hand=hand, node=spin.bar)
                palm = character.node(("l_hand", "r_hand")[hand == "right"])
                if np.linalg.norm(palm - bar) < GRAB_REACH * scale:
                    try:
                        character.grab(rider.ride, hand=hand, node=spin.bar)
                    except TwigError:
                        pass
            if any(character.holding.get(h) == rider.ride for h in spin.hands):
                spin.phase, spin.phase_since = "run", now
            elif now - spin.phase_since > TAKE_TIME:
                self._leave(character, spin, now, centre)
            return
        # run round alongside, holding on: along the rim's tangent, steering back to a
        # circle just outside it
        out = _flat_unit(character.position - centre)
        tangent = _round(out)
        if float(tangent @ character.facing) < 0.0:
            # the way it faces: the held bar is at its side, so the side it lies on flips
            # from frame to frame (a child turned back and forth on the spot, and fell)
            tangent = -tangent
        character.stoop(tuple(bar))  # the bar goes round with it: lean to where it is now
        off = ground_distance(character.position, centre) - (rim + _outside(spin.bar) * scale)
        # stooped to the deck's rim it pushes at a walk: nobody runs in a squat
        pace = (RUN if spin.bar.startswith("handle") else STOOPED) * scale
        # pushing a heavy deck up to speed: a little ahead of the bar, not off at a run from a
        # standstill (the arm, holding a bar that lags behind, hauled the body back over - the
        # lean past LET_GO flung it on to 50 degrees as it let go)
        bar_pace = float(ride.node_velocity(spin.bar) @ tangent)
        pace = min(pace, max(0.0, bar_pace) + PUSH_LEAD * scale)
        walk = tangent * pace - out * 1.5 * off
        speed = float(np.linalg.norm(walk))
        limit = character.character.max_speed
        character.walk(walk * min(1.0, limit / max(speed, 1e-9)))
        if now - spin.phase_since > PUSH_TIME:
            self._leave(character, spin, now, centre)

    def _bar_for(self, character, ride, centre: np.ndarray) -> str:
        """The node it will hold: the nearest overhead handle if it can reach that high,
        else the nearest node of the deck's rim."""
        names = ride.node_names
        pos = ride.node_positions
        shoulder = float(character.node("neck")[1])
        handles = [k for k, n in enumerate(names) if n.startswith("handle")]
        if not handles or pos[handles[0]][1] > shoulder + 0.75 * ARM * character.scale:
            handles = [k for k, n in enumerate(names) if n.startswith("rim")] or list(range(len(names)))
        return names[min(handles, key=lambda k: ground_distance(pos[k], character.position))]

    def _leave(self, character, spin, now: float, centre: np.ndarray) -> None:
        """Let go and step back out from the rim, running on round it as it slows (the
        ``leave`` phase); ``centre``: the deck's axle point."""
        self._let_go(character)
        spin.run_out = float(character.walk_velocity @ _round(_flat_unit(character.position - centre)))
        spin.phase, spin.phase_since = "leave", now

    def _done(self, character) -> None:
        if self.world.has_component(character.entity, Spin):
            self.world.remove_component(character.entity, Spin)
        self._let_go(character)

    def _let_go(self, character) -> None:
        rider = self.settings(character)
        for hand, held in list(character.holding.items()):
            if held == rider.ride:
                character.release(hand)
        character.stoop(None)

    def stop(self, character, goal) -> None:
        """Let go of the bar, stop (an interrupted go starts again from walking there)."""
        self._let_go(character)
        spin = self.world.try_component(character.entity, Spin)
        if spin is not None:
            spin.phase = "go"
        character.stop()
        character.pose("hang")


def _outside(bar: str) -> float:
    """How far outside the rim (m at 1.75 m tall) a rider holding ``bar`` stands and runs."""
    return RUN_OUTSIDE if bar.startswith("handle") else OUTSIDE


def _centre(ride) -> np.ndarray:
    """The axle's point of a ride: its ``hub`` node, else the middle of its nodes."""
    return ride.node("hub") if "hub" in ride.node_names else ride.node_positions.mean(axis=0)


def _round(out: np.ndarray) -> np.ndarray:
    """The way round a deck (counter-clockwise seen from above) at a point ``out`` from its
    centre (a unit ground vector)."""
    return np.cross([0.0, 1.0, 0.0], out)


def _flat_unit(v: np.ndarray) -> np.ndarray:
    v = v * np.array([1.0, 0.0, 1.0])
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else np.array([0.0, 0.0, 1.0])
