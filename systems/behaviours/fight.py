"""fight: now and then a child picks a fight with its rival (SPEC 5).

For each character with a :class:`Feisty`: when the rival is
within ``reach``, a fight starts at random (``temper`` per second, from the scene's
seeded RNG) as a grapple goal; at most one fight every ``COOLDOWN`` seconds, and none
while the rival is on its way to a hug or in one. The one attacked squares up to the
fighter (:class:`Defend`): its activation and act for every defender of a step at once,
over arrays (:func:`defend_activations`, :func:`act_defences`), with the per-character forms'
arithmetic (tests/test_brawl_batch.py compares the two).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from twig_ecs.behavior import Behavior, Mind, goal_targets, register
from twig_ecs.components import Character
from twig_ecs.kernelmath import GAZE_NODE, GRAPPLE, HEAD, L_HIP, PELVIS, R_HIP, SIT
from twig_ecs.steering import ground_distance
from twig_ecs.step import StepContext
from twig_ecs.systems.behaviours.arrays import GROUND, ground_gaps, lengths, walkable


@dataclass(slots=True)
class Feisty:
    """Picks a fight with a rival now and then, when it is near."""

    rival: str = ""
    temper: float = 0.06  # chance per second of starting a fight when within reach
    reach: float = 2.5  # m
    fights: int = 0


@dataclass(slots=True)
class LastFight:
    """When a feisty character last started a fight (systems/behaviours/fight.py: one per cooldown)."""

    at: float  # s (scene time)


COOLDOWN = 25.0  # s between fights
FIGHT_TIME = 3.0  # s of grappling
DEFEND = 0.9  # activation of squaring up to a fighter: above play, rides and goals, below pain
SQUARE_UP = 2.0  # m (ground): a fighter this near is faced
TURN_PACE = 0.25  # m/s (at 1.75 m tall) of the steps round to face it
FACED = 0.8  # cosine: facing it this squarely is facing it
#: Defenders from which a step's defence goes over arrays (:func:`act_defences`): for one, the
#: per-character form costs 25-43 us against the arrays' 50-88 us, and both write the same.
ARRAYS_FROM = 2


@register
class Fight(Behavior):
    """Starts grapples with a rival, at random, now and then."""

    name = "fight"
    component = Feisty

    def run(self, ctx: StepContext) -> None:
        """Maybe start fights (as grapple goals); this behaviour never acts itself."""
        dt = ctx.dt
        scene = self.scene
        for entity, (_, feisty) in ctx.world.get_components(Character, Feisty):
            last = ctx.world.try_component(entity, LastFight)
            cooling = last is not None and scene.time - last.at < COOLDOWN
            if not scene.has_entity(feisty.rival) or cooling:
                continue
            me = scene.character_handle(entity)
            if me.goals or not me.autonomous:
                continue
            rival = scene.entity(feisty.rival)
            if ground_distance(me.position, rival.position) > feisty.reach:
                continue
            if any(g.behavior == "hug" for g in getattr(rival, "goals", ())):
                continue  # not while it runs to (or hugs) its grown-up
            if scene.rng.random() < feisty.temper * dt:
                ctx.world.add_component(entity, LastFight(scene.time))
                feisty.fights += 1
                me.grapple(feisty.rival, duration=FIGHT_TIME)


def attackers_of(scene) -> dict[int, int]:
    """Who is fighting whom right now: {target entity: fighter entity} (grapple goals)."""
    return {target: fighter for target, (fighter, _) in goal_targets(scene, "grapple").items()}


@register
class Defend(Behavior):
    """Square up to someone who comes to fight: face it, arms up (not commanded).

    Every autonomous character someone is coming at with a grapple goal, within
    ``SQUARE_UP`` metres, stops what it was doing (its activation beats play, rides and
    goals, not pain: a blow that hurts makes it stagger back and turn away, see
    withdraw), turns to the fighter and holds its arms up in guard.
    """

    name = "defend"
    batch = True

    def setup(self) -> None:
        """Who is attacked by whom this step (looked up once per step)."""
        self.attacked_by: dict[int, int] = {}
        self.fighter_rows: dict[int, int] = {}  # the same, the fighter by its character row

    def candidates(self) -> list[tuple[int, Mind]]:
        """Only the characters someone is fighting (who fights whom looked up again when the
        grapple goals or the store's rows change, not every step)."""
        scene = self.scene
        state = scene.state

        def fights() -> tuple[int, ...]:  # the grapple goals' ids (made again when a goal is given or ends)
            return tuple(mind.goals[0].id for _, mind in scene.goal_holders_of("grapple"))

        key = (self.scratch.keyed("fights", scene.goals.changes, fights), state.version, id(state))
        self.attacked_by, self.fighter_rows, attacked = self.scratch.keyed("attacked", key, self._attacked)
        return [(e, self.world.component_for_entity(e, Mind)) for e in attacked]

    def _attacked(self) -> tuple[dict[int, int], dict[int, int], list[int]]:
        """Who is attacked by whom (by entity, and by the fighter's character row), and the
        attacked characters that have minds."""
        world = self.world
        attacked_by = attackers_of(self.scene)
        rows = {e: world.component_for_entity(f, Character).index for e, f in attacked_by.items()}
        return attacked_by, rows, [e for e in attacked_by if world.entity_exists(e)
                                   and world.has_component(e, Mind)]  # fmt: skip

    def propose_crowd(self, crowd) -> np.ndarray:
        """:meth:`activation` of every one at once (:func:`defend_activations`)."""
        return defend_activations(self, self.fighter_rows, crowd.entities, crowd.rows)

    def act_batch(self, rows: list[int], entities: list[int], dt: float, goals: list | None = None) -> None:
        """:meth:`act` for every defender at once, over arrays (:func:`act_defences`);
        a character at a time where one would be refused, or for a lone defender."""
        few = len(entities) < ARRAYS_FROM
        if few or not act_defences(self, self.attacked_by, self.fighter_rows, rows, entities):
            for entity in entities:
                mind = self.world.component_for_entity(entity, Mind)
                self.act(self.scene.character_handle(entity), mind, None, dt)

    def activation(self, character, mind: Mind, goal) -> float:
        """High while the fighter is near (one character: the per-character form of
        :meth:`propose_crowd`)."""
        fighter = self.attacked_by.get(character.entity)
        if fighter is None:
            return 0.0
        other = self.scene.character_handle(fighter)
        return DEFEND if ground_distance(character.position, other.position) < SQUARE_UP else 0.0

    def act(self, character, mind: Mind, goal, dt: float) -> None:
        """Face the fighter, guard up; a step round to face it when turned away."""
        other = self.scene.character_handle(self.attacked_by[character.entity])
        character.look_at(other.name, node="head")
        character.pose("grapple")
        to = (other.position - character.position) * np.array([1.0, 0.0, 1.0])
        to /= max(float(np.linalg.norm(to)), 1e-9)
        if float(character.facing @ to) < FACED:
            character.walk(tuple(to * TURN_PACE * character.scale))  # slow steps round to face it
        else:
            character.stop()

    def stop(self, character, goal) -> None:
        """Guard down."""
        character.pose("hang")
        character.stop()
        character.look_at(None)


# -- the batch form: every defender of a step at once (issue 36) --------------------------------


def defend_activations(defend: Behavior, fighter_rows: dict[int, int], entities: list[int],
                       rows: np.ndarray) -> np.ndarray:  # fmt: skip
    """``Defend.activation`` of every character ``entities`` (character rows ``rows``) at once:
    ``DEFEND`` where the one fighting it (its character row ``fighter_rows[entity]``) is within
    ``SQUARE_UP`` on the ground, else 0."""
    ch = defend.scene.state.characters
    pos = defend.scene.state.nodes.pos
    out = np.zeros(len(entities))
    pairs = [(k, fighter_rows.get(e)) for k, e in enumerate(entities)]
    pairs = [(k, f) for k, f in pairs if f is not None]
    if not pairs:
        return out
    picked = np.array([k for k, _ in pairs], dtype=np.int64)
    theirs = [f for _, f in pairs]
    gap = ground_gaps(pos[ch.nodes[rows[picked], PELVIS]], pos[ch.nodes[theirs, PELVIS]])
    out[picked] = np.where(gap < SQUARE_UP, DEFEND, 0.0)
    return out


def act_defences(defend: Behavior, attacked_by: dict[int, int], fighter_rows: dict[int, int], rows: list[int],
                 entities: list[int]) -> bool:  # fmt: skip
    """``Defend.act`` for every defender at once: face the fighter (``attacked_by``, by entity;
    ``fighter_rows``, by character row), guard up, slow steps round to face it when turned away.
    False, nothing written, when one would be refused (the per-character form raises)."""
    scene = defend.scene
    world = defend.world
    ch = scene.state.characters
    pos = scene.state.nodes.pos
    fighters = [attacked_by[e] for e in entities]
    if any(f == e for f, e in zip(fighters, entities, strict=True)):
        return False
    crows = np.array(rows, dtype=np.int64)
    mine = ch.nodes[crows]
    theirs = ch.nodes[[fighter_rows[e] for e in entities]]
    to = (pos[theirs[:, PELVIS]] - pos[mine[:, PELVIS]]) * GROUND
    to /= np.maximum(lengths(to), 1e-9)[:, None]
    # CharacterHandle.facing: (left hip - right hip) x up, of length 1
    left = pos[mine[:, L_HIP]] - pos[mine[:, R_HIP]]
    facing = np.zeros((len(rows), 3))
    facing[:, 0], facing[:, 2] = -left[:, 2], left[:, 0]
    length = lengths(facing)
    facing /= np.where(length != 0.0, length, 1.0)[:, None]
    turning = np.vecdot(facing, to) < FACED
    walk = to * TURN_PACE * ch.scale[crows][:, None]
    turners = [entities[k] for k in np.flatnonzero(turning).tolist()]
    limit = np.array([world.component_for_entity(e, Character).max_speed for e in turners])
    if not walkable(walk[turning], limit):
        return False
    ch.gaze_node[crows] = theirs[:, HEAD]  # look_at(fighter, node="head")
    ch.gaze_mode[crows] = GAZE_NODE
    ch.arm_mode[crows] = GRAPPLE
    ch.walk[crows] = 0.0
    ch.walk[crows[turning]] = walk[turning]
    ch.walk[crows, 1] = 0.0
    for k in np.flatnonzero(turning & (ch.mode[crows] == SIT)).tolist():
        scene.character_handle(entities[k]).stand()
    return True
