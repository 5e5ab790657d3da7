"""Physical invariants of the core: momentum, rest, separation, axles, pain, limits."""

from __future__ import annotations

import math

import numpy as np
import pytest
from helpers import angle_about_y, knee_hyperextension, max_overlap_between_bodies, total_momentum

from twig_ecs import Scene
from twig_ecs.threads import usable_threads

NO_DAMPING = {"air": 0.0, "ground": 0.0}


def test_free_bodies_in_zero_gravity_keep_total_momentum_through_collision(zero_g_scene):
    scene = zero_g_scene
    a = scene.spawn("humanoid", name="a", position=(-0.8, 3.0, 0.0), facing=90, damping=NO_DAMPING)
    b = scene.spawn("humanoid", name="b", position=(0.8, 3.2, 0.1), facing=-90, damping=NO_DAMPING)
    a.set_velocity((2.0, 0.1, 0.0))
    b.set_velocity((-2.5, 0.0, 0.3))
    a.set_node_velocity("l_hand", (3.0, 2.0, -1.0))  # spin it: joints and limits work too
    b.set_node_velocity("head", (-1.0, 0.0, 2.0))
    scene.step()
    before = total_momentum(scene)
    va_before = a.velocity
    scene.run(2.0)
    after = total_momentum(scene)
    assert scene.event_counts["contact"] > 0, "the bodies should have collided"
    assert np.linalg.norm(a.velocity - va_before) > 0.5, "the collision should change a's motion"
    assert np.linalg.norm(after - before) <= 1e-9 * np.linalg.norm(before)


def test_dropped_humanoid_comes_to_rest_on_the_ground_in_shape(empty_scene):
    scene = empty_scene
    body = scene.spawn("humanoid", name="doll", position=(0.0, 1.0, 0.0), facing=20)
    body.set_node_velocity("head", (1.5, 0.0, 0.8))  # tip it over
    scene.run(10.0)
    nodes = scene.state.nodes
    pos = nodes.pos[: nodes.count]
    speed = np.linalg.norm(pos - nodes.prev[: nodes.count], axis=1) / scene.dt
    assert pos[:, 1].min() > -0.01
    assert scene.state.link_errors().max() < 0.01
    assert speed.max() < 0.05, "it should have come to rest"
    assert body.position[1] < 0.4, "it should lie on the ground, not stand"


def test_two_bodies_dropped_on_each_other_end_separated(empty_scene):
    scene = empty_scene
    scene.spawn("humanoid", name="below", position=(0.0, 0.5, 0.0), facing=0)
    above = scene.spawn("humanoid", name="above", position=(0.1, 1.6, 0.0), facing=90)
    above.set_node_velocity("head", (0.5, 0.0, 0.0))
    scene.run(8.0)
    assert scene.event_counts["contact"] > 0, "the bodies should have met"
    assert max_overlap_between_bodies(scene) <= 0.01


def test_push_on_merry_go_round_bar_spins_it_about_its_axle_keeping_its_shape(empty_scene):
    scene = empty_scene
    mgr = scene.spawn("merry_go_round", name="mgr", position=(0.0, 0.0, 0.0))
    hub, top = mgr.node("hub"), mgr.node("top")
    rest = scene.state.links.rest[: scene.state.links.count].copy()
    radius0 = np.linalg.norm(mgr.node("rim0")[[0, 2]])
    height0 = mgr.node("rim0")[1]
    start = angle_about_y(mgr.node("rim0"))
    # push the handle bar sideways for a second, as a child running alongside would
    for _ in range(60):
        handle = mgr.node("handle0")
        tangent = np.cross([0.0, 1.0, 0.0], handle)
        mgr.apply_force("handle0", tuple(150.0 * tangent / np.linalg.norm(tangent)))
        scene.step()
    turned = (angle_about_y(mgr.node("rim0")) - start + math.pi) % (2 * math.pi) - math.pi
    assert abs(turned) > math.radians(10), "a push should set it spinning"
    np.testing.assert_allclose(mgr.node("hub"), hub)
    np.testing.assert_allclose(mgr.node("top"), top)
    assert abs(np.linalg.norm(mgr.node("rim0")[[0, 2]]) - radius0) < 1e-3
    assert abs(mgr.node("rim0")[1] - height0) < 1e-3
    assert scene.state.link_errors().max() < 0.01
    lengths = np.linalg.norm(
        scene.state.nodes.pos[scene.state.links.a[: len(rest)]]
        - scene.state.nodes.pos[scene.state.links.b[: len(rest)]],
        axis=1,
    )
    np.testing.assert_allclose(lengths, rest, rtol=0.01)


def test_fast_impact_hurts_the_struck_character_and_pain_decays_with_half_life(zero_g_scene):
    scene = zero_g_scene
    victim = scene.spawn("humanoid", name="victim", position=(0.0, 2.0, 0.0),
                         pain={"threshold": 2.0, "half_life": 0.5})  # fmt: skip
    ball = scene.spawn("ball", name="ball", position=(0.0, 3.55, 3.0))
    ball.set_velocity((0.0, 0.0, -15.0))  # straight at the head
    pains = []
    scene.on("pain", pains.append)
    for _ in range(60):
        scene.step()
        if pains:
            break
    assert pains, "a 15 m/s ball to the head should hurt"
    hit = pains[0]
    assert hit.body == victim.entity
    # the struck part, by name (nodes and links are not entities): a link at the top of the body
    a, b = hit.link.split("-")
    assert {a, b} <= set(victim.node_names) and "neck" in (a, b)
    assert scene.name_of(hit.source_body) == "ball"
    assert hit.energy >= 2.0
    # let the ball fly off, then watch the level fall with no further blows
    scene.run(0.5)
    pains.clear()
    level = victim.pain
    assert level > 0
    scene.run(0.5)
    assert not pains
    assert victim.pain / level == pytest.approx(0.5, rel=0.01)


def test_knees_never_bend_backwards_during_a_fall_and_settle(empty_scene):
    scene = empty_scene
    body = scene.spawn("humanoid", name="faller", position=(0.0, 0.6, 0.0))
    body.set_node_velocity("pelvis", (0.0, 0.0, -2.0))  # legs kick forward, body falls back
    body.set_node_velocity("head", (0.5, 0.0, 1.0))
    worst = -1.0
    for _ in range(600):
        scene.step()
        worst = max(worst, knee_hyperextension(body))
    # the solver leaves legs within 1.5% of straight alone: that is about 1 degree
    assert worst < 0.02, f"a knee bent backwards ({worst:.3f} of the leg length)"


def test_same_seed_gives_the_same_state_hash(scenes):
    hashes = []
    for _ in range(2):
        scene = Scene.load("schoolyard", seed=7)
        scenes.append(scene)
        scene.run(3.0)
        hashes.append(scene.state_hash())
    assert hashes[0] == hashes[1]
    with Scene.load("schoolyard", seed=7) as fresh:
        assert hashes[0] != fresh.state_hash()  # it did move


def _row(body, node: str) -> int:
    return body.body.node_index(node)


def _kinetic_energy(scene) -> float:
    n = scene.state.nodes
    v = (n.pos - n.prev)[: n.count] / scene.dt
    return 0.5 * float((n.mass[: n.count] * (v**2).sum(axis=1)).sum())


def _fold_right_knee_sideways(body, hip_to_foot: float) -> np.ndarray:
    """Fold the right leg, its foot ``hip_to_foot`` m below the hip, with the knee pointing
    to the body's right instead of forwards: a bend far past one edge of the knee's arc,
    both link lengths kept. Moves positions only; returns the body's left (unit)."""
    pos = body.scene.state.nodes.pos
    hip, knee, foot = (_row(body, n) for n in ("r_hip", "r_knee", "r_foot"))
    thigh = np.linalg.norm(pos[knee] - pos[hip])
    shin = np.linalg.norm(pos[foot] - pos[knee])
    left = pos[_row(body, "l_hip")] - pos[hip]
    left /= np.linalg.norm(left)
    down = np.array([0.0, -1.0, 0.0])
    along = (thigh**2 - shin**2 + hip_to_foot**2) / (2.0 * hip_to_foot)
    pos[foot] = pos[hip] + hip_to_foot * down
    pos[knee] = pos[hip] + along * down - math.sqrt(thigh**2 - along**2) * left
    return left


def test_a_knee_folded_far_past_its_limit_is_put_back_without_gaining_speed(zero_g_scene):
    # the 300-crowd soak's blow-ups: a knee found deep past its arc (a folded leg turned
    # sideways) was moved straight onto the edge's plane, in towards the hip-foot line;
    # the links pushed it out again and each pass turned the fight into speed (a folded
    # knee reached 35 m/s within one step). A joint stop must never add energy.
    from twig_ecs.systems.physics.constrain import constraints_of, solve_constraints

    scene = zero_g_scene
    body = scene.spawn("humanoid", name="folded", position=(0.0, 1.0, 0.0), facing=0)
    scene.step()
    left = _fold_right_knee_sideways(body, hip_to_foot=0.3)
    nodes = scene.state.nodes
    nodes.prev[: nodes.count] = nodes.pos[: nodes.count]  # at rest
    solve_constraints(scene.settings.iterations, constraints_of(scene.state))
    speed = np.linalg.norm(nodes.pos - nodes.prev, axis=1)[: nodes.count] / scene.dt
    assert speed.max() < 0.5, f"the repair flung a node at {speed.max():.1f} m/s"
    # and it was repaired: the knee bends forwards again, the links keep their lengths
    hip, knee, foot = (body.node(n) for n in ("r_hip", "r_knee", "r_foot"))
    axis = (foot - hip) / np.linalg.norm(foot - hip)
    bend = (knee - hip) - np.dot(knee - hip, axis) * axis
    forward = np.cross(left, body.node("neck") - body.node("pelvis"))
    assert np.dot(bend, forward) > 0.0, "the knee should bend forwards"
    assert abs(np.dot(bend, left)) < 0.35 * np.linalg.norm(bend), "the knee should bend forwards"
    assert scene.state.link_errors().max() < 0.05


def test_a_knee_driven_into_its_limit_stops_without_bouncing(zero_g_scene):
    # a stop takes out the speed into the fault and gives none back: a folded knee swinging
    # outwards at 3 m/s, past the edge of its arc, leaves the body with no more energy
    from twig_ecs.systems.physics.constrain import constraints_of, solve_constraints

    scene = zero_g_scene
    body = scene.spawn("humanoid", name="kneed", position=(0.0, 1.0, 0.0), facing=0)
    scene.step()
    nodes = scene.state.nodes
    left = _fold_right_knee_sideways(body, hip_to_foot=0.6)
    nodes.prev[: nodes.count] = nodes.pos[: nodes.count]
    knee = _row(body, "r_knee")
    nodes.prev[knee] += 3.0 * scene.dt * left  # moving to the body's right, into the fault
    before = _kinetic_energy(scene)
    solve_constraints(scene.settings.iterations, constraints_of(scene.state))
    assert _kinetic_energy(scene) <= 1.01 * before


def test_the_contact_passes_visit_exactly_the_candidate_pairs_within_reach_in_order():
    """``near_pairs`` keeps, in the broad phase's order, the candidate pairs whose capsules are
    within the margin of touching (measured here by sampling both segments densely)."""
    from twig_ecs.bench.cases import hugging_pairs
    from twig_ecs.systems.physics.collide import CollideSystem, near_pairs

    with hugging_pairs(40) as scene:
        scene.run(4.0)  # arms round: many pairs touching, many more close, most boxes just overlapping
        collide = next(s for s in scene.schedule.systems() if isinstance(s, CollideSystem))
        n = collide.broad_phase()
        st = scene.state
        pos, col = st.nodes.pos, st.colliders
        pairs = st.pairs[:n]
        near, count = near_pairs(pos, col.a, col.b, col.radius, st.pairs, n, 0.1)
        t = np.linspace(0.0, 1.0, 201)[:, None]
        gaps = []
        for chunk in np.array_split(pairs, max(1, len(pairs) // 32)):  # 32 pairs a numpy call, not 1
            i, j = chunk[:, 0], chunk[:, 1]
            p = pos[col.a[i]][:, None] + t * (pos[col.b[i]] - pos[col.a[i]])[:, None]  # (pairs, 201, 3)
            q = pos[col.a[j]][:, None] + t * (pos[col.b[j]] - pos[col.a[j]])[:, None]
            # every sample of one against every sample of the other, |p - q|^2 as |p|^2 + |q|^2 - 2 p.q
            # (a matrix product: five times quicker than the differences; off by < 1e-9 m here)
            across = p @ q.transpose(0, 2, 1)  # (pairs, 201, 201): p.q
            square = (p * p).sum(axis=2)[:, :, None] + (q * q).sum(axis=2)[:, None] - 2 * across
            closest = np.sqrt(np.maximum(square.min(axis=(1, 2)), 0.0))
            gaps.extend(closest - col.radius[i] - col.radius[j])
        gaps = np.array(gaps)
        # sampled distances overestimate by at most the spacing: leave out the borderline ones
        sure_in = {tuple(p) for p, g in zip(pairs.tolist(), gaps, strict=True) if g < 0.1 - 0.01}
        sure_out = {tuple(p) for p, g in zip(pairs.tolist(), gaps, strict=True) if g > 0.1 + 0.01}
        kept = [tuple(p) for p in near[:count].tolist()]
        assert sure_in <= set(kept) and not (sure_out & set(kept))
        assert 0 < len(sure_in) < 0.6 * n, "most candidate pairs are further apart than that"
        order = {p: k for k, p in enumerate(map(tuple, pairs.tolist()))}
        assert [order[p] for p in kept] == sorted(order[p] for p in kept)


def test_the_near_pairs_follow_moving_nodes_and_never_leave_out_a_touching_pair():
    """As nodes move between contact passes, ``repick_moved`` measures again only the pairs of
    colliders on a node that has moved a quarter of the margin, and its list still holds every
    touching candidate pair, in the broad phase's order."""
    from twig_ecs.bench.cases import hugging_pairs
    from twig_ecs.systems.physics.collide import (
        CONTACT_MARGIN,
        REPICK_MOVE,
        CollideSystem,
        ContactColumns,
        contacts_of,
        mark_near,
        near_pairs,
        repick_moved,
    )
    from twig_ecs.systems.physics.constrain import NodeColumns, constraints_of

    with hugging_pairs(40) as scene:
        scene.run(4.0)
        collide = next(s for s in scene.schedule.systems() if isinstance(s, CollideSystem))
        n = collide.broad_phase()
        st = scene.state
        nodes = NodeColumns(*constraints_of(st)[0])
        cols = ContactColumns(*contacts_of(st))
        pos, col = st.nodes.pos, st.colliders
        near = np.empty((n, 2), dtype=st.pairs.dtype)
        is_near = np.empty(n, dtype=np.bool_)
        count = mark_near(pos, col.a, col.b, col.radius, st.pairs, n, CONTACT_MARGIN, is_near, near)
        watch = (is_near, pos[: st.nodes.count].copy(), np.empty(st.nodes.count, np.bool_),
                 np.empty(col.count, np.bool_))  # fmt: skip
        order = {p: k for k, p in enumerate(map(tuple, st.pairs[:n].tolist()))}
        rng = np.random.default_rng(3)
        changed = 0
        for _ in range(40):
            # small jitters everywhere (each under the threshold: nothing measured again) and a
            # few long moves, as contact and link corrections make within a step
            pos[: st.nodes.count] += rng.normal(0.0, 0.002, (st.nodes.count, 3))
            far = rng.choice(st.nodes.count, 5, replace=False)
            pos[far] += rng.normal(0.0, 0.03, (5, 3))
            before = near[:count].copy()
            count = repick_moved(nodes, cols, st.pairs, n, near, count, watch)
            changed += count != len(before) or not (near[:count] == before).all()
            touching, n_touching = near_pairs(pos, col.a, col.b, col.radius, st.pairs, n, 0.0)
            kept = [tuple(p) for p in near[:count].tolist()]
            assert {tuple(p) for p in touching[:n_touching].tolist()} <= set(kept)
            assert [order[p] for p in kept] == sorted(order[p] for p in kept)
        # a jitter alone (every node well within the threshold) changes nothing
        pos[: st.nodes.count] = watch[1] + 0.4 * REPICK_MOVE / math.sqrt(3.0)
        before = near[:count].copy()
        assert repick_moved(nodes, cols, st.pairs, n, near, count, watch) == count
        assert (near[:count] == before).all()
        assert changed > 10, "the long moves bring pairs near and take others away"


@pytest.mark.skipif(usable_threads() < 2, reason="one usable thread (NUMBA_NUM_THREADS=1?): nothing to split")
def test_link_and_limit_passes_split_across_threads_by_body_leave_the_same_state(monkeypatch, scenes):
    """A crowd big enough for the threaded passes (a grab joint among them: a body pair that must
    wait its turn) steps to the last bit as on one thread; scenes stepped from other threads at
    the same time run their passes on one thread (numba's pool takes one caller at a time) and
    take turns a step at a time (Scene.STEP_LOCK).
    Every scene is closed even when an assertion fails (the ``scenes`` fixture). Threads are
    fixed (``TWIG_THREADS``): measured, the choice might keep one thread throughout."""
    import threading

    from twig_ecs.bench.cases import crowd
    from twig_ecs.systems.physics import constrain

    monkeypatch.setenv("TWIG_THREADS", str(usable_threads()))
    size = constrain.PARALLEL_BODIES + 20

    def world() -> Scene:
        scene = crowd(size)
        scenes.append(scene)
        first = scene.character_handle(int(scene.state.characters.entity[0]))
        scene.spawn("ball", name="toy", position=tuple(first.node("r_hand")))
        first.grab("toy", hand="right")
        return scene

    threaded = world()
    threaded.step(1)  # (the step sets the thread count its constraint plan is made for)
    assert constrain.constraints_of(threaded.state)[4][4], "this crowd's passes are split across threads"
    threaded.step(89)
    chunks, groups = constrain.constraints_of(threaded.state)[4][:2]
    runs = np.diff(groups)
    assert runs.max() >= constrain.PARALLEL_BODIES and (runs == 1).any(), "bodies share runs; the joint waits"
    monkeypatch.setattr(constrain, "PARALLEL_BODIES", 10**9)
    alone = world()
    assert not constrain.constraints_of(alone.state)[4][4]
    alone.step(90)
    assert alone.state_hash() == threaded.state_hash()
    monkeypatch.undo()
    others = [world() for _ in range(2)]
    steppers = [threading.Thread(target=scene.step, args=(90,)) for scene in others]
    for t in steppers:
        t.start()
    for t in steppers:
        t.join()
    assert [s.state_hash() for s in others] == [threaded.state_hash()] * 2


def test_the_one_thread_link_order_takes_bodies_side_by_side_keeping_each_bodys_rows_in_order():
    # four bodies of 3 rows and one of 2 in one run, a grab joint (a run of its own), then two
    # bodies of 3: bodies four at a time where they have as many rows, never across a run
    from twig_ecs.systems.physics.constrain import interleaved

    ends = np.cumsum([3, 3, 3, 3, 2, 1, 3, 3])
    chunks = np.stack([np.append(0, ends[:-1]), ends], axis=1)
    groups = np.array([0, 5, 6, 8])
    order = interleaved(chunks, groups, 4).tolist()
    assert order[:12] == [0, 3, 6, 9, 1, 4, 7, 10, 2, 5, 8, 11]  # first rows, second rows, ...
    assert order[12:] == [12, 13, 14, 15, 18, 16, 19, 17, 20]  # the short body, the joint, two more
    assert interleaved(chunks, groups, 1).tolist() == list(range(21))


def test_links_projected_bodies_side_by_side_leave_the_state_to_the_last_bit(monkeypatch, scenes):
    # the order of the rows of different bodies changes nothing: a falling pile steps to the
    # same bits with the bodies' link rows side by side as one body after another
    from twig_ecs.bench.cases import ragdoll_pile
    from twig_ecs.systems.physics import constrain

    hashes = []
    for lanes in (1, constrain.LINK_LANES):
        monkeypatch.setattr(constrain, "LINK_LANES", lanes)
        scene = ragdoll_pile(9)
        scenes.append(scene)
        scene.step(90)
        hashes.append(scene.state_hash())
    assert hashes[0] == hashes[1]
    assert constrain.LINK_LANES > 1


def test_fixed_bodies_meeting_each_other_give_no_contact_work_and_a_ball_only_its_own(empty_scene):
    # fence panels meeting at their posts overlap by design: 39 candidate pairs a joint, each
    # tested in every pass of every step though neither side can move (issue 36: nine in ten of
    # the schoolyard's pairs, collide 1.2 of its 2.2 ms a step)
    scene = empty_scene
    for k, (x, z, facing) in enumerate([(0, 0, 0), (5, 0, 0), (10, 0, 0), (10, 0, 90)]):
        scene.spawn("fence", name=f"fence{k}", position=(x, 0, z), facing=facing)
    scene.step(2)
    assert scene.state.n_pairs == 0
    scene.spawn("ball", name="ball", position=(5.0, 0.4, 0.2))  # at a post where two panels meet
    scene.run(0.5)
    state = scene.state
    pairs = state.pairs[: state.n_pairs]
    ball = scene.entity("ball").body.index
    owners = state.colliders.body[pairs]
    assert len(pairs) > 0 and np.all((owners == ball).any(axis=1)), "every pair left is the ball's"
    assert scene.entity("ball").node_positions[:, 1].min() > 0.0  # and it still rests, bounced off


def test_the_broad_phase_sorts_its_grid_entries_by_bucket_keeping_their_order_within_one():
    """``sort_by_hash`` orders the grid's entries as counting them into buckets did (buckets
    in turn, entries within one in the order they came), however many bits the hash has."""
    from twig_ecs.systems.physics.collide import sort_by_hash

    rng = np.random.default_rng(5)
    for bits in (4, 11, 12, 19, 23):
        keys = rng.integers(0, 1 << bits, 5000)
        keys[::7] = keys[0]  # many equal keys: their order must hold
        order, sorted_keys = sort_by_hash(keys, bits)
        assert (order == np.argsort(keys, kind="stable")).all()
        assert (sorted_keys == np.sort(keys)).all()


def test_the_ground_pass_lifts_marks_and_locks_nodes_as_the_node_by_node_rule_says():
    """``project_ground`` (written without branches) does to every node what the plain rule
    says: a free node below its radius comes up onto it, one within the contact slop is marked
    in contact, one that locks on contact is locked where it then stands; locked nodes and
    nodes in the air are left alone."""
    from twig_ecs.store import NODE_IN_CONTACT, NODE_LOCK_ON_CONTACT, NODE_LOCKED
    from twig_ecs.systems.physics.constrain import CONTACT_SLOP, NodeColumns, project_ground

    rng = np.random.default_rng(7)
    count = 400
    pos = rng.uniform(-0.05, 0.1, (count + 5, 3))  # (rows past count: not live)
    radius = rng.uniform(0.0, 0.05, count + 5)
    kinds = np.array([0, NODE_LOCKED, NODE_LOCK_ON_CONTACT, NODE_IN_CONTACT], np.uint32)
    flags = rng.choice(kinds, count + 5)
    lock_pos = np.zeros((count + 5, 3))
    want_pos, want_flags, want_lock = pos.copy(), flags.copy(), lock_pos.copy()
    was_locked, was_at = (flags & NODE_LOCKED) != 0, pos[:, 1].copy()
    for i in range(count):  # the rule, node by node
        f = int(want_flags[i])
        if f & NODE_LOCKED or want_pos[i, 1] >= radius[i] + CONTACT_SLOP:
            continue
        want_pos[i, 1] = max(want_pos[i, 1], radius[i])
        f |= NODE_IN_CONTACT
        if f & NODE_LOCK_ON_CONTACT:
            f |= NODE_LOCKED
            want_lock[i] = want_pos[i]
        want_flags[i] = f
    project_ground(NodeColumns(pos, pos.copy(), np.ones(count + 5), flags, radius, lock_pos, count))
    assert np.array_equal(pos, want_pos) and np.array_equal(flags, want_flags)
    assert np.array_equal(lock_pos, want_lock)
    assert ((flags & NODE_LOCKED != 0) & ~was_locked).any(), "some nodes locked as they landed"
    assert (pos[:count, 1] > was_at[:count]).any(), "some nodes lifted onto the ground"
