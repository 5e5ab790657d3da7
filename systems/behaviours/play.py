"""play: run after the toy and kick it about, by contact (SPEC 5).

For each character with a :class:`Playful`: its activation is its
joy, damped by its anxiety if it has an attachment. Winning, it picks a place to send
the toy (inside the yard, if the scene has fences round it: see :func:`yard_of`), runs
round to the far side of the toy from there, slows as it comes up behind it and swings
the foot that stands behind the toy through it on a ballistic arc
(:func:`twig_ecs.systems.behaviours.kick.launch_kick`). The toy moves only because the leg's
capsules hit it; a kick that misses leaves it lying, and the child lines up again.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Attachment
from twig_ecs.steering import SteeringParams, approach_velocity, ground_distance
from twig_ecs.store import NODE_LOCKED
from twig_ecs.systems.behaviours.approach import obstacles_near
from twig_ecs.systems.behaviours.kick import FEET, foot_busy, launch_kick


@dataclass(slots=True)
class Playful:
    """Loves a toy: approaches it and kicks it about."""

    toy: str = "ball"
    joy: float = 0.5  # activation of play
    speed: float = 2.0  # m/s running after it
    touches: int = 0


@dataclass(slots=True)
class Kicking:
    """A child's game with its toy: where it wants the toy to go, its kick."""

    aim_at: np.ndarray  # where it sends the toy (m)
    kicked_at: float = -1e9
    chosen_at: float = 0.0  # s it chose ``aim_at``
    kick_ends: float = -1e9  # s the swinging foot lands
    foot: str = ""  # the foot that kicked last ('l_foot' or 'r_foot')
    speed_before: float = 0.0  # m/s of the toy before the kick
    counted: bool = True  # has the last kick been judged (touched or missed)?


@dataclass(slots=True)
class ToyHome:
    """Where a toy lay when play first sent it somewhere: with no fenced yard, kicks aim
    within a circle round it (on the toy's entity, systems/behaviours/play.py)."""

    at: np.ndarray


BEHIND = 0.6  # m (at 1.75 m tall): pelvis to toy centre, along the aim, when it kicks
LINE_UP = 0.35  # m (at 1.75 m tall): how near that spot it must be to kick
CREEP = 0.45  # m/s: the least pace of the last steps (the field fades to nothing at the spot)
RETHINK = 5.0  # s lining up without a kick: send the toy somewhere else
THROUGH = 0.3  # m (at 1.75 m tall) beyond the toy's centre that the foot's arc ends
FOOT_SPEED = 5.5  # m/s (at 1.75 m tall) of the swinging foot along the ground
LIFT = 0.12  # m (at 1.75 m tall) above the toy's centre where the arc ends: the foot rises into it
SLOW = 0.6  # m/s: the last steps up to the toy
SETTLE = 0.25  # s after a kick before lining up again
LAND_WAIT = 1.0  # s after a kick at most that it waits for the kicking foot to come down
ROLLING = 1.5  # m/s: a toy rolling faster than this is chased, not kicked
ARRIVED = 1.2  # m: a toy this near the place it was sent to gets a new one
YARD_MARGIN = 2.5  # m inside the fence that a kick aims for
DECK_MARGIN = 2.0  # m beyond a turning deck's rim that a kick aims for (a ball at rest against it is awkward)
DECK_PATH = 0.6  # m beyond a deck's rim that a kick's straight path keeps
DECK_CLEAR = 0.5  # m (at 1.75 m tall) beyond a deck's rim where the kicker stands: its legs clear the rim
TRIES = 8  # places drawn for the toy before taking the one furthest from the decks
KICK_CONE = 0.7  # cos of the largest angle between the body's facing and a kick's swing (45 deg)
TURN_PACE = 0.3  # m/s (at 1.75 m tall) of the steps that turn the body to a toy beside it
OPEN_FIELD = 6.0  # m: with no fence, the radius round the toy's start that kicks aim within


def decks_of(scene) -> list[tuple[np.ndarray, float]]:
    """The (x, z) centre and rim radius of every body that turns on a fixed axle (a
    merry-go-round's deck): its nodes only go round, so the disc stays where it is."""
    st = scene.state
    n = st.nodes.count
    axle, body = st.nodes.axle_a[:n], st.nodes.body[:n]
    out = []
    for b in np.unique(body[axle >= 0]):
        rows = np.flatnonzero((body == b) & (axle >= 0))
        centre = st.nodes.pos[axle[rows[0]]][[0, 2]].copy()
        out.append((centre, float(st.nodes.axle_radius[rows].max())))
    return out


def deck_clearance(decks, start: np.ndarray, end: np.ndarray) -> float:
    """How far (m) the ground segment start-end keeps beyond the rims of ``decks``
    (negative: it crosses one); inf with no decks."""
    worst = np.inf
    a, ab = start[[0, 2]], (end - start)[[0, 2]]
    for centre, radius in decks:
        t = float(np.clip((centre - a) @ ab / max(float(ab @ ab), 1e-12), 0.0, 1.0))
        worst = min(worst, float(np.linalg.norm(a + t * ab - centre)) - radius)
    return worst


def yard_of(scene) -> tuple[np.ndarray, np.ndarray] | None:
    """The (x, z) low and high corners of the fenced yard: the box round every static
    body wider than 2 m (fences, walls; all nodes locked), or None without fences."""
    st = scene.state
    n = st.nodes.count
    body, flags, pos = st.nodes.body[:n], st.nodes.flags[:n], st.nodes.pos[:n]
    free = np.bincount(body, (flags & NODE_LOCKED) == 0, st.bodies.count)
    static = np.flatnonzero(free == 0)
    points = []
    for b in static:
        rows = pos[body == b][:, [0, 2]]
        if np.ptp(rows, axis=0).max() > 2.0:
            points.append(rows)
    if not points:
        return None
    every = np.concatenate(points)
    return every.min(axis=0), every.max(axis=0)


@register
class Play(Behavior):
    """Chase the toy and kick it where it wants it to go."""

    name = "play"
    component = Playful

    def setup(self) -> None:
        """The yard (looked up once: fences do not move). Each child's game is its
        :class:`~twig_ecs.components.Kicking` component."""
        self.yard: tuple[np.ndarray, np.ndarray] | None | bool = False
        self.decks: list[tuple[np.ndarray, float]] | None = None

    def activation(self, character, mind: Mind, goal) -> float:
        """Joy, less the anxiety of an attached child."""
        playful = self.settings(character)
        if not self.scene.has_entity(playful.toy):
            return 0.0
        attachment = self.world.try_component(character.entity, Attachment)
        anxiety = attachment.anxiety if attachment is not None else 0.0
        return playful.joy * (1.0 - 0.5 * anxiety)

    def _decks(self) -> list[tuple[np.ndarray, float]]:
        """The scene's turning decks (looked up once: their axles do not move)."""
        if self.decks is None:
            self.decks = decks_of(self.scene)
        return self.decks

    def _target(self, toy_name: str, toy_at: np.ndarray) -> np.ndarray:
        """A new place to send the toy: inside the yard, or near where the toy started;
        away from any turning deck, and not across one (of a few draws, the clearest)."""
        decks = self._decks()
        best, clearest = None, -np.inf
        for _ in range(TRIES if decks else 1):
            place = self._draw_target(toy_name, toy_at)
            clear = min(deck_clearance(decks, place, place) - DECK_MARGIN,
                        deck_clearance(decks, toy_at, place) - DECK_PATH)  # fmt: skip
            if clear > clearest:
                best, clearest = place, clear
            if clear >= 0.0:
                break
        return best

    def _draw_target(self, toy_name: str, toy_at: np.ndarray) -> np.ndarray:
        """A place drawn at random: inside the yard, or near where the toy started."""
        if self.yard is False:
            self.yard = yard_of(self.scene)
        rng = self.scene.rng
        if self.yard is not None:
            lo, hi = self.yard
            lo, hi = lo + YARD_MARGIN, np.maximum(hi - YARD_MARGIN, lo + YARD_MARGIN)
            x, z = rng.uniform(lo[0], hi[0]), rng.uniform(lo[1], hi[1])
        else:
            toy = self.scene.entity(toy_name).entity
            home = self.world.try_component(toy, ToyHome)
            if home is None:
                home = ToyHome(toy_at.copy())
                self.world.add_component(toy, home)
            home = home.at
            angle, r = rng.uniform(0.0, 2.0 * np.pi), OPEN_FIELD * np.sqrt(rng.uniform())
            x, z = home[0] + r * np.cos(angle), home[2] + r * np.sin(angle)
        return np.array([x, 0.0, z])

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Line up behind the toy, then swing a foot through it."""
        playful = self.settings(character)
        toy = self.scene.entity(playful.toy)
        now = self.scene.time
        scale = character.scale
        ball = toy.position
        game = self.world.try_component(character.entity, Kicking)
        stale = game is not None and now - max(game.chosen_at, game.kick_ends) > RETHINK
        if game is None or stale or ground_distance(ball, game.aim_at) < ARRIVED:
            game = Kicking(self._target(playful.toy, ball), chosen_at=now)
            self.world.add_component(character.entity, game)
        speed = float(np.linalg.norm(toy.velocity))
        if not game.counted and now >= game.kick_ends:
            game.counted = True
            if speed > game.speed_before + 0.3:  # the foot met it: it went off faster
                playful.touches += 1
        character.look_at(playful.toy)
        landing = game.foot and now < game.kick_ends + LAND_WAIT and not character.is_locked(game.foot)
        if now < game.kick_ends + SETTLE or landing:
            # the kick is in flight: stand on the other foot until the kicking one is down
            # (running after the toy with it still up splits the legs)
            character.stop()
            return
        aim = _flat_unit(game.aim_at - ball)
        left = np.array([aim[2], 0.0, -aim[0]])  # the body's left when facing along the aim
        foot = self._kicking_foot(character, ball, aim, left)
        # the pelvis stands behind the toy, shifted sideways so the kicking foot is on
        # the line through it
        side = 1.0 if foot == "r_foot" else -1.0
        spot = ball - aim * BEHIND * scale + left * side * 0.1 * scale
        if self.yard:
            # a toy by the fence: the spot behind it may be beyond the fence; stand
            # inside and kick along (or off) the fence instead
            lo, hi = self.yard
            inside = np.clip(spot[[0, 2]], lo + 0.4, hi - 0.4)
            if np.any(inside != spot[[0, 2]]):
                spot[[0, 2]] = inside
                aim = _flat_unit(ball - spot)
                left = np.array([aim[2], 0.0, -aim[0]])
        spot, aim, left = self._off_the_decks(spot, ball, aim, left, scale)
        here = character.position
        behind = float((here - ball) @ aim) < -0.1 * scale
        exclude = {playful.toy} if behind else set()
        far = ground_distance(here, spot)
        params = SteeringParams(speed=playful.speed if far > 1.0 else min(playful.speed, SLOW))
        obstacles = obstacles_near(character, exclude, params.cutoff)
        if far > LINE_UP * scale or not behind or speed > ROLLING or foot_busy(character):
            walk = approach_velocity(here, self._round_the_decks(here, spot, scale), obstacles, params)
            pace = float(np.linalg.norm(walk))
            if 1e-6 < pace < CREEP:
                walk *= CREEP / pace
            character.walk(walk)
            return
        self._kick(character, foot, ball, aim, game, speed)

    def _off_the_decks(self, spot: np.ndarray, ball: np.ndarray, aim: np.ndarray, left: np.ndarray,
                       scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # fmt: skip
        """A toy by a turning deck: the spot behind it may be on the deck, where the legs
        catch its bars and kick it round; stand off the rim and kick the toy from there."""
        for centre, radius in self._decks():
            out = spot[[0, 2]] - centre
            far = float(np.linalg.norm(out))
            clear = radius + DECK_CLEAR * scale
            if far < clear:
                out = out / far if far > 1e-9 else np.array([0.0, 1.0])
                spot = spot.copy()
                spot[[0, 2]] = centre + out * clear
                aim = _flat_unit(ball - spot)
                left = np.array([aim[2], 0.0, -aim[0]])
        return spot, aim, left

    def _round_the_decks(self, here: np.ndarray, spot: np.ndarray, scale: float) -> np.ndarray:
        """Where to head for ``spot``: straight there, unless the way crosses a turning deck
        (the field's push off its rim is soft, and legs in its bars spin it): then out off the
        deck, or to the point beside it on the near side, past its rim."""
        for centre, radius in self._decks():
            clear = radius + DECK_CLEAR * scale
            if deck_clearance([(centre, clear)], here, spot) >= 0.0:
                continue
            out = here[[0, 2]] - centre
            far = float(np.linalg.norm(out))
            if far < clear:  # on the deck or at its rim: step off it first
                point = centre + (out / far if far > 1e-9 else np.array([0.0, 1.0])) * (clear + 0.3)
                return np.array([point[0], here[1], point[1]])
            way = (spot - here)[[0, 2]]
            way = way / max(float(np.linalg.norm(way)), 1e-9)
            across = np.array([-way[1], way[0]])
            if float(across @ (centre - here[[0, 2]])) > 0.0:
                across = -across  # the side of the deck that the child is on
            point = centre + across * (clear + 0.3)
            return np.array([point[0], here[1], point[1]])
        return spot

    def _kicking_foot(self, character, ball: np.ndarray, aim: np.ndarray, left: np.ndarray) -> str:
        """The foot nearer the line through the toy along the aim."""
        offsets = [abs(float((character.node(f) - ball) @ left)) for f in FEET]
        return FEET[int(np.argmin(offsets))]

    def _kick(self, character, foot: str, ball: np.ndarray, aim: np.ndarray, game: Kicking,
              speed: float) -> None:  # fmt: skip
        """Swing ``foot`` through the toy towards the aim; the other foot stays planted."""
        scale = character.scale
        other = FEET[1 - FEET.index(foot)]
        start = character.node(foot)
        if not character.scene.state.nodes.flags[character.node_row(other)] & NODE_LOCKED:
            character.stop()  # wait for the standing foot to plant
            return
        # the arc ends beyond the toy, on the aim line - but only a swing in front of the body:
        # a foot swung across or behind it spins the child round on its standing foot, so a
        # toy off to the side of the kick is turned to first (slow steps towards it)
        end = ball + aim * THROUGH * scale
        if float(_flat_unit(end - start) @ character.facing) < KICK_CONE:
            character.walk(_flat_unit(ball - character.position) * TURN_PACE * scale)
            return
        # and above its centre: the foot meets it rising, under the centre, and lofts it
        # (a ball rolling on the ground soon stops)
        end[1] = ball[1] + LIFT * scale
        run = ground_distance(start, end)
        duration = max(0.06, run / (FOOT_SPEED * scale**0.5))
        character.stop()
        launch_kick(character, foot, end, duration)
        now = character.scene.time
        game.kicked_at, game.kick_ends, game.foot = now, now + duration, foot
        game.speed_before, game.counted = speed, False

    def stop(self, character, goal) -> None:
        """Stop running."""
        character.stop()


def _flat_unit(v: np.ndarray) -> np.ndarray:
    v = v * np.array([1.0, 0.0, 1.0])
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else np.array([0.0, 0.0, 1.0])
