"""Contact figures of a run: are the schoolyard's physical interactions true to contact?

:class:`InteractionRecorder` watches a scene step by step and measures what a viewer
checks when two things meet (BELIEVABILITY.md, "Touch"):

- **kicks**: each time a ball speeds up, the gap between the ball and the nearest leg
  capsule (thigh or shin) of any character, over this step and the one before (the
  contact happens inside the step; projection has separated them by its end), and how
  fast and how high (its underside off the ground) the ball ever went;
- **pushes**: each time a turning body (on an axle: the merry-go-round) spins up, the gap
  between the nearest character's hand and the nearest of its bars;
- **hugs**: frames in which a hug holds (its ``hold`` phase) with both of the hugger's
  hands on the partner's back, and with at least one of the partner's hands on the
  hugger's back (a hand on a back: beyond the torso as seen from the other, within 0.3 m
  of its nearest torso node), the pain either side felt from the other during the hug goal, and
  the deepest an arm (upper arm, and forearm short of the hand) sank into the partner;
- **fights** (grapple goals, once the fighter has closed in): the share of frames the
  two are within arm's reach, of those the share they face each other (each one's
  facing within 60 degrees of the other), and how far the victim got pushed or went
  from where the fight began;
- **the yard** (a scene fenced round): how far any free node no higher than the fences
  got beyond their box (through them, or over and down), and which bodies did;
- **carried things**: the largest link error of a body a character holds, how deep it
  sank into its carrier, and pain the holder felt from what it holds or let go of within
  the last second.

Gaps and depths are surface distances between capsules (segment distance less the two
radii); a gap below 0 is an overlap.

It also notes each interaction's **moment** (:class:`Moment`, in ``moments``): the step a
viewer would want a picture of - a leg at the ball as it speeds up, a hand on a bar as the
ride first spins up, both arms round the partner's back (and the partner's hand on the
hugger's) in a hug, the two face to face within reach in a fight, a hand taking hold.
``twig render --at`` frames them (:mod:`twig_ecs.graphics.closeup`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from twig_ecs.components import Character
from twig_ecs.store import LINK_COLLIDE, LINK_GRAB, LINK_OFF, LINK_ROPE, NODE_LOCKED, NODE_SPHERE
from twig_ecs.systems.behaviours.hug import hands_on_back
from twig_ecs.systems.behaviours.play import fences_of, yard_of
from twig_ecs.systems.physics.collide import capsule_gaps

SPEED_UP = 0.4  # m/s gained in one step by a ball: a kick (rolling and bouncing lose speed)
SPIN_UP = 0.005  # rad/s gained in one step by a turning body: a push (its bearings only slow it)
MERGE = 0.15  # s: ball speed-ups closer together than this are one kick
TOUCH_GAP = 0.03  # m: a leg this close to the ball touched it
HAND_GAP = 0.06  # m: a hand this close to a bar is on it
RELEASE_MEMORY = 1.0  # s after letting go that a dropped thing still counts as held
DEPTH_EVERY = 6  # steps between samples of a carried thing's depth in its carrier (10 Hz)
FIGHT_REACH = 0.8  # m (at 1.75 m tall, the fighter's): pelvis to pelvis within arm's reach
FACING = 0.5  # cosine: facing within 60 degrees of the other
FOREARM_SHARE = 0.7  # of the forearm from the elbow: the rest is the (exempt) holding hand
LEGS = (("l_hip", "l_knee"), ("r_hip", "r_knee"), ("l_knee", "l_foot"), ("r_knee", "r_foot"))
PUSH_PAUSE = 1.0  # s without a spin-up before the next spin-up begins another push
#: The kinds of moment recorded, in the order the docs list them.
MOMENT_KINDS = ("kick", "push", "hug", "fight", "grab")
ARMS = (("l_shoulder", "l_elbow", 1.0), ("r_shoulder", "r_elbow", 1.0),
        ("l_elbow", "l_hand", FOREARM_SHARE), ("r_elbow", "r_hand", FOREARM_SHARE))  # fmt: skip


def point_segment_gaps(point: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances from ``point`` to each segment a[k]b[k] (rows), vectorised."""
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", point - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0, 1)
    return np.linalg.norm(a + t[:, None] * ab - point, axis=1)


@dataclass(slots=True, frozen=True)
class Moment:
    """The step that shows an interaction: its kind (one of MOMENT_KINDS), the scene time (s),
    the step's frame number and the entities involved, the one who acts first (kicker and
    ball, pusher and ride, hugger and partner, fighter and target, holder and held)."""

    kind: str
    time: float
    frame: int
    names: tuple[str, ...]


@dataclass(slots=True)
class _Hug:
    """Running figures of the hugs between one hugger and one partner."""

    frames: int = 0
    both_arms: int = 0
    partner_hand: int = 0
    max_limb_depth: float = 0.0
    max_pain: float = 0.0


@dataclass(slots=True)
class _Fight:
    """Running figures of the fights between one fighter and its target."""

    frames: int = 0
    in_reach: int = 0
    face_to_face: int = 0
    max_shift: float = 0.0
    start: np.ndarray | None = None
    shown: bool = False  # this fight's moment is recorded


@dataclass(slots=True)
class _Event:
    """A speed-up (kick or push): when and the smallest gap seen around it."""

    time: float
    gap: float
    by: str = ""


@dataclass(slots=True)
class _Carried:
    """Running figures of one carried body."""

    frames: int = 0
    max_link_error: float = 0.0
    max_depth: float = 0.0
    pain_to_holder: float = 0.0
    holders: set = field(default_factory=set)


class InteractionRecorder:
    """Measures kicks, pushes, hugs and carried things of a scene, step by step."""

    def __init__(self, scene, moments_only: bool = False) -> None:
        """``moments_only``: record the moments and the figures they come from (kicks,
        pushes, hugs, fights, grabs), not those of carried things and the yard, which make
        no moment (a close-up looking for a moment measures a quarter less each step)."""
        self.scene = scene
        self.moments_only = moments_only
        self._links_cache: dict[tuple[int, int], list[int]] = {}
        self._rigid_cache: dict[int, tuple[tuple[int, int], np.ndarray]] = {}  # body -> (layout, link rows)
        st = scene.state
        self.balls: dict[str, int] = {}  # name -> node row
        self.rides: dict[str, tuple[int, list[int]]] = {}  # name -> (free node row, collidable link rows)
        for name in scene.entity_names:
            handle = scene.entity(name)
            body = handle.body
            rows = range(body.rows.start, body.rows.stop)
            flags = st.nodes.flags
            if len(rows) == 1 and flags[rows[0]] & NODE_SPHERE and not flags[rows[0]] & NODE_LOCKED:
                self.balls[name] = rows[0]
            free = [i for i in rows if st.nodes.axle_a[i] >= 0 and st.nodes.axle_radius[i] > 0.1]
            if free:
                self.rides[name] = (free[0], self._collidable_links(body.index))
        self.kicks: dict[str, list[_Event]] = {b: [] for b in self.balls}
        self.pushes: dict[str, list[_Event]] = {r: [] for r in self.rides}
        self._speed = {b: 0.0 for b in self.balls}
        self._leg_gap = {b: math.inf for b in self.balls}
        self._fastest = {b: 0.0 for b in self.balls}  # m/s
        self._highest = {b: 0.0 for b in self.balls}  # m of its underside above the ground
        self._spin = {r: 0.0 for r in self.rides}
        self._hand_gap = {r: math.inf for r in self.rides}
        self.hugs: dict[tuple[str, str], _Hug] = {}
        self.fights: dict[tuple[str, str], _Fight] = {}
        self.carried: dict[str, _Carried] = {}
        self._let_go: dict[tuple[str, str], float] = {}  # (holder, thing) -> time released
        self._held_before: dict[str, set[str]] = {}
        self.hug_pain_events = 0
        self.yard = yard_of(scene)
        self.fence_top = _fence_top(scene) if self.yard is not None else math.inf
        self.outside = 0.0
        self.escaped: set[str] = set()
        self.moments: list[Moment] = []
        self._kick_moment = {b: -math.inf for b in self.balls}  # time of each ball's last kick moment
        self._last_spin_up = {r: -math.inf for r in self.rides}
        self._hug_shown: set[int] = set()  # ids of the hug goals whose moment is recorded

    def _moment(self, kind: str, *names: str) -> None:
        self.moments.append(Moment(kind, self.scene.time, self.scene.frame, names))

    def _collidable_links(self, body_index: int) -> list[int]:
        lk = self.scene.state.links
        n = lk.count
        key = (body_index, n)  # rows change only when bodies or joints come or go
        cached = self._links_cache.get(key)
        if cached is None:
            cached = list(np.flatnonzero((lk.body[:n] == body_index) & ((lk.flags[:n] & LINK_COLLIDE) != 0)))
            self._links_cache[key] = cached
        return cached

    def _characters(self) -> list:
        scene = self.scene
        return [scene.character_handle(e) for e, _ in self.scene.world.get_component(Character)]

    def step(self) -> None:
        """Measure the state after one step."""
        scene = self.scene
        st = scene.state
        chars = self._characters()
        pos, prev = st.nodes.pos, st.nodes.prev
        dt = scene.dt
        for name, row in self.balls.items():
            speed = float(np.linalg.norm(pos[row] - prev[row])) / dt
            self._fastest[name] = max(self._fastest[name], speed)
            self._highest[name] = max(self._highest[name], float(pos[row, 1] - st.nodes.radius[row]))
            gap_now, by = self._nearest_leg(chars, row)
            gap = min(gap_now, self._leg_gap[name])
            if speed - self._speed[name] > SPEED_UP:
                self._add(self.kicks[name], gap, by)
                if gap <= TOUCH_GAP:  # a leg touched it: a kick, unless it goes on the last one
                    if by and scene.time - self._kick_moment[name] >= MERGE:
                        self._moment("kick", by, name)
                    self._kick_moment[name] = scene.time
            self._speed[name], self._leg_gap[name] = speed, gap_now
        for name, (row, links) in self.rides.items():
            spin = float(np.linalg.norm(pos[row] - prev[row])) / dt / float(st.nodes.axle_radius[row])
            gap_now, by = self._nearest_hand(chars, links)
            gap = min(gap_now, self._hand_gap[name])
            if spin - self._spin[name] > SPIN_UP:  # every spin-up frame counts: a push lasts seconds
                self.pushes[name].append(_Event(scene.time, gap, by))
                if gap <= HAND_GAP and scene.time - self._last_spin_up[name] > PUSH_PAUSE:
                    self._moment("push", by, name)
                self._last_spin_up[name] = scene.time
            self._spin[name], self._hand_gap[name] = spin, gap_now
        self._measure_hugs(chars)
        self._measure_fights(chars)
        self._note_grabs()
        if self.moments_only:
            return
        self._measure_carried(chars)
        if self.yard is not None:
            self._measure_yard()

    def _measure_yard(self) -> None:
        """How far beyond the fenced box any free node no higher than the fence is (m), and
        whose it is (a hand reaching over the top is not out: a 1.35 m child's hand at 1.09 m
        swung 2.4 cm over a 1.05 m fence as it kicked a ball lying by it)."""
        st = self.scene.state
        n = st.nodes.count
        lo, hi = self.yard
        xz = st.nodes.pos[:n][:, [0, 2]]
        beyond = np.maximum(np.maximum(lo - xz, xz - hi), 0.0).max(axis=1)
        beyond[(st.nodes.flags[:n] & NODE_LOCKED) != 0] = 0.0
        beyond[st.nodes.pos[:n, 1] > self.fence_top] = 0.0
        worst = float(beyond.max()) if n else 0.0
        if worst > 0.0:
            self.outside = max(self.outside, worst)
            for row in np.flatnonzero(beyond > 0.0):
                entity = int(st.bodies.entity[int(st.nodes.body[row])])
                self.escaped.add(self.scene.name_of(entity) or f"node {row}")

    def _add(self, events: list[_Event], gap: float, by: str) -> None:
        now = self.scene.time
        if events and now - events[-1].time < MERGE:
            last = events[-1]
            last.time = now
            if gap < last.gap:
                last.gap, last.by = gap, by
            return
        events.append(_Event(now, gap, by))

    def _nearest_leg(self, chars, ball_row: int) -> tuple[float, str]:
        """Surface gap from the ball to the nearest thigh or shin of any character."""
        st = self.scene.state
        pos = st.nodes.pos
        centre, radius = pos[ball_row], float(st.nodes.radius[ball_row])
        # far off (beyond two body heights and a metre): no need to look at its legs
        near = [me for me in chars if float(np.linalg.norm(me.position - centre)) <= 2.0 * me.scale + 1.0]
        if not near:
            return math.inf, ""
        a = pos[[me.node_row(u) for me in near for u, _ in LEGS]]
        b = pos[[me.node_row(v) for me in near for _, v in LEGS]]
        radii = np.concatenate([np.array([0.07, 0.07, 0.05, 0.05]) * me.scale for me in near])
        per_leg = point_segment_gaps(centre, a, b) - radii - radius
        k = int(np.argmin(per_leg))  # the first of equals, as characters are listed
        return float(per_leg[k]), near[k // len(LEGS)].name

    def _nearest_hand(self, chars, links: list[int]) -> tuple[float, str]:
        """Surface gap from the nearest hand of any character to the nearest collidable bar."""
        if not chars:
            return math.inf, ""
        st = self.scene.state
        lk, pos = st.links, st.nodes.pos
        a, b = pos[lk.a[links]], pos[lk.b[links]]
        hands = np.array([me.node_row(hand) for me in chars for hand in ("l_hand", "r_hand")])
        p = pos[hands]
        ab = b - a
        length2 = np.maximum(np.einsum("lk,lk->l", ab, ab), 1e-12)
        t = np.clip(np.einsum("hlk,lk->hl", p[:, None] - a[None], ab) / length2, 0.0, 1.0)
        gaps = np.linalg.norm(a[None] + t[..., None] * ab[None] - p[:, None], axis=2) - lk.radius[links][None]
        per_hand = gaps.min(axis=1) - st.nodes.radius[hands]
        k = int(np.argmin(per_hand))
        return float(per_hand[k]), chars[k // 2].name

    def _measure_hugs(self, chars) -> None:
        scene = self.scene
        pains = [e for e in scene.events if e.kind == "pain"]
        for me in chars:
            goal = next((g for g in me.goals if g.behavior == "hug"), None)
            if goal is None or not scene.has_entity(goal.params["target"]):
                continue
            partner = scene.entity(goal.params["target"])
            figures = self.hugs.setdefault((me.name, partner.name), _Hug())
            for e in pains:
                if {e.body, e.source_body} == {me.entity, partner.entity}:
                    figures.max_pain = max(figures.max_pain, e.energy)
                    self.hug_pain_events += 1
            phase = goal.memory.get("phase")
            if phase not in ("wrap", "hold"):
                continue
            figures.max_limb_depth = max(
                figures.max_limb_depth,
                self._arm_depth(me, partner),
                self._arm_depth(partner, me) if hasattr(partner, "holding") else 0.0,
            )
            if phase != "hold":
                continue
            figures.frames += 1
            both = hands_on_back(me, partner) == 2
            answered = hasattr(partner, "holding") and hands_on_back(partner, me) >= 1
            figures.both_arms += int(both)
            figures.partner_hand += int(answered)
            if both and (answered or not hasattr(partner, "holding")) and goal.id not in self._hug_shown:
                self._hug_shown.add(goal.id)
                self._moment("hug", me.name, partner.name)

    def _measure_fights(self, chars) -> None:
        scene = self.scene
        for me in chars:
            goal = next((g for g in me.goals if g.behavior == "grapple"), None)
            key = None if goal is None else (me.name, goal.params["target"])
            for pair, figures in self.fights.items():
                if pair[0] == me.name and pair != key:
                    figures.start = None  # that fight is over: the next one starts afresh
                    figures.shown = False
            if goal is None or "fighting" not in goal.memory or not scene.has_entity(key[1]):
                continue
            other = scene.entity(key[1])
            figures = self.fights.setdefault(key, _Fight())
            if figures.start is None:
                figures.start = other.position
            figures.frames += 1
            shift = float(np.hypot(*(other.position - figures.start)[[0, 2]]))
            figures.max_shift = max(figures.max_shift, shift)
            apart = (other.position - me.position) * np.array([1.0, 0.0, 1.0])
            gap = float(np.linalg.norm(apart))
            if gap > FIGHT_REACH * me.scale:
                continue
            figures.in_reach += 1
            toward = apart / max(gap, 1e-9)
            if hasattr(other, "facing") and me.facing @ toward > FACING and -(other.facing @ toward) > FACING:
                figures.face_to_face += 1
                if not figures.shown:
                    figures.shown = True
                    self._moment("fight", me.name, other.name)

    def _note_grabs(self) -> None:
        """A moment for each hand that took hold in this step."""
        scene = self.scene
        for e in scene.events:
            if e.kind == "grab":
                holder, held = scene.name_of(e.holder), scene.name_of(e.held)
                if holder and held:
                    self._moment("grab", holder, held)

    def _arm_depth(self, me, other) -> float:
        """How deep ``me``'s arms (short of the hands) sink into ``other``'s colliders (m)."""
        st = self.scene.state
        lk, pos = st.links, st.nodes.pos
        links = np.asarray(self._collidable_links(other.body.index), dtype=np.int64)
        if not len(links):
            return 0.0
        p = np.array([me.node(u) for u, _, _ in ARMS])
        q = np.array([me.node(v) for _, v, _ in ARMS])
        share = np.array([s for _, _, s in ARMS])
        q = p + share[:, None] * (q - p)
        r = np.where(share == 1.0, 0.045, 0.04) * me.scale
        gaps = capsule_gaps(p, q, r, pos[lk.a[links]], pos[lk.b[links]], lk.radius[links])
        return max(0.0, float(-gaps.min()))

    def _measure_carried(self, chars) -> None:
        scene = self.scene
        now = scene.time
        pains = [e for e in scene.events if e.kind == "pain"]
        for me in chars:
            held = {n for n in me.holding.values() if scene.has_entity(n)}
            # a carried thing: not a hugged partner, nor a fixed thing held on to (a ride's bar)
            things = {n for n in held if not hasattr(scene.entity(n), "holding") and not self._anchored(n)}
            for gone in self._held_before.get(me.name, set()) - things:
                self._let_go[(me.name, gone)] = now
            self._held_before[me.name] = things
            recent = {
                t for (h, t), when in self._let_go.items() if h == me.name and now - when < RELEASE_MEMORY
            }
            for e in pains:
                if e.body != me.entity:
                    continue
                source = scene.name_of(e.source_body)
                if source in things | recent:
                    figures = self.carried.setdefault(source, _Carried())
                    figures.pain_to_holder = max(figures.pain_to_holder, e.energy)
            for name in things:
                figures = self.carried.setdefault(name, _Carried())
                figures.frames += 1
                figures.holders.add(me.name)
                thing = scene.entity(name)
                figures.max_link_error = max(figures.max_link_error, self._link_error(thing.body.index))
                if scene.frame % DEPTH_EVERY == 0:  # capsule pairs in Python: sampled, not every step
                    hands = tuple(me.node_row(("l_hand", "r_hand")[h == "right"])
                                  for h, n in me.holding.items() if n == name)  # fmt: skip
                    depth = self._depth(thing.body.index, me.body.index, hands)
                    figures.max_depth = max(figures.max_depth, depth)

    def _anchored(self, name: str) -> bool:
        """Has body ``name`` a locked node (an axle's hub, a fence): it cannot be carried."""
        st = self.scene.state
        body = self.scene.entity(name).body
        rows = body.rows
        return bool((st.nodes.flags[rows] & NODE_LOCKED).any())

    def _link_error(self, body_index: int) -> float:
        """Largest relative length error of a body's rigid links (a rope only when stretched)."""
        state = self.scene.state
        lk, pos = state.links, state.nodes.pos
        n = lk.count
        # the body's links change only with the store's layout; of those, the ones that are
        # no grab joint, switched on, with a length (not a scan of every link each step)
        layout = (n, state.version)
        known = self._rigid_cache.get(body_index)
        if known is None or known[0] != layout:
            known = self._rigid_cache[body_index] = (layout, np.flatnonzero(lk.body[:n] == body_index))
        own = known[1]
        rows = own[((lk.flags[own] & (LINK_GRAB | LINK_OFF)) == 0) & (lk.rest[own] > 0)]
        length = np.linalg.norm(pos[lk.a[rows]] - pos[lk.b[rows]], axis=1)
        error = (length - lk.rest[rows]) / lk.rest[rows]
        rope = (lk.flags[rows] & LINK_ROPE) != 0
        error = np.where(rope, np.maximum(error, 0.0), np.abs(error))
        return float(error.max()) if len(error) else 0.0

    def _depth(self, body_a: int, body_b: int, hands: tuple[int, ...] = ()) -> float:
        """Deepest overlap (m) between the collidable links of two bodies; a link of
        ``body_b`` ending at one of the node rows ``hands`` (a holding hand) counts only
        its FOREARM_SHARE from the other end: the hand itself holds the thing."""
        lk, pos = self.scene.state.links, self.scene.state.nodes.pos
        mine = np.asarray(self._collidable_links(body_a), dtype=np.int64)
        theirs = np.asarray(self._collidable_links(body_b), dtype=np.int64)
        if not len(mine) or not len(theirs):
            return 0.0
        p, q = pos[lk.a[theirs]].copy(), pos[lk.b[theirs]].copy()
        into = np.isin(lk.b[theirs], hands)  # the link ends at a holding hand: count it short of the hand
        p_into, q_into = p[into], q[into]
        q[into] = p_into + FOREARM_SHARE * (q_into - p_into)
        out = ~into & np.isin(lk.a[theirs], hands)
        p_out, q_out = p[out], q[out]
        p[out] = q_out + FOREARM_SHARE * (p_out - q_out)
        gaps = capsule_gaps(pos[lk.a[mine]], pos[lk.b[mine]], lk.radius[mine], p, q, lk.radius[theirs])
        return max(0.0, float(-gaps.min()))

    def report(self) -> dict:
        """The interaction figures, JSON-ready."""
        out: dict = {}
        for name, events in self.kicks.items():
            gaps = [e.gap for e in events]
            out.setdefault("kicks", {})[name] = {
                "speed_ups": len(gaps),
                "touched_fraction": round(sum(g <= TOUCH_GAP for g in gaps) / len(gaps), 3) if gaps else None,
                "median_gap_m": round(float(np.median(gaps)), 3) if gaps else None,
                "gaps_m": [round(g, 3) for g in gaps[:200]],
                "max_speed_m_s": round(self._fastest[name], 2),
                "max_height_m": round(self._highest[name], 2),
            }
        for name, events in self.pushes.items():
            gaps = [e.gap for e in events]
            out.setdefault("pushes", {})[name] = {
                "spin_up_frames": len(gaps),
                "hand_on_fraction": round(sum(g <= HAND_GAP for g in gaps) / len(gaps), 3) if gaps else None,
                "median_gap_m": round(float(np.median(gaps)), 3) if gaps else None,
                "gaps_m": [round(g, 3) for g in gaps[:200]],
            }
        hugs = {}
        for (me, partner), h in self.hugs.items():
            hugs[f"{me}->{partner}"] = {
                "hold_frames": h.frames,
                "both_arms_fraction": round(h.both_arms / h.frames, 3) if h.frames else None,
                "partner_hand_on_back_fraction": round(h.partner_hand / h.frames, 3) if h.frames else None,
                "max_pain_j": round(h.max_pain, 3),
                "max_limb_depth_m": round(h.max_limb_depth, 4),
            }
        out["hugs"] = hugs
        out["fights"] = {
            f"{me}->{target}": {
                "frames": f.frames,
                "in_reach_fraction": round(f.in_reach / f.frames, 3) if f.frames else None,
                "face_to_face_fraction": round(f.face_to_face / f.in_reach, 3) if f.in_reach else None,
                "max_victim_shift_m": round(f.max_shift, 3),
            }
            for (me, target), f in self.fights.items()
        }
        if self.yard is not None:
            out["yard"] = {
                "low_xz": [round(float(v), 3) for v in self.yard[0]],
                "high_xz": [round(float(v), 3) for v in self.yard[1]],
                "max_outside_m": round(self.outside, 4),
                "escaped": sorted(self.escaped),
            }
        out["carried"] = {
            name: {
                "frames": c.frames,
                "max_link_error": round(c.max_link_error, 4),
                "max_depth_in_carrier_m": round(c.max_depth, 4),
                "max_pain_to_holder_j": round(c.pain_to_holder, 3),
            }
            for name, c in self.carried.items()
        }
        return out


def _fence_top(scene) -> float:
    """Height (m) of the lowest top among the yard's fences
    (:func:`~twig_ecs.systems.behaviours.play.fences_of`)."""
    tops = [float(rows[:, 1].max()) for rows in fences_of(scene)]
    return min(tops) if tops else math.inf
