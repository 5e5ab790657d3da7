"""select_behavior: each character's highest activation wins and acts (SPEC 4).

Reads the activations the behaviour systems proposed this step (on each character's
:class:`~twig_ecs.mind.Mind`, and the lists of :meth:`~twig_ecs.behavior.Behavior.propose_all`);
writes the winner and calls its ``act``, which sets the character's controller targets.
Switching is stable: the current winner gets a bonus (``STICKINESS``) and keeps the floor for
at least ``MIN_DWELL`` seconds unless a rival beats it by ``URGENT`` (a reflex such as pain
withdrawal), so two behaviours with near-equal activations cannot trade places every frame.

Selection over arrays: the proposals made as lists (a goal behaviour's fixed activation,
the embrace's, ``propose_crowd``'s, the wanderers') are columns of one table, a row per
character, and every character's winner and its hysteresis are found in one compiled pass
(``selection.choose_winners``). A character whose winner carries on over a batch behaviour
is only added to its batch; the others - a proposal in its mind's dict (a per-character
``activation``), a switch, a goal starting, a winner that acts per character - go through
the per-character loop, in entity order, as before.
"""

from __future__ import annotations

from operator import attrgetter, itemgetter
from typing import Any

import numpy as np

from twig_ecs.components import Character
from twig_ecs.mind import BehaviorChanged, Mind
from twig_ecs.step import StepContext
from twig_ecs.system import System

# (the rule's figures live with its compiled pass, and are here too, where they always were)
from twig_ecs.systems.control.selection import IDLE, MIN_DWELL, STICKINESS, URGENT, choose_winners

_ACTIVATIONS = attrgetter("activations")


class _Minds:
    """The characters in selection order (the (Character, Mind) query's), with each one's
    winner as a code and the time it won: what ``choose_winners`` reads, kept between steps
    (select_behavior is the only writer of a mind's winner)."""

    def __init__(self, items: list, state) -> None:
        self.items = items
        self.state_key = (id(state), state.version)
        self.entities = [entity for entity, _ in items]
        self.minds = [mind for _, (_, mind) in items]
        self.rows = np.array([character.index for _, (character, _) in items], dtype=np.int64)
        self.position = {entity: k for k, entity in enumerate(self.entities)}
        self.names: list[str] = []
        self.codes: dict[str, int] = {}
        self.winner = np.array([self.code(mind.winner) for mind in self.minds], dtype=np.int64)
        self.since = np.array([mind.since for mind in self.minds], dtype=np.float64)

    def code(self, name: str) -> int:
        """A behaviour name's code (new names get the next one)."""
        found = self.codes.get(name)
        if found is None:
            found = self.codes[name] = len(self.names)
            self.names.append(name)
        return found


class SelectBehaviorSystem(System):
    """Picks each character's winning behaviour and lets it act."""

    name = "select_behavior"

    def run(self, ctx: StepContext) -> None:
        """Select, switch (with hysteresis) and act, for every character."""
        items = ctx.world.get_components(Character, Mind)
        listed = self._listed(ctx.frame)
        batches: dict[str, list] = {}
        if not listed:
            switched = self._select_each(items, ctx.dt, batches)
            self._forget(switched)
        else:
            self._select_over_arrays(items, listed, ctx, batches)
        # batch behaviours act once for all the characters they won, after the others
        behaviors = self.scene.behaviors
        for name, (rows, entities, goals) in batches.items():
            behavior = behaviors[name]
            if behavior.goal_driven:  # each one's goal too (None where it has none)
                behavior.act_batch(rows, entities, dt=ctx.dt, goals=goals)
            else:
                behavior.act_batch(rows, entities, ctx.dt)

    def _listed(self, frame: int) -> list[tuple[Any, ...]]:
        """This step's proposals made as lists (:meth:`~twig_ecs.behavior.Behavior.propose_all`),
        taken from the behaviours, in the order they were made: (order, name, entities, minds, value)."""
        listed = []
        # (every behaviour, also one under another's name; only behaviours file "proposed" in
        # their scratch: control does not import the behaviour layer above it)
        for system in self.scene.schedule.systems():
            made = system.scratch.pop("proposed", None)
            if made is not None and made[0] == frame:
                listed.extend(made[1])
        listed.sort(key=lambda call: call[0])
        return listed

    def _forget(self, switched: list[tuple[int, Mind]]) -> None:
        """After a step selected by the loop alone: the table's winners of the ones that
        switched (the minds' `last` are their own now: none counts as carried on)."""
        self.scratch.pop("carried", None)
        table = self.scratch.get("minds")
        if table is not None and switched:
            for entity, mind in switched:
                k = table.position.get(entity)
                if k is not None:
                    table.winner[k], table.since[k] = table.code(mind.winner), mind.since

    def _table(self, items: list) -> _Minds:
        state = self.scene.state
        table = self.scratch.get("minds")
        if table is None or table.items is not items or table.state_key != (id(state), state.version):
            table = self.scratch["minds"] = _Minds(items, state)
        return table

    def _select_over_arrays(self, items: list, listed: list, ctx: StepContext, batches: dict) -> None:
        """:meth:`_select_each`, the winners found by ``choose_winners`` over the listed proposals;
        only the characters with something to do beyond joining their winner's batch go
        through the per-character loop."""
        table = self._table(items)
        minds = table.minds
        n = len(minds)
        names = [call[1] for call in listed]
        if len(set(names)) < len(names) or "idle" in names or len(table.names) + len(names) > 62:
            # a behaviour that proposed twice (its later value counts, in its first place), or
            # too many names for a set of bits: into the minds' dicts, for the loop
            for _, name, _, pending, value in listed:
                for mind, one in zip(pending, np.broadcast_to(value, len(pending)).tolist(), strict=True):
                    mind.activations[name] = one
            self._forget(self._select_each(items, ctx.dt, batches))
            return
        values = np.full((n, len(listed) + 1), -np.inf)
        values[:, -1] = IDLE
        codes = np.array([table.code(name) for name in names] + [table.code("idle")], dtype=np.int64)
        proposed = {}  # each listed proposal's value where it is the same for all, else None
        for col, (_, name, entities, pending, value) in enumerate(listed):
            at, value = self._positions(table, name, entities, pending, value)
            values[at, col] = value
            if isinstance(value, np.ndarray):
                value = float(value[0]) if len(value) and (value == value[0]).all() else None
            proposed[name] = value
        # who goes per character: a switch, a winner that acts alone, or a proposal in its dict
        behaviors = self.scene.behaviors
        batch = np.array([name not in behaviors or behaviors[name].batch for name in table.names])
        best, alone, keys = np.empty(n, np.int64), np.empty(n, np.bool_), np.empty(n, np.int64)
        choose_winners(values, codes, table.winner, table.since, ctx.time, batch, best, alone, keys)
        if any(map(_ACTIVATIONS, minds)):
            alone[[k for k, mind in enumerate(minds) if mind.activations]] = True
        present = values[:, :-1] != -np.inf
        # batch name -> the positions, rows, entities and goals of those only joining it
        joined: dict[str, tuple] = {}
        goals_changed = self.scene.goals.changes
        carry = ~alone
        for code in np.flatnonzero(np.bincount(best[carry], minlength=len(table.names))).tolist():
            name = table.names[code]
            at = np.flatnonzero(carry & (best == code))
            if name not in behaviors:  # no behaviour to act (idle): nothing to join
                continue
            members = self._members(table, name, at, goals_changed)
            if members is None:  # a goal starts among them: the loop marks it
                alone[at] = True
                continue
            joined[name] = members
        carry = ~alone
        self._give_last(table, carry, present, values, keys, names, codes[:-1], proposed)
        # the others through the loop, in entity order, their listed proposals in their dicts
        each = [items[k] for k in np.flatnonzero(alone).tolist()]
        for k in np.flatnonzero(alone & present.any(axis=1)).tolist():
            self._merge(minds[k], listed, present[k], values[k].tolist())
        for entity, mind in self._select_each(each, ctx.dt, batches, joined, table.position):
            k = table.position[entity]
            table.winner[k], table.since[k] = table.code(mind.winner), mind.since

    def _give_last(self, table: _Minds, carry: np.ndarray, present: np.ndarray, values: np.ndarray,
                   keys: np.ndarray, names: list[str], codes: np.ndarray,
                   proposed: dict) -> None:  # fmt: skip
        """The minds carrying on get this step's proposals as ``last``: one dict for all with
        the same set of proposals (``keys``: as bits of their ``codes``; ``proposed``: their
        values where the same for all), given
        only to those whose set differs from their last step's (an equal dict is there
        already); one each for those with a proposal whose value differs between them."""
        minds = table.minds
        fresh = carry.copy()
        before = self.scratch.get("carried")
        if before is not None and before[0] is table and before[1] == proposed:
            fresh &= ~before[2] | (keys != before[3])
        varying = [col for col, name in enumerate(names) if proposed[name] is None]
        if varying:
            each = fresh & present[:, varying].any(axis=1)
            fresh &= ~each
            for k in np.flatnonzero(each).tolist():
                last = {names[c]: float(values[k, c]) for c in np.flatnonzero(present[k]).tolist()}
                last["idle"] = IDLE
                minds[k].last = last
        for key in np.unique(keys[fresh]).tolist() if fresh.any() else ():
            bits = codes.tolist()
            last = {name: proposed[name] for name, bit in zip(names, bits, strict=True) if key >> bit & 1}
            last["idle"] = IDLE
            for k in np.flatnonzero(fresh & (keys == key)).tolist():
                minds[k].last = last
        # (a mind with a varying proposal gets a `last` each step: it counts as not carried on)
        carried = carry & ~present[:, varying].any(axis=1) if varying else carry
        self.scratch["carried"] = (table, proposed, carried, keys)

    def _positions(self, table: _Minds, name: str, entities: list, minds: list,
                   value: float | np.ndarray) -> tuple[np.ndarray, float | np.ndarray]:  # fmt: skip
        """The selection positions of the characters a listed proposal is for, and its values
        there; a mind that is no character's is never selected: its proposal goes into its
        dict (as it did)."""
        kept = self.scratch.get(("at", name))
        if kept is not None and kept[0] is table and kept[1] == entities:
            return kept[2], value
        try:
            at = np.fromiter(map(table.position.__getitem__, entities), np.int64, len(entities))
            self.scratch[("at", name)] = (table, list(entities), at)
            return at, value
        except KeyError:
            position = table.position
            inside = [e in position for e in entities]
            every = np.broadcast_to(value, len(entities)).tolist()
            for mind, one, ok in zip(minds, every, inside, strict=True):
                if not ok:
                    mind.activations[name] = one
            at = np.array([position[e] for e, ok in zip(entities, inside, strict=True) if ok], dtype=np.int64)
            return at, value if np.ndim(value) == 0 else np.asarray(value)[inside]

    def _members(self, table: _Minds, name: str, at: np.ndarray, goals_changed: int) -> tuple | None:
        """The positions, rows, entities and own goals of the characters at positions ``at``
        carrying on with batch behaviour ``name``; None when one's goal is pending (it starts
        now). Kept while the same characters carry on and no goal was given or ended."""
        kept = self.scratch.get(("members", name))
        if kept is not None and kept[0] is table and kept[1] == goals_changed and np.array_equal(kept[2], at):
            return kept[3]
        minds, entities, rows = table.minds, table.entities, table.rows
        goals = []
        for k in at.tolist():
            held = minds[k].goals
            goal = held[0] if held and held[0].behavior == name else None
            if goal is not None and goal.status == "pending":
                return None
            goals.append(goal)
        members = (at.tolist(), rows[at].tolist(), [entities[k] for k in at.tolist()], goals)
        self.scratch[("members", name)] = (table, goals_changed, at, members)
        return members

    def _merge(self, mind: Mind, listed: list, present: np.ndarray, values: list[float]) -> None:
        """Put one character's listed proposals into its mind's dict, with those there, in the
        order they were made (:meth:`_ranks`)."""
        proposals = {listed[c][1]: values[c] for c in np.flatnonzero(present).tolist()}
        own = mind.activations
        if own:
            # kept while the schedule's order is the same list (made again when a system comes;
            # a system taking an empty stage leaves an equal list, so `is`, not `==`)
            order, kept = self.scene.schedule.order(), self.scratch.get("ranks")
            if kept is None or kept[0] is not order:
                kept = self.scratch["ranks"] = (order, self._ranks())
            ranks = kept[1]
            proposals.update(own)
            merged = sorted(proposals.items(), key=lambda item: ranks.get(item[0], -len(ranks)))
            own.clear()
            own.update(merged)
        else:
            own.update(proposals)

    def _ranks(self) -> dict[str, int]:
        """The order in which this step's proposals were made, by behaviour name: a behaviour
        proposes under its own name when it runs, one after select_behavior in the schedule
        a step before (first), the others in the schedule's order; a name of no behaviour
        first of all (written between steps)."""
        systems = self.scene.schedule.systems()
        me = next(k for k, system in enumerate(systems) if system is self)
        return {system.name: k - len(systems) if k > me else k for k, system in enumerate(systems)}

    def _select_each(self, each: list, dt: float, batches: dict, joined: dict | None = None,
                     position: dict | None = None) -> list[tuple[int, Mind]]:  # fmt: skip
        """The per-character selection: for each (entity, (character, mind)) in entity order,
        over the proposals in its mind's dict: the winner with hysteresis, the switch (stop,
        start, event), the goal started, and the act (or a place in its batch). ``joined``:
        the characters that only join a batch (with their positions in ``position``'s order),
        merged into the batches in that order. Returns (entity, mind) of those that switched."""
        scene = self.scene
        now = scene.time
        behaviors = scene.behaviors
        members: dict[str, tuple] = {}
        switched = []  # (entity, mind) of those whose winner changed
        for entity, (character, mind) in each:
            proposals = mind.activations
            was = mind.winner
            if len(proposals) == 1 and proposals.get(was, -1.0) >= IDLE:
                # the one proposal is the winner's, above idle: it carries on (a crowd's usual step)
                proposals["idle"] = IDLE
                best = was
            else:
                proposals.setdefault("idle", IDLE)
                best = max(proposals, key=proposals.__getitem__)
            if best != was and was in proposals:
                held = now - mind.since < MIN_DWELL
                margin = proposals[best] - (proposals[was] + STICKINESS)
                if margin <= 0.0 or (held and margin < URGENT):
                    best = was
            goals = mind.goals
            goal = goals[0] if goals else None
            handle = None  # made only when needed: most steps most characters just carry on
            if best != was:
                handle = scene.character_handle(entity)
                old = behaviors.get(was)
                if old is not None:
                    old.stop(handle, goal if goal is not None and goal.behavior == was else None)
                scene.emit(BehaviorChanged(entity, was, best))
                mind.winner, mind.since = best, now
                mind.switches += 1
                switched.append((entity, mind))
                new = behaviors.get(best)
                if new is not None:
                    new.start(handle, goal if goal is not None and goal.behavior == best else None)
            # this step's proposals become `last`, the next step's go into a new dict (not last
            # step's, which may be shared by the minds that carried on over arrays)
            mind.last, mind.activations = proposals, {}
            winner = behaviors.get(best)
            if winner is None:
                continue
            own_goal = goal if goal is not None and goal.behavior == best else None
            if own_goal is not None and own_goal.status == "pending":
                own_goal.status, own_goal.started = "active", now
            if winner.batch:
                batch = members.get(best)
                if batch is None:
                    batch = members[best] = ([], [], [])
                batch[0].append(character.index)
                batch[1].append(entity)
                batch[2].append(own_goal)
                continue
            winner.act(handle or scene.character_handle(entity), mind, own_goal, dt)
        if joined is None:
            batches.update(members)
            return switched
        # the batches in the order of their first member, each in entity order (the loop's)
        # (the kept lists of `joined` copied: act_batch gets its own)
        merged = {name: (at[0], list(rows), list(entities), list(goals))
                  for name, (at, rows, entities, goals) in joined.items()}  # fmt: skip
        for name, (rows, entities, goals) in members.items():
            at = [position[entity] for entity in entities]
            if name in joined:
                old = joined[name]
                both = sorted(zip(at + old[0], rows + old[1], entities + old[2], goals + old[3], strict=True),
                              key=itemgetter(0))  # fmt: skip
                at, rows, entities, goals = (list(column) for column in zip(*both, strict=True))
            merged[name] = (at[0], rows, entities, goals)
        for name, (_, rows, entities, goals) in sorted(merged.items(), key=lambda item: item[1][0]):
            batches[name] = (rows, entities, goals)
        return switched
