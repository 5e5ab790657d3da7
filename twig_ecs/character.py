"""Characters: bodies that stand, walk, look, reach, grab, gesture, sit and breathe.

:func:`make_character` turns a spawned humanoid-like body into a character (a row of
the store's character table plus a :class:`~twig_ecs.components.Character`
component). :class:`CharacterHandle` is the Python API a drama manager or a behaviour
uses; every call only sets controller targets, which the controller systems (gait,
gaze, posture, arms, respiration) act on in the next steps.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from twig_ecs.components import Body, Character, GrabJoint
from twig_ecs.errors import SceneError, TwigError
from twig_ecs.handles import BodyHandle
from twig_ecs.kernelmath import (
    ARM_MODES,
    CARRY,
    GAZE_AHEAD,
    GAZE_NODE,
    GAZE_POINT,
    HANG,
    LIMP,
    POINT,
    REACH,
    RISE,
    SIT,
    STAND,
    WAVE,
)
from twig_ecs.mind import Goal, Mind, on_goal_schema
from twig_ecs.store import LINK_BRACE, LINK_OFF, NODE_LOCK_ON_CONTACT, NODE_LOCKED, ROLES
from twig_ecs.validate import LIMIT, suggest

if TYPE_CHECKING:
    from twig_ecs.goals import GoalSchema
    from twig_ecs.step import SceneView

HANDS = {"left": (0,), "right": (1,), "both": (0, 1)}
_ROLE_INDEX = {role: k for k, role in enumerate(ROLES)}
POSTURES = {STAND: "stand", SIT: "sit", RISE: "rise", LIMP: "limp"}
GESTURES = ("wave", "point")
#: The arm poses of :meth:`CharacterHandle.pose`.
ARM_POSES = ("hang", "grapple", "hug", "carry")
#: sin of the most a stoop bends the torso (25 degrees, posture's MAX_PITCH): knees bend instead.
STOOP_LEAN = math.sin(math.radians(25.0))
#: Height (m) of the reference humanoid; characters scale their gait by height / this.
REFERENCE_HEIGHT = 1.75
#: Standing pelvis height as a fraction of the template's: knees slightly bent.
STANCE = 1.0
#: Farthest a hand may be from what it grabs (m, at reference height).
GRAB_REACH = 0.3


@dataclass
class CharacterSpec:
    """How a scene makes a body a character, and what it starts doing."""

    max_speed: float = 6.0
    start: dict[str, Any] = field(default_factory=dict)  # initial commands: walk, look_at...
    where: dict[str, Any] = field(default_factory=dict)  # YAML mapping of each command, for errors


def make_character(scene: SceneView, entity: int, facing: float, spec: CharacterSpec) -> int:
    """Give the body ``entity`` a character row and component; returns the row."""
    body = scene.world.component_for_entity(entity, Body)
    missing = [r for r in ROLES if r not in body.node_names]
    if missing:
        raise SceneError(f"a character needs a body with the humanoid's nodes; '{body.template}' lacks "
                         + ", ".join(missing))  # fmt: skip
    state = scene.state
    ch, links = state.characters, state.links
    row = ch.allocate(1).start
    ch.body[row] = body.index
    ch.entity[row] = entity
    ch.nodes[row] = [body.node_index(r) for r in ROLES]
    ch.scale[row] = body.height / REFERENCE_HEIGHT
    pelvis = state.nodes.pos[ch.nodes[row, 0]]
    lowest = state.nodes.pos[body.rows, 1].min()
    lowest -= state.nodes.radius[ch.nodes[row, ROLES.index("l_foot")]]
    ch.stand_height[row] = (pelvis[1] - lowest) * STANCE
    pos = state.nodes.pos
    hip, knee, foot = (body.node_index(n) for n in ("l_hip", "l_knee", "l_foot"))
    ch.leg_length[row] = np.linalg.norm(pos[hip] - pos[knee]) + np.linalg.norm(pos[knee] - pos[foot])
    ch.mode[row] = STAND
    a = math.radians(facing)
    ch.head_dir[row] = (math.sin(a), 0.0, math.cos(a))
    ch.face_dir[row] = ch.head_dir[row]
    rows = range(body.link_start, body.link_start + body.link_count)
    spine = body.node_index("spine")
    for k, shoulder in enumerate(("l_shoulder", "r_shoulder")):
        s = body.node_index(shoulder)
        for j in rows:
            if {int(links.a[j]), int(links.b[j])} == {s, spine}:
                ch.breath_links[row, k] = j
                ch.breath_rest[row, k] = links.rest[j]
    _set_braces(scene, body, on=False)
    scene.world.add_component(entity, Character(row, max_speed=spec.max_speed))
    scene.world.add_component(entity, Mind())
    return row


def _set_braces(scene: SceneView, body: Body, on: bool) -> None:
    """Switch a body's brace links on (passive) or off (under control)."""
    flags = scene.state.links.flags[body.link_start : body.link_start + body.link_count]
    braces = (flags & LINK_BRACE) != 0
    if on:
        flags[braces] &= np.uint32(~LINK_OFF & 0xFFFFFFFF)
    else:
        flags[braces] |= LINK_OFF


def _vector(value: Any, what: str, size: int = 3) -> np.ndarray:
    """A finite 2- or 3-vector from user input, or a TwigError naming ``what``."""
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (size,):
        v = value  # what a behaviour computed: used as it is (as np.asarray would), no copy
    else:
        try:
            v = np.asarray(value, dtype=np.float64).reshape(-1)
        except (TypeError, ValueError):
            raise TwigError(f"{what} must be a list of numbers, got {value!r}") from None
        if v.size == 2 and size == 3:
            v = np.array([v[0], 0.0, v[1]])  # [x, z] on the ground
    # plain floats: numpy's reductions cost more than the check on three numbers
    if v.size != size or not all(math.isfinite(x) and abs(x) <= LIMIT for x in v.tolist()):
        raise TwigError(f"{what} must be {size} finite numbers (at most {LIMIT:g} in size), got {value!r}")
    return v


class CharacterHandle(BodyHandle):
    """A character: the body read-outs plus the control API of SPEC 3.

    Targets are points ``(x, y, z)`` in metres or entity names (then a node of that
    entity is tracked: its ``centre``, ``spine`` or the node nearest its middle).
    """

    # -- internals ---------------------------------------------------------------------

    @property
    def character(self) -> Character:
        """The Character component."""
        self.scene.check_open()
        # looked up once per handle: a behaviour's act reads it ten times (rows, holding,
        # max speed); the check that the entity still lives keeps a removed one an error
        found = self.__dict__.get("_character")
        if found is None or not self.world.entity_exists(self.entity):
            found = self.__dict__["_character"] = self.world.component_for_entity(self.entity, Character)
        return found

    @property
    def character_row(self) -> int:
        """Row in the character table."""
        return self.character.index

    def _chars(self):
        return self.scene.state.characters

    def _role(self, role: str) -> int:
        return int(self._chars().nodes[self.character_row, _ROLE_INDEX[role]])

    def _hands(self, hand: str) -> tuple[int, ...]:
        try:
            return HANDS[hand]
        except KeyError:
            raise TwigError(f"hand must be 'left', 'right' or 'both', got {hand!r}") from None

    def _target_node(self, target: str, node: str | None = None) -> int:
        """Row of the node tracked for an entity target."""
        if target == self.name:
            raise TwigError(f"'{self.name}' cannot target itself")
        try:
            other = self.scene.entity(target)
        except KeyError as exc:
            raise TwigError(str(exc.args[0])) from None
        names = other.node_names
        if node is not None:
            if node not in names:
                raise TwigError(f"'{target}' has no node '{node}'" + suggest(node, names))
            return other.body.node_index(node)
        for preferred in ("centre", "spine"):
            if preferred in names:
                return other.body.node_index(preferred)
        pos = other.node_positions
        return other.body.node_start + int(np.argmin(np.linalg.norm(pos - pos.mean(axis=0), axis=1)))

    # -- read-outs -----------------------------------------------------------------------

    @property
    def position(self) -> np.ndarray:
        """Pelvis centre (m)."""
        return self.scene.state.nodes.pos[self._role("pelvis")].copy()

    @property
    def facing(self) -> np.ndarray:
        """Unit ground-plane vector the pelvis faces: (left hip - right hip) x up."""
        pos = self.scene.state.nodes.pos
        left = pos[self._role("l_hip")] - pos[self._role("r_hip")]
        f = np.array([-left[2], 0.0, left[0]])
        return f / (np.linalg.norm(f) or 1.0)

    @property
    def torso_pitch(self) -> float:
        """The torso's lean from upright (degrees): the pelvis-to-neck line's angle from the vertical."""
        pos = self.scene.state.nodes.pos
        up = pos[self._role("neck")] - pos[self._role("pelvis")]
        return math.degrees(math.atan2(math.hypot(float(up[0]), float(up[2])), float(up[1])))

    @property
    def shoulder_facing(self) -> np.ndarray:
        """Unit ground-plane vector the shoulders face."""
        pos = self.scene.state.nodes.pos
        left = pos[self._role("l_shoulder")] - pos[self._role("r_shoulder")]
        f = np.array([-left[2], 0.0, left[0]])
        return f / (np.linalg.norm(f) or 1.0)

    @property
    def head_direction(self) -> np.ndarray:
        """Unit vector the face points along."""
        return self._chars().head_dir[self.character_row].copy()

    @property
    def face_direction(self) -> np.ndarray:
        """Unit vector the drawn face points along: :attr:`head_direction`, or an idle glance away
        from it (``systems/control/glance.py``)."""
        return self._chars().face_dir[self.character_row].copy()

    @property
    def gaze_target(self) -> np.ndarray | None:
        """The point being looked at (None when looking where it goes)."""
        ch, row = self._chars(), self.character_row
        if ch.gaze_mode[row] == GAZE_POINT:
            return ch.gaze_point[row].copy()
        if ch.gaze_mode[row] == GAZE_NODE and ch.gaze_node[row] >= 0:
            return self.scene.state.nodes.pos[ch.gaze_node[row]].copy()
        return None

    @property
    def holding(self) -> dict[str, str]:
        """What each hand holds: {"right": "ball"}."""
        out = {}
        for hand, grab in self.character.holding.items():
            joint = self.world.try_component(grab, GrabJoint)
            if joint is not None:
                out[hand] = self.scene.name_of(joint.held) or str(joint.held)
        return out

    @property
    def posture(self) -> str:
        """ "stand", "sit", "rise" (getting up) or "limp"."""
        return POSTURES[int(self._chars().mode[self.character_row])]

    @property
    def walk_velocity(self) -> np.ndarray:
        """The walk vector it is following (m/s)."""
        return self._chars().walk[self.character_row].copy()

    @property
    def scale(self) -> float:
        """Body height / 1.75 m: lengths in the controllers and behaviours scale by it."""
        return float(self._chars().scale[self.character_row])

    @property
    def stand_height(self) -> float:
        """Pelvis height (m) the character stands at."""
        return float(self._chars().stand_height[self.character_row])

    @property
    def last_foot(self) -> str:
        """The foot that stepped last: "left" or "right"."""
        return ("left", "right")[int(self._chars().last_step[self.character_row])]

    @property
    def steps(self) -> int:
        """Steps taken so far."""
        return int(self._chars().steps[self.character_row])

    @property
    def arm_modes(self) -> dict[str, str]:
        """What each arm is doing: hang, reach, grapple, hug, wave, point or carry."""
        names = {v: k for k, v in ARM_MODES.items()}
        modes = self._chars().arm_mode[self.character_row]
        return {"left": names[int(modes[0])], "right": names[int(modes[1])]}

    # -- locomotion ----------------------------------------------------------------------

    def walk(self, velocity: Sequence[float]) -> None:
        """Walk with this ground velocity, (x, z) or (x, y, z) in m/s (y is ignored).

        A sitting character stands up first.
        """
        v = _vector(velocity, "walk velocity")
        v[1] = 0.0
        speed = math.hypot(v[0], v[2])
        character = self.character
        limit = character.max_speed
        if speed > limit:
            raise TwigError(f"walk speed {speed:.2f} m/s is more than '{self.name}' can do ({limit} m/s)")
        ch, row = self._chars(), character.index
        ch.walk[row] = v
        if ch.mode[row] == SIT:
            self.stand()

    def stop(self) -> None:
        """Stand still (the feet settle under the hips)."""
        self._chars().walk[self.character_row] = 0.0

    def sit(self, on: str | None = None) -> None:
        """Sit down: on the ground here, or on the seat entity ``on`` (stand next to it first)."""
        ch, row, n = self._chars(), self.character_row, self.scene.state.nodes
        pelvis = n.pos[self._role("pelvis")]
        if on is None:
            seat = np.array([pelvis[0], n.radius[self._role("pelvis")], pelvis[2]])
        else:
            seat_body = self.scene.entity(on) if on != self.name else None
            if seat_body is None:
                raise TwigError(f"'{self.name}' cannot sit on itself")
            pos = seat_body.node_positions
            rows = seat_body.body.rows
            tops = pos[:, 1] + n.radius[rows]
            top = float(tops.max())
            # over the seat's top surface (its highest nodes), towards its middle
            surface = pos[tops > top - 0.05][:, [0, 2]]
            lo, hi = surface.min(axis=0), surface.max(axis=0)
            mid, half = (lo + hi) / 2, (hi - lo) / 2 * 0.8
            x, z = np.clip(pelvis[[0, 2]], mid - half, mid + half)
            seat = np.array([x, top + n.radius[self._role("l_hip")], z])
        ch.seat[row] = seat
        ch.walk[row] = 0.0
        ch.mode[row] = SIT
        ch.mode_time[row] = 0.0

    def stand(self) -> None:
        """Stand up (from sitting: lean over the feet, then rise; from limp: from where the body
        lies - through a kneel if it is on the ground)."""
        ch, row = self._chars(), self.character_row
        if ch.mode[row] == SIT:
            ch.seat[row] = self.scene.state.nodes.pos[self._role("pelvis")]
            ch.mode[row] = RISE
        elif ch.mode[row] == LIMP:
            _set_braces(self.scene, self.body, on=False)
            ch.seat[row] = self.scene.state.nodes.pos[self._role("pelvis")]
            ch.mode[row] = RISE
        ch.mode_time[row] = 0.0

    def go_limp(self) -> None:
        """Stop all control: the body falls as a ragdoll until :meth:`stand`."""
        ch, row, n = self._chars(), self.character_row, self.scene.state.nodes
        ch.mode[row] = LIMP
        ch.walk[row] = 0.0
        ch.arm_mode[row] = HANG
        for foot in ("l_foot", "r_foot"):
            n.flags[self._role(foot)] &= np.uint32(~(NODE_LOCKED | NODE_LOCK_ON_CONTACT) & 0xFFFFFFFF)
        _set_braces(self.scene, self.body, on=True)

    # -- gaze ----------------------------------------------------------------------------

    def look_at(self, target: str | Sequence[float] | None, node: str | None = None) -> None:
        """Face a point or an entity (tracked as it moves); None: look where it goes."""
        ch, row = self._chars(), self.character_row
        if target is None:
            ch.gaze_mode[row] = GAZE_AHEAD
        elif isinstance(target, str):
            ch.gaze_node[row] = self._target_node(target, node)
            ch.gaze_mode[row] = GAZE_NODE
        else:
            ch.gaze_point[row] = _vector(target, "look-at point")
            ch.gaze_mode[row] = GAZE_POINT

    # -- arms ----------------------------------------------------------------------------

    def _aim(self, hands: tuple[int, ...], mode: int, target: Any, node: str | None) -> None:
        ch, row = self._chars(), self.character_row
        for h in hands:
            if isinstance(target, str):
                ch.arm_node[row, h] = self._target_node(target, node)
            else:
                ch.arm_node[row, h] = -1
                ch.arm_point[row, h] = _vector(target, "target point")
            ch.arm_mode[row, h] = mode

    def stoop(self, towards: str | Sequence[float] | None) -> None:
        """Crouch and lean so the hands can get down to a low point (or entity); None: stand tall.

        The shoulders lean towards it (the torso up to 25 degrees from upright) and the
        pelvis sinks (up to 55% of standing height: a squat) until they are within an
        arm's length.
        """
        ch, row = self._chars(), self.character_row
        if towards is None:
            ch.crouch[row] = 0.0
            ch.lean[row] = 0.0
            return
        point = self.scene.entity(towards).position if isinstance(towards, str) else _vector(towards, "point")
        scale = ch.scale[row]
        pos = self.scene.state.nodes.pos
        arm = 0.56 * scale
        torso = float(np.linalg.norm(pos[self._role("neck")] - pos[self._role("pelvis")]))
        shoulders = ch.stand_height[row] + torso  # standing shoulder height
        drop = shoulders - point[1] - 0.85 * arm  # how much lower the shoulders must get
        if drop <= 0.0:
            self.stoop(None)
            return
        ahead = (point - pos[self._role("pelvis")]) * np.array([1.0, 0.0, 1.0])
        ahead /= max(float(np.linalg.norm(ahead)), 1e-9)
        # the torso bends at most as far as posture leans it (25 degrees); the knees do the rest
        lean = min(0.45 * scale, 0.8 * drop, STOOP_LEAN * torso)
        lowered = torso - math.sqrt(max(torso**2 - lean**2, 0.0))
        ch.lean[row] = ahead * lean
        ch.crouch[row] = min(0.55 * ch.stand_height[row], max(0.0, drop - lowered))

    def lean(self, offset: Sequence[float] | None) -> None:
        """Hold the shoulders ``offset`` (m, on the ground plane) ahead of the pelvis; None: upright."""
        self._chars().lean[self.character_row] = (
            0.0 if offset is None else _vector(offset, "lean") * [1.0, 0.0, 1.0]
        )

    @property
    def seat(self) -> np.ndarray:
        """Where the pelvis goes when sitting (set by :meth:`sit`)."""
        return self._chars().seat[self.character_row].copy()

    def reach(self, target: str | Sequence[float], hand: str = "right", node: str | None = None) -> None:
        """Reach a hand (or ``"both"``) towards a point or an entity."""
        self._aim(self._hands(hand), REACH, target, node)

    def pose(self, name: str, hand: str = "both") -> None:
        """Hold the arms in a pose: ``hang`` (relaxed), ``grapple``, ``hug`` or ``carry``."""
        if name not in ARM_POSES:
            raise TwigError(f"unknown arm pose '{name}'" + suggest(name, ARM_POSES))
        ch, row = self._chars(), self.character_row
        for h in self._hands(hand):
            ch.arm_mode[row, h] = ARM_MODES[name]

    def gesture(
        self, name: str | None, target: str | Sequence[float] | None = None, hand: str = "right"
    ) -> None:
        """Make a gesture with one hand: ``wave``, ``point`` (at ``target``), or None to stop."""
        hands = self._hands(hand)
        if name is None:
            self.pose("hang", hand)
        elif name == "wave":
            for h in hands:
                self._chars().arm_mode[self.character_row, h] = WAVE
        elif name == "point":
            if target is None:
                raise TwigError("gesture 'point' needs a target (an entity name or a point)")
            self._aim(hands, POINT, target, None)
        else:
            raise TwigError(f"unknown gesture '{name}'" + suggest(str(name), GESTURES))

    def grab(self, target: str, hand: str = "right", node: str | None = None, standoff: float = 0.0) -> None:
        """Hold ``target`` in a hand with a ball joint (the hand must be near it: reach first).

        The nearest node of the target is taken unless ``node`` names one; ``standoff``
        (m) keeps the hand that far from the node (on the surface of a torso, say). A
        hand that was reaching for it then holds it up in front of the body (carry); a
        hanging arm just keeps hanging, holding it.
        """
        (h,) = self._hands(hand) if hand != "both" else (None,)
        if h is None:
            raise TwigError("grab takes one hand: 'left' or 'right'")
        hand_name = ("left", "right")[h]
        if hand_name in self.character.holding:
            raise TwigError(
                f"'{self.name}' already holds something in the {hand_name} hand; release it first"
            )
        hand_row = self._role(("l_hand", "r_hand")[h])
        other = self.scene.entity(target) if target != self.name else None
        if other is None:
            raise TwigError(f"'{self.name}' cannot grab itself")
        hand_pos = self.scene.state.nodes.pos[hand_row]
        if node is None:
            pos = other.node_positions
            k = int(np.argmin(np.linalg.norm(pos - hand_pos, axis=1)))
            node = other.node_names[k]
        distance = float(np.linalg.norm(other.node(node) - hand_pos))
        reach = GRAB_REACH * self.scale
        if distance > reach:
            raise TwigError(f"'{target}' is {distance:.2f} m from the {hand_name} hand of '{self.name}' "
                            f"(grabbing needs {reach:.2f} m or less): reach for it first")  # fmt: skip
        grab = self.scene.grab(self.name, ("l_hand", "r_hand")[h], target, node, standoff)
        self.character.holding[hand_name] = grab
        ch = self._chars()
        if ch.arm_mode[self.character_row, h] == REACH:  # fetched it: hold it up in front
            ch.arm_mode[self.character_row, h] = CARRY

    def release(self, hand: str | None = None) -> None:
        """Let go with one hand, or both (None); the arm relaxes."""
        hands = (0, 1) if hand is None else self._hands(hand)
        for h in hands:
            hand_name = ("left", "right")[h]
            grab = self.character.holding.pop(hand_name, None)
            if grab is not None:
                self.scene.release(grab)
            self._chars().arm_mode[self.character_row, h] = HANG

    def _hold_nearest(self, target: str) -> None:
        """Grab ``target`` with whichever hand is nearer to it."""
        other = self.scene.entity(target) if target != self.name else None
        if other is None:
            raise TwigError(f"'{self.name}' cannot hold itself")
        pos = other.node_positions
        gaps = [float(np.linalg.norm(pos - self.node(h), axis=1).min()) for h in ("l_hand", "r_hand")]
        self.grab(target, hand="left" if gaps[0] < gaps[1] else "right")

    def patrol(self, route: Sequence[Sequence[float]], speed: float = 1.0) -> None:
        """Walk round a loop of ground waypoints [(x, z), ...] at ``speed`` m/s; [] to stop."""
        points = [tuple(float(v) for v in _vector(p, "waypoint", 2)) for p in route]
        if speed <= 0 or speed > self.character.max_speed:
            raise TwigError(f"patrol speed must be above 0 and at most {self.character.max_speed} m/s")
        character = self.character
        character.route, character.route_speed, character.waypoint = points, float(speed), 0
        if not points:
            self.stop()

    # -- behaviour goals (SPEC 4) ------------------------------------------------------------

    @property
    def mind(self):
        """The behaviour state: goals, current winner, switch count."""
        self.scene.check_open()
        return self.world.component_for_entity(self.entity, Mind)

    @property
    def behaviour(self) -> str:
        """The behaviour winning right now ("idle" when nothing in particular)."""
        return self.mind.winner

    @property
    def goals(self) -> list:
        """Queued goals, the current one first."""
        return list(self.mind.goals)

    def do(self, behavior: str, /, on_end=None, **params):
        """Queue a goal for behaviour ``behavior`` (approach, hug, grapple, carry, drag, sit,
        stand, freeze, gesture, or a plug-in's) and return it; it reports ``goal.done`` or
        ``goal.failed`` events and calls ``on_end(goal)`` when it ends.

        The parameters are checked against the behaviour's schema (its
        :class:`~twig_ecs.goals.GoalSchema`) and then against the world: a name must be of
        an entity here (not this character), a ``figure`` one of a body with a head."""
        if on_end is not None and not callable(on_end):
            raise TwigError(f"{behavior}: on_end must be a function of the goal, got {on_end!r}")

        system = self.scene.behaviors.get(behavior)
        if system is None or not system.goal_driven:
            known = sorted(k for k, v in self.scene.behaviors.items() if v.goal_driven)
            raise TwigError(f"no goal behaviour '{behavior}'" + suggest(behavior, known))
        if system.schema is None:
            raise TwigError(f"goal behaviour '{behavior}' ({type(system).__name__}) declares no schema: "
                            "give its class one (docs/authoring-behaviours.md, section 3)")  # fmt: skip
        merged = system.schema.bind(params)
        for p in system.schema.params:
            value = merged[p.name]
            if isinstance(value, str) and p.kind in ("name", "target"):
                if value == self.name:
                    raise TwigError(f"{behavior}: '{self.name}' cannot {behavior} itself")
                other = self.scene.entity(value)  # KeyError with suggestions if unknown
                if p.figure and "head" not in other.node_names:
                    raise TwigError(f"{behavior}: '{p.name}' must be {p.describe()}; '{value}' has none")
            elif p.unit == "m/s" and value is not None and value > self.character.max_speed:
                raise TwigError(f"{behavior}: '{p.name}' {value:g} m/s is more than '{self.name}' can do "
                                f"({self.character.max_speed:g} m/s)")  # fmt: skip
        goal = Goal(behavior, merged, id=self.scene.new_goal_id(), on_end=on_end)
        self.mind.goals.append(goal)
        self.scene.note_goal(self.entity, self.mind)  # goal-driven behaviours look only at these
        return goal

    # The goal methods (approach, hug, grapple, carry, drag, freeze, and any plug-in goal
    # whose name is free) are not written here: each goal behaviour's schema makes one
    # when its class is defined (add_goal_method, below).

    @property
    def autonomous(self) -> bool:
        """Does it act on its own (behaviours it has, patrols), or only on goals and reflexes?"""
        return self.mind.autonomous

    @autonomous.setter
    def autonomous(self, value: bool) -> None:
        self.mind.autonomous = bool(value)
        if not value:
            self.stop()

    def cancel_goals(self) -> None:
        """Fail every queued goal (reason "cancelled")."""
        for goal in list(self.mind.goals):
            self.scene.end_goal(self, goal, False, "cancelled")

    # -- starting commands from YAML ---------------------------------------------------------

    def apply(self, commands: dict[str, Any]) -> None:
        """Run the ``character:`` commands of a scene file (:data:`START_COMMANDS`: walk, look_at...)."""
        for key, value in commands.items():
            command = START_COMMANDS.get(key)
            if command is None:  # pragma: no cover - the loader only passes known keys
                raise TwigError(f"unknown character command '{key}'" + suggest(key, START_COMMANDS))
            command.run(self, value)


@dataclass(frozen=True)
class StartCommand:
    """A command a scene file's ``character:`` mapping starts a character with.

    ``takes`` names the YAML value it reads (the scene reader's ``velocity``, ``target``,
    ``entity``, ``gesture``, ``pose``, ``seat`` or ``patrol``); ``names_entity``: a text
    value names another entity, checked once the whole file is read.
    """

    takes: str
    run: Callable[[CharacterHandle, Any], None]
    names_entity: bool = False


#: The ``character:`` keys that start a character doing something, in the order they run.
START_COMMANDS: dict[str, StartCommand] = {
    "walk": StartCommand("velocity", lambda c, v: c.walk(v)),
    "look_at": StartCommand("target", lambda c, v: c.look_at(v), names_entity=True),
    "reach": StartCommand("target", lambda c, v: c.reach(v), names_entity=True),
    "point_at": StartCommand("target", lambda c, v: c.gesture("point", v), names_entity=True),
    "hold": StartCommand("entity", lambda c, v: c._hold_nearest(v), names_entity=True),  # noqa: SLF001
    "gesture": StartCommand("gesture", lambda c, v: c.gesture(v)),
    "pose": StartCommand("pose", lambda c, v: c.pose(v)),
    "sit": StartCommand("seat", lambda c, v: c.sit(None if v is True else v), names_entity=True),
    "patrol": StartCommand("patrol", lambda c, v: c.patrol(v["route"], v.get("speed", 1.0))),
}
#: Every key of a scene file's ``character:`` mapping: the setting, then the start commands.
CHARACTER_KEYS = ("max_speed", *START_COMMANDS)


def add_goal_method(schema: GoalSchema) -> None:
    """Give :class:`CharacterHandle` the method of a goal: ``handle.<goal>(...)`` queues it.

    Made from the schema (signature, docstring, checks), when a goal behaviour's class is
    defined. A name the handle already uses for something else - an immediate control such
    as ``sit`` or ``walk`` - is left alone: that goal is reached with ``handle.do(name, ...)``.
    """
    current = CharacterHandle.__dict__.get(schema.name)
    if not schema.handle_method or (current is not None and not hasattr(current, "goal_schema")):
        return
    setattr(CharacterHandle, schema.name, schema.handle_function())


on_goal_schema(add_goal_method)  # every goal behaviour, defined now or later, gets its method
