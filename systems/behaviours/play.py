"""play: run after the toy and kick it about, by contact (SPEC 5).

For each character with a :class:`Playful`: its activation is its
joy, damped by its anxiety if it has an attachment. Winning, it picks a place to send
the toy (inside the yard, if the scene has fences round it: see :func:`yard_of`; of a few
places drawn, one it can kick the toy to from the side it is on, so it need not walk
round the toy; a child tied to a caregiver aims near the caregiver, and when that puts
the spot it kicks from beyond a toy further out than itself, it kicks the toy straight
on from the side it came from instead), goes to the spot behind the toy from there,
slows as it comes up and kicks with the foot on the line through the toy: a backswing
(the foot behind the standing hip, heel up), the swing through the toy and a
follow-through, each a ballistic arc (:func:`twig_ecs.systems.behaviours.kick.launch_kick`),
the other foot planted beside and a little behind the toy. The toy moves only because the
leg's capsules hit it; a kick that misses leaves it lying, and the child lines up again.
Children playing with one toy take turns (the last to kick holds back while another goes
for it) and pass (a child not tied to a caregiver sends it to a playmate going for it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind, register
from twig_ecs.components import Attachment
from twig_ecs.steering import ground_distance
from twig_ecs.store import NODE_LOCKED
from twig_ecs.systems.behaviours.approach import walk_towards
from twig_ecs.systems.behaviours.kick import FEET, foot_busy, launch_kick
from twig_ecs.systems.control.gait import KICK_DIP

HIPS = {"l_foot": "l_hip", "r_foot": "r_hip"}  # the hip above each foot


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
    phase: str = ""  # the kick under way: "back" (backswing), "swing", "follow" (through), "down"; "" none
    phase_ends: float = -1e9  # s the current phase's arc ends
    aim: np.ndarray | None = None  # unit ground vector the kick under way sends the toy along
    contact: np.ndarray | None = None  # where the swinging foot's arc ends, through the toy
    onward: bool = False  # ``aim_at`` is straight on from the side the child came from (one kick)
    passing: bool = False  # ``aim_at`` is a pass to a playmate


@dataclass(slots=True)
class ToyHome:
    """Where a toy lay when play first sent it somewhere: with no fenced yard, kicks aim
    within a circle round it (on the toy's entity, systems/behaviours/play.py)."""

    at: np.ndarray


BEHIND = 0.26  # m (at 1.75 m tall): pelvis to toy centre, along the aim, when it kicks: the
# swing's lowest point (under the hip) meets the toy, and the standing foot is beside it
LINE_UP = 0.2  # m (at 1.75 m tall): how near that spot it must be to kick
CREEP = 0.45  # m/s: the least pace of the last steps (the field fades to nothing at the spot)
RETHINK = 5.0  # s lining up without a kick: send the toy somewhere else
# the kick, in three ballistic arcs of the kicking foot (at 1.75 m tall; times by the root of the size)
BACK = 0.3  # m behind the hip the backswing takes the foot ...
BACK_UP = 0.22  # m ... and this high (the knee bends, the heel comes up)
BACK_TIME = 0.2  # s of the backswing
THROUGH = 0.05  # m beyond the toy's centre the swing's arc ends (within the leg's reach: a foot
# sent beyond it is pulled in and slowed by the gait's guide)
FOOT_SPEED = 7.0  # m/s of the swinging foot along the ground (5.8 m/s for a 1.2 m child)
FOLLOW = 0.78  # leg lengths ahead of the hip the follow-through takes the foot ...
FOLLOW_DROP = 0.55  # ... and this many below it: the leg near straight, 35 degrees below level
FOLLOW_TIME = 0.15  # s of the follow-through
DOWN = 0.2  # m ahead of the hip the foot comes down after it ...
DOWN_TIME = 0.2  # s ... in this long
REACH = 0.9  # of the leg's horizontal reach at the swing's height: the furthest the swing ends
SURE = 0.85  # of that reach: the furthest the toy's centre may be for a kick (at the edge of it,
# the hip drawn back a little by the backswing, the swing ended at the toy's back: a tap)
RUNUP = 0.5  # m (at 1.75 m tall) behind the spot that a child not yet lined up on the kicking
# line walks to first, so that it comes up to the toy along the aim, facing it
RUNUP_WIDTH = 0.2  # m (at 1.75 m tall) off the kicking line that is on it ...
RUNUP_FROM = 0.9  # ... from this far behind the spot: then the last steps go straight along it
DIRECT = 1.2  # m (at 1.75 m tall) from the run-up point within which it walks straight there
# (and within 1.2 m at any size while the field turns it away from the point)
LAST_PACE = 0.25  # m/s (at 1.75 m tall, by the root of the size): the least pace of those steps
KICKING_FOOT = "r_foot"  # a child kicks with its stronger foot (the other stands beside the toy)
AROUND = 0.6  # m (at 1.75 m tall) out from the toy that a child on its wrong side walks round it
AHEAD = 0.5  # cos of the largest angle between where the toy is sent and the way from the child
# to the toy that a new place is drawn for (60 degrees: no walk round the toy to kick it)
SLOW = 0.6  # m/s: the last steps up to the toy
SETTLE = 0.25  # s after a kick before lining up again
LAND_WAIT = 1.0  # s after a kick at most that it waits for the kicking foot to come down
ROLLING = 1.5  # m/s: a toy rolling faster than this is chased, not kicked
ARRIVED = 1.2  # m: a toy this near the place it was sent to gets a new one
YARD_MARGIN = 2.5  # m inside the fence that a kick aims for
FENCE_ROOM = 0.4  # m (at 1.75 m tall) inside the fence that a kicker stands (at 0.4 m whatever its size,
# the 1.05 m child stood 0.32 m from a ball by the fence, beyond its swing's reach, stepping on the spot)
DECK_MARGIN = 2.0  # m beyond a turning deck's rim that a kick aims for (a ball at rest against it is awkward)
DECK_PATH = 0.6  # m beyond a deck's rim that a kick's straight path keeps
DECK_CLEAR = 0.5  # m (at 1.75 m tall) beyond a deck's rim where the kicker stands: its legs clear the rim
TRIES = 8  # places drawn for the toy before taking the one furthest from the decks
KICK_CONE = 0.7  # cos of the largest angle between the body's facing and a kick's swing (45 deg)
TURN_PACE = 0.3  # m/s (at 1.75 m tall) of the steps that turn the body to a toy beside it
TURN_STEP = 0.06  # m/s (at 1.75 m tall): the walk that turns the body to the aim on the kicking spot
NEAR_HOME = 3.0  # m beyond its safe distance from its caregiver that an attached child kicks the toy to
ONWARD = 4.0  # m beyond the toy that an attached child kicking it on from its own side aims
OPEN_FIELD = 6.0  # m: with no fence, the radius round the toy's start that kicks aim within
PASS_RANGE = 9.0  # m from the toy within which a playmate is passed to
PASS_SHORT = 1.0  # m short of the playmate that a pass aims: the toy rolls up to it
TURN_WAIT = 12.0  # s after its kick at most that a child holds back while a playmate goes for the toy
HOLD_OFF = 0.25  # s an attached child on its kicking spot holds off running home (renewed each step there)
WAIT_OFF = 2.0  # m (at 1.75 m tall) from the toy that a child waiting its turn keeps


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


def fences_of(scene) -> list[np.ndarray]:
    """The node positions (rows of x, y, z) of every static body wider than 2 m: fences,
    walls (all nodes locked)."""
    st = scene.state
    n = st.nodes.count
    body, flags, pos = st.nodes.body[:n], st.nodes.flags[:n], st.nodes.pos[:n]
    free = np.bincount(body, (flags & NODE_LOCKED) == 0, st.bodies.count)
    fences = []
    for b in np.flatnonzero(free == 0):
        rows = pos[body == b]
        if np.ptp(rows[:, [0, 2]], axis=0).max() > 2.0:
            fences.append(rows)
    return fences


def yard_of(scene) -> tuple[np.ndarray, np.ndarray] | None:
    """The (x, z) low and high corners of the fenced yard: the box round every fence
    (:func:`fences_of`), or None without fences."""
    fences = fences_of(scene)
    if not fences:
        return None
    every = np.concatenate(fences)[:, [0, 2]]
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

    def _yard(self) -> tuple[np.ndarray, np.ndarray] | None:
        """The fenced yard's corners, or None (looked up once: fences do not move)."""
        if self.yard is False:
            self.yard = yard_of(self.scene)
        return self.yard

    def _decks(self) -> list[tuple[np.ndarray, float]]:
        """The scene's turning decks (looked up once: their axles do not move)."""
        if self.decks is None:
            self.decks = decks_of(self.scene)
        return self.decks

    def _playmates(self, character, toy_name: str) -> list[int]:
        """The other characters playing with the same toy right now (their entities)."""
        mates = []
        for entity, playful in self.world.get_component(Playful):
            if entity != character.entity and playful.toy == toy_name:
                mind = self.world.try_component(entity, Mind)
                if mind is not None and mind.winner == self.name:
                    mates.append(entity)
        return mates

    def _waits_its_turn(self, character, playful: Playful, game: Kicking, ball: np.ndarray) -> bool:
        """Taking turns: a child that kicked the toy last holds back while a playmate goes
        for it - for TURN_WAIT after its kick at most, WAIT_OFF from the toy, watching it.
        (Without turns the 1.75 m child, quicker to every ball, kicked it away from under the
        1.05 m child again and again: schoolyard seed 0's small child came within 1-2.5 m of
        the ball three times in its first 70 s and never kicked it.)"""
        if self.scene.time - game.kicked_at > TURN_WAIT:
            return False
        mates = self._playmates(character, playful.toy)
        if not mates:
            return False
        for entity in mates:
            theirs = self.world.try_component(entity, Kicking)
            if theirs is not None and theirs.kicked_at > game.kicked_at:
                return False  # a playmate has had its turn since
        away = character.position - ball
        away[1] = 0.0
        gap = float(np.hypot(away[0], away[2]))
        if 1e-6 < gap < WAIT_OFF * character.scale:
            character.walk(away / gap * SLOW)  # out of the way of the kick
        else:
            character.stop()
        return True

    def _pass_to(self, kicker, toy_name: str, toy_at: np.ndarray) -> np.ndarray | None:
        """Where to pass the toy: just short of a playmate going for it (the nearest within
        PASS_RANGE), if that is onwards from the kicker and clear of the decks; else None.
        A child tied to a caregiver does not pass: its kicks stay near home."""
        if self.world.try_component(kicker.entity, Attachment) is not None:
            return None
        toward = _flat_unit(toy_at - kicker.position)
        best, nearest = None, PASS_RANGE
        for entity in self._playmates(kicker, toy_name):
            mate = self.scene.character_handle(entity).position
            gap = ground_distance(mate, toy_at)
            if gap >= nearest or gap <= PASS_SHORT:
                continue
            place = mate + _flat_unit(toy_at - mate) * PASS_SHORT
            place[1] = 0.0
            if float(_flat_unit(place - toy_at) @ toward) < AHEAD:
                continue  # behind the kicker: it would have to walk round the toy
            if not self._room_behind(toy_at, _flat_unit(place - toy_at), kicker.scale):
                continue  # by the fence, the kicking spot beyond it: no pass from a corner
            decks = self._decks()
            if min(deck_clearance(decks, place, place), deck_clearance(decks, toy_at, place)) < DECK_PATH:
                continue
            best, nearest = place, gap
        return best

    def _room_behind(self, toy_at: np.ndarray, aim: np.ndarray, scale: float) -> bool:
        """Whether the spot a kick along ``aim`` is made from lies inside the yard (no yard: yes)."""
        yard = self._yard()
        if yard is None:
            return True
        lo, hi = yard
        spot = (toy_at - aim * BEHIND * scale)[[0, 2]]
        return bool(np.all(spot >= lo + FENCE_ROOM * scale) and np.all(spot <= hi - FENCE_ROOM * scale))

    def _target(self, toy_name: str, toy_at: np.ndarray, kicker) -> np.ndarray:
        """A new place to send the toy: inside the yard, or near where the toy started;
        away from any turning deck, and not across one; and onwards from where the kicker
        stands (within 60 degrees of the way from it to the toy, so it kicks from its own
        side instead of walking round the toy). Of a few draws, the first that does both,
        else the best: the clearest of the decks, then the most onwards. (A playmate going
        for the toy gets it passed instead: :meth:`_pass_to`.)"""
        decks = self._decks()
        toward = _flat_unit(toy_at - kicker.position)
        best, score = None, (-np.inf, -np.inf)
        for _ in range(TRIES):
            place = self._draw_target(toy_name, toy_at, kicker)
            clear = min(deck_clearance(decks, place, place) - DECK_MARGIN,
                        deck_clearance(decks, toy_at, place) - DECK_PATH)  # fmt: skip
            onwards = float(_flat_unit(place - toy_at) @ toward)
            mine = (min(clear, 0.0), onwards)
            if mine > score:
                best, score = place, mine
            if clear >= 0.0 and onwards >= AHEAD:
                break
        return best

    def _draw_target(self, toy_name: str, toy_at: np.ndarray, kicker) -> np.ndarray:
        """A place drawn at random: inside the yard, or near where the toy started; for a
        child tied to a caregiver, near the caregiver (a kick sends the ball 10-20 m, and
        a child sent after it that far soon runs home instead of playing)."""
        yard = self._yard()
        rng = self.scene.rng
        attachment = self.world.try_component(kicker.entity, Attachment)
        if attachment is not None and self.scene.has_entity(attachment.caregiver):
            home = self.scene.entity(attachment.caregiver).position
            angle, r = (
                rng.uniform(0.0, 2.0 * np.pi),
                (attachment.safe_distance + NEAR_HOME) * np.sqrt(rng.uniform()),
            )
            x, z = home[0] + r * np.cos(angle), home[2] + r * np.sin(angle)
            if yard is not None:
                lo, hi = yard
                x, z = (
                    np.clip(x, lo[0] + YARD_MARGIN, hi[0] - YARD_MARGIN),
                    np.clip(z, lo[1] + YARD_MARGIN, hi[1] - YARD_MARGIN),
                )
            return np.array([x, 0.0, z])
        if yard is not None:
            lo, hi = yard
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
            # (a new place to send the toy; when it last kicked is kept, for taking turns)
            kicked = game.kicked_at if game is not None else -1e9  # (never)
            game = Kicking(self._target(playful.toy, ball, character), chosen_at=now, kicked_at=kicked)
            self.world.add_component(character.entity, game)
        elif game.onward and game.counted and not game.phase and game.kicked_at >= game.chosen_at:
            # kicked on from its own side: the next kick aims near home again (the game
            # itself kept: the kicking foot may still be coming down)
            game.aim_at, game.chosen_at, game.onward = self._target(playful.toy, ball, character), now, False
        if not game.passing and not game.phase and now >= game.kick_ends + SETTLE:
            # a playmate going for the toy (now, or since the child chose where to send it)
            # gets it passed; the pass stands until the toy gets there or goes stale
            passed = self._pass_to(character, playful.toy, ball)
            if passed is not None:
                game.aim_at, game.chosen_at, game.onward, game.passing = passed, now, False, True
        speed = float(np.linalg.norm(toy.velocity))
        if not game.counted and now >= game.kick_ends:
            game.counted = True
            if speed > game.speed_before + 0.3:  # the foot met it: it went off faster
                playful.touches += 1
        character.look_at(playful.toy)
        if game.phase:
            self._hold_off_home(character, now)
            self._kick_on(character, game)
            return
        landing = game.foot and now < game.kick_ends + LAND_WAIT and not character.is_locked(game.foot)
        if now < game.kick_ends + SETTLE or landing:
            # the kick is in flight: stand on the other foot until the kicking one is down
            # (running after the toy with it still up splits the legs)
            character.stop()
            return
        if self._waits_its_turn(character, playful, game, ball):
            return
        aim = self._from_its_side(character, game, ball, _flat_unit(game.aim_at - ball))
        left = np.array([aim[2], 0.0, -aim[0]])  # the body's left when facing along the aim
        foot = KICKING_FOOT
        # the pelvis stands behind the toy, shifted sideways so the kicking foot is on
        # the line through it
        side = 1.0 if foot == "r_foot" else -1.0
        spot = ball - aim * BEHIND * scale + left * side * 0.1 * scale
        yard = self._yard()
        if yard is not None:
            # a toy by the fence: the spot behind it may be beyond the fence; kick along
            # the fence instead (the aim with its part across the fence dropped), and
            # stand inside
            lo, hi = yard
            inside = np.clip(spot[[0, 2]], lo + FENCE_ROOM * scale, hi - FENCE_ROOM * scale)
            if np.any(inside != spot[[0, 2]]):
                along = aim.copy()
                along[[0, 2]] *= inside == spot[[0, 2]]  # keep only the part along the fence
                if np.hypot(along[0], along[2]) < 1e-6:
                    along = np.array([aim[2], 0.0, -aim[0]]) * (inside == spot[[0, 2]])[[0, 0, 1]]
                aim = _flat_unit(along)
                if float((ball - character.position) @ aim) < 0.0:
                    # along the fence from the child's own side: the way round the toy to
                    # its far side runs by the boards, and the steering held a child off it
                    # (seed 1's big child stepped to and fro 1 m off a ball by the fence for
                    # most of five minutes once a foot no longer squeezed it out of the corner)
                    aim = -aim
                left = np.array([aim[2], 0.0, -aim[0]])
                spot = ball - aim * BEHIND * scale + left * side * 0.1 * scale
                inside = np.clip(spot[[0, 2]], lo + FENCE_ROOM * scale, hi - FENCE_ROOM * scale)
                if np.any(inside != spot[[0, 2]]):
                    spot[[0, 2]] = inside
                    aim = _flat_unit(ball - spot)
                    if float((character.position - ball) @ aim) >= -0.1 * scale:
                        # pinned in a corner, the child on its open side: the spot wedged
                        # in the corner is out of its reach (schoolyard seed 0's big child
                        # stood by a cornered ball for 160 s), so it kicks the toy from
                        # where it stands, into the corner, and it comes back off the boards
                        aim = _flat_unit(ball - character.position)
                        spot = ball - aim * BEHIND * scale
                        # ... and keeps that aim until the kick (recomputed from where it
                        # stands each step, the aim swung as it moved, and seed 1's big child
                        # stepped to and fro 0.9 m off a ball by the fence for 10 s at a time)
                        game.aim_at, game.chosen_at, game.onward = ball + aim * ONWARD, now, True
                    left = np.array([aim[2], 0.0, -aim[0]])
        spot, aim, left = self._off_the_decks(spot, ball, aim, left, scale)
        here = character.position
        behind = float((here - ball) @ aim) < -0.1 * scale
        exclude = (playful.toy,) if behind else ()
        far = ground_distance(here, spot)
        steer_pace = playful.speed if far > 1.0 else min(playful.speed, SLOW)
        if far > LINE_UP * scale or not behind or speed > ROLLING or foot_busy(character):
            if not behind:  # on the toy's wrong side: round it first
                goal = _round_the_toy(here, ball, aim, left, scale)
                walk = walk_towards(character, self._round_the_decks(here, goal, scale), steer_pace, exclude)
            else:
                off = here - spot
                lateral, back = abs(float(off @ left)), -float(off @ aim)
                on_line = lateral < RUNUP_WIDTH * scale and -LINE_UP * scale < back < RUNUP_FROM * scale
                if on_line and speed <= ROLLING:
                    # on the kicking line behind the spot: the last steps straight along it
                    # (facing the aim when it gets there), slowing as it comes up
                    self._hold_off_home(character, now)
                    if far <= LINE_UP * scale:
                        # on the spot, a foot still in the air: the way to the spot is noise
                        # there, and the body turns to the way it walks (a 1.2 m child turned
                        # 70 degrees from the aim on the spot and walked onto the toy)
                        character.walk(aim * TURN_STEP * scale)
                        return
                    pace = min(SLOW, max(LAST_PACE, 1.5 * far)) * scale**0.5
                    character.walk(_flat_unit(spot - here) * pace)
                    return
                # else first to a run-up point further back on the line
                goal = spot - aim * RUNUP * scale
                gap = ground_distance(here, goal)
                toward = _flat_unit(goal - here)
                close = gap < DIRECT * scale
                route = self._round_the_decks(here, goal, scale)
                walk = None if close else walk_towards(character, route, steer_pace, exclude)
                # close by: straight there (the field holds a walker off a goal by a fence, or
                # circles it, a metre short); a small child further off too while the field
                # turns it away (held 0.9 m off a ball in the yard's corner, it went home)
                if (close or (gap < DIRECT and float(walk @ toward) <= 0.0)) and speed <= ROLLING:
                    pace = min(SLOW, max(LAST_PACE, 1.5 * gap)) * scale**0.5
                    character.walk(toward * pace)
                    return
                if walk is None:
                    walk = walk_towards(character, route, steer_pace, exclude)
            pace = float(np.linalg.norm(walk))
            # the least pace: round the toy the point beside it is only a way past, which the
            # field slows to as to a goal (a 1.05 m child crept round a ball at 0.46 m/s for
            # 3 s, and its anxiety sent it home 0.7 m short); else CREEP short of the goal
            least = min(SLOW, steer_pace) if not behind else CREEP
            if 1e-6 < pace < least and ground_distance(here, goal) > LINE_UP * scale:
                walk *= least / pace  # (at the goal itself it would circle it)
            character.walk(walk)
            return
        self._hold_off_home(character, now)
        self._kick(character, foot, ball, aim, game, speed)

    def _hold_off_home(self, character, now: float) -> None:
        """On the kicking line's last steps, on the spot or kicking: an attached child finishes
        the kick before it runs home (see :data:`~twig_ecs.systems.behaviours.attachment.FINISH_MARGIN`)."""
        attachment = self.world.try_component(character.entity, Attachment)
        if attachment is not None:
            attachment.finishing_until = now + HOLD_OFF

    def _from_its_side(self, character, game: Kicking, ball: np.ndarray, aim: np.ndarray) -> np.ndarray:
        """The aim of an attached child's next kick: ``aim`` - unless the child is on the
        toy's wrong side for it and going round to the kicking spot would take it further
        from its caregiver. Then it kicks the toy straight on from where it stands (and
        remembers that aim, :attr:`Kicking.onward`, until the kick).

        Its kicks aim near its caregiver and it comes from the caregiver, so a toy further
        out always has the kicking spot on its far side: on schoolyard seed 0 the 1.05 m child
        came within 0.8-1.5 m of the ball four times in five minutes, on the wrong side each
        time, and went home anxious while going round it, without a kick."""
        scale = character.scale
        here = character.position
        if float((here - ball) @ aim) < -0.1 * scale:
            return aim  # behind the toy already: no walk round it
        attachment = self.world.try_component(character.entity, Attachment)
        if attachment is None or not self.scene.has_entity(attachment.caregiver):
            return aim
        home = self.scene.entity(attachment.caregiver).position
        spot = ball - aim * BEHIND * scale
        out = ground_distance(spot, home)
        if out <= ground_distance(ball, home) or out <= ground_distance(here, home):
            return aim  # the kicking spot is not beyond the toy and the child, seen from home
        on = _flat_unit(ball - here)
        if deck_clearance(self._decks(), ball, ball + on * ONWARD) < DECK_PATH:
            return aim  # straight on sends it across a turning deck: round it after all
        game.aim_at, game.chosen_at, game.onward = ball + on * ONWARD, self.scene.time, True
        return on

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

    def _kick(self, character, foot: str, ball: np.ndarray, aim: np.ndarray, game: Kicking,
              speed: float) -> None:  # fmt: skip
        """Begin a kick with ``foot`` towards the aim: the backswing (the other foot stays planted)."""
        scale = character.scale
        other = FEET[1 - FEET.index(foot)]
        if not character.scene.state.nodes.flags[character.node_row(other)] & NODE_LOCKED:
            character.stop()  # wait for the standing foot to plant
            return
        # the swing ends through the toy, on the aim line - but only a swing in front of the body:
        # a foot swung across or behind it spins the child round on its standing foot, so a
        # toy off to the side of the kick is turned to first (slow steps towards it)
        contact = ball + aim * THROUGH * scale
        if float(aim @ character.facing) < KICK_CONE:
            # a very slow walk along the aim turns the body to it on the spot (a step towards
            # the toy itself, from beside it, swung the walk round and the body with it; a
            # faster one took it off the spot, and back it came, facing the other way)
            character.walk(aim * TURN_STEP * scale)
            return
        # at the toy's centre: the foot meets it square (lower, the leg's reach is shorter)
        contact[1] = ball[1]
        hip = character.node(HIPS[foot])
        ahead = float((contact - hip) @ aim)
        if ahead > SURE * _reach(character, hip, contact[1]) or ahead < 0.5 * BEHIND * scale:
            # the toy beyond the swing's reach (or under the hip): a slow step to or from it
            character.walk(aim * (TURN_PACE if ahead > 0.0 else -TURN_PACE) * scale)
            return
        # behind both hips: the kicking one and the standing one (a body turned a little
        # away from the aim has the standing hip further back)
        back = hip - aim * (BACK * scale + max(0.0, float((hip - character.node(HIPS[other])) @ aim)))
        back[1] = BACK_UP * scale
        character.stop()
        now = character.scene.time
        game.phase, game.phase_ends = "back", now + _arc(character, foot, back, BACK_TIME * scale**0.5)
        game.aim, game.contact = aim.copy(), contact
        game.kicked_at, game.kick_ends, game.foot = now, np.inf, foot
        game.speed_before, game.counted = speed, False

    def _kick_on(self, character, game: Kicking) -> None:
        """The kick under way: stand on the other foot; as each arc ends, the next - the swing
        through the toy after the backswing, the follow-through after the swing."""
        character.stop()
        now = character.scene.time
        if now < game.phase_ends:
            return
        scale = character.scale
        foot = game.foot
        hip = character.node(HIPS[foot])
        if game.phase == "back":
            # through the toy, as far as the leg reaches at that height: the gait's guide pulls
            # a foot sent further in and slows it to a walking foot's pace
            end = game.contact.copy()
            flat = _reach(character, hip, end[1])
            off = (end - hip) * np.array([1.0, 0.0, 1.0])
            far = float(np.hypot(off[0], off[2]))
            if far > flat:
                end[[0, 2]] = hip[[0, 2]] + off[[0, 2]] * (flat / far)
            swing = ground_distance(character.node(foot), end) / (FOOT_SPEED * scale**0.5)
            game.phase, game.phase_ends = "swing", now + _arc(character, foot, end, swing)
        elif game.phase == "swing":
            # on, forwards and up, the leg near straight
            leg = float(character.scene.state.characters.leg_length[character.character_row])
            end = hip + game.aim * FOLLOW * leg
            end[1] = hip[1] - FOLLOW_DROP * leg
            game.phase, game.phase_ends = "follow", now + _arc(character, foot, end, FOLLOW_TIME * scale**0.5)
        elif game.phase == "follow":
            # and down, a step ahead of the standing foot (left to fall, the raised leg hung
            # there with the knee bent, as if marching)
            end = hip + game.aim * DOWN * scale
            end[1] = 0.0
            game.phase, game.phase_ends = "down", now + _arc(character, foot, end, DOWN_TIME * scale**0.5)
        else:  # the foot is down (or about to be: Play.act waits for it)
            game.phase, game.kick_ends = "", now

    def stop(self, character, goal) -> None:
        """Stop running; a kick under way is given up (its foot comes down as it falls)."""
        game = self.world.try_component(character.entity, Kicking)
        if game is not None and game.phase:
            game.phase, game.kick_ends = "", self.scene.time
        character.stop()


def _round_the_toy(here: np.ndarray, toy: np.ndarray, aim: np.ndarray, left: np.ndarray,
                   scale: float) -> np.ndarray:  # fmt: skip
    """Where to head for while not yet behind the toy: a point beside it, on the side the
    child is on, ``AROUND`` out and a little behind - so it walks round the toy to the
    kicking spot instead of straight through it (the spot lies beyond the toy)."""
    side = 1.0 if float((here - toy) @ left) >= 0.0 else -1.0
    return toy + (left * side - aim * 0.5) * AROUND * scale


def _reach(character, hip: np.ndarray, height: float) -> float:
    """How far (m, on the ground) from ``hip`` a swinging foot reaches at ``height``, less a
    margin (``REACH``): the gait's guide pulls a foot sent further in, and slows it. Reckoned,
    as the gait does, from the hip KICK_DIP leg lengths lower: the standing knee gives as the
    foot swings (from the straight-legged standing hip, a 1.2 m child's reach was 0.2 m and it
    stepped to and fro by the ball for up to 20 s)."""
    leg = float(character.scene.state.characters.leg_length[character.character_row])
    drop = hip[1] - KICK_DIP * leg - height
    return REACH * float(np.sqrt(max(0.0, (0.99 * leg) ** 2 - drop * drop)))


def _arc(character, foot: str, end: np.ndarray, duration: float) -> float:
    """Send ``foot`` on a ballistic arc to ``end`` in ``duration`` s, rounded up to whole steps
    (so the next arc begins the step this one ends); returns that time less half a step."""
    dt = character.scene.dt
    steps = max(2, int(np.ceil(duration / dt - 1e-9)))
    launch_kick(character, foot, end, steps * dt)
    return (steps - 0.5) * dt


#: Keeps a vector's ground-plane part (x, z).
_GROUND_PART = np.array([1.0, 0.0, 1.0])


def _flat_unit(v: np.ndarray) -> np.ndarray:
    """``v``'s ground-plane direction (x, 0, z), a unit vector; +z for a vertical ``v``."""
    v = v * _GROUND_PART
    n = float(np.linalg.norm(v))
    return v / n if n > 1e-9 else np.array([0.0, 0.0, 1.0])
