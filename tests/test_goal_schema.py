"""A goal behaviour is declared once: the handle method, the RPC method and the docs come from its schema.

Checked here: for every goal the handle's method, the server's method and the schema list
the same parameters (names, order, defaults, kinds); the docs tables are the ones the
schemas make; drag's ``speed`` works from Python, JSON-RPC and the Twig line over real
loopback sockets and changes how fast the body is pulled; bad values are refused with
the goal and parameter named, on every path, and leave the world as it was; a plug-in
goal behaviour (one file) gets its method on the handle, over RPC and on the Twig line.
"""

from __future__ import annotations

import inspect
import json
import textwrap
from pathlib import Path

import numpy as np
import pytest
from server_helpers import RawLines, running_server

from twig_ecs import Scene, TwigError
from twig_ecs.arguments import REQUIRED, Param
from twig_ecs.behavior import Behavior
from twig_ecs.character import CharacterHandle
from twig_ecs.client import Client, RemoteError
from twig_ecs.goaldocs import stale
from twig_ecs.goals import GoalSchema, seconds
from twig_ecs.plugins import builtin_goal_schemas, load_builtin_behaviors
from twig_ecs.server.methods import METHODS, find_method
from twig_ecs.server.twigline import parse_line

ROOT = Path(__file__).resolve().parent.parent
SCHEMAS = builtin_goal_schemas()
#: The goals whose names the handle uses for immediate controls: reached with do(name, ...).
CONTROL_NAMES = {"sit", "stand", "gesture"}


def test_every_goal_behaviour_declares_a_schema_and_every_schema_is_a_goal():
    goal_driven = {name for name, cls in load_builtin_behaviors().items() if cls.goal_driven}
    assert goal_driven == {s.name for s in SCHEMAS}
    assert goal_driven >= {"approach", "hug", "grapple", "carry", "drag", "sit", "stand", "freeze", "gesture"}


@pytest.mark.parametrize("schema", SCHEMAS, ids=lambda s: s.name)
def test_handle_method_rpc_method_and_schema_agree(schema):
    expected = [(p.name, p.kind, p.default) for p in schema.params]
    # the RPC method: the character, then the schema's parameters in order, with their kinds
    method = METHODS[schema.name]
    assert method.subject == "character" and method.params[0].name == "character"
    assert [(p.name, p.kind, p.default) for p in method.params[1:]] == expected
    assert [(p.low, p.high, p.choices) for p in method.params[1:]] == [
        (p.low, p.high, p.choices) for p in schema.params
    ]
    # the handle method: a real signature with the same names, order and defaults
    if schema.name in CONTROL_NAMES:
        assert not schema.handle_method
        assert not hasattr(getattr(CharacterHandle, schema.name), "goal_schema"), "the control stays"
        return
    function = getattr(CharacterHandle, schema.name)
    assert function.goal_schema is schema
    signature = inspect.signature(function)
    params = list(signature.parameters.values())
    assert params[0].name == "self" and params[-1].name == "on_end"
    assert params[-1].kind is inspect.Parameter.KEYWORD_ONLY
    got = [(p.name, inspect.Parameter.empty if p.default is REQUIRED else p.default) for p in schema.params]
    assert [(p.name, p.default) for p in params[1:-1]] == got
    assert all(p.name in function.__doc__ for p in schema.params)


def test_drag_has_speed_everywhere():
    drag = next(s for s in SCHEMAS if s.name == "drag")
    assert [p.name for p in drag.params] == ["target", "distance", "hand", "speed"]
    assert "speed" in inspect.signature(CharacterHandle.drag).parameters
    assert "speed" in [p.name for p in METHODS["drag"].params]
    assert parse_line("ann: drag doll 3 left 0.7") == (
        "drag",
        {"character": "ann", "target": "doll", "distance": 3, "hand": "left", "speed": 0.7},
    )


def test_the_committed_docs_tables_are_the_ones_the_schemas_make():
    assert stale(ROOT) == {}, "run: python -m twig_ecs.goaldocs"
    text = (ROOT / "docs" / "characters.md").read_text()
    assert '`drag(target, distance=5.0, hand="right", speed=1.0)`' in text
    assert "`speed` (m/s, 0.1-100; default 1)" in (ROOT / "docs" / "server.md").read_text()


# -- drag's speed changes the motion ------------------------------------------------------------


def drag_for(scenes, speed: float) -> dict:
    """Drag a ragdoll 3 m at ``speed``; how long the pull took and how fast the doll went."""
    scene = Scene.load("empty")
    scenes.append(scene)
    dragger = scene.spawn("humanoid", name="dragger", character=True)
    doll = scene.spawn("ragdoll", name="doll", position=(0.3, 0.1, 1.5))
    scene.run(1.0)
    goal = dragger.drag("doll", 3.0, speed=speed)  # positional and keyword, as any method
    assert goal.params["speed"] == speed
    pulling = 0
    for _ in range(60 * 30):
        scene.step()
        if len(dragger.holding) == 2:  # both hands on its wrists
            if not pulling:
                start = doll.position
            pulling += 1
        if goal.finished:
            break
    assert goal.status == "done", goal.reason
    seconds_pulling = pulling / 60
    moved = float(np.hypot(*(doll.position - start)[[0, 2]]))
    return {"time": seconds_pulling, "doll_speed": moved / seconds_pulling}


def test_drag_speed_from_python_sets_the_pace_of_the_pull(scenes):
    """The dragger steps backwards at the pace asked, up to the most it can (about half a
    metre a second for a grown-up with a doll): the doll comes along at that pace."""
    slow, fast = drag_for(scenes, 0.25), drag_for(scenes, 1.6)
    assert slow["doll_speed"] == pytest.approx(0.25, rel=0.25)
    assert 0.35 < fast["doll_speed"] < 0.8
    assert slow["time"] > 1.5 * fast["time"]


def test_bad_goal_values_from_python_are_refused_and_queue_nothing(scenes):
    scene = Scene.load("empty")
    scenes.append(scene)
    ann = scene.spawn("humanoid", name="ann", character=True)
    scene.spawn("ragdoll", name="doll", position=(0.3, 0.1, 1.5))
    scene.spawn("ball", name="ball", position=(1.0, 0.0, 0.0))
    scene.run(0.2)
    before = scene.state_hash()
    cases = [
        (lambda: ann.drag("doll", speed=500), "drag: 'speed' must be between 0.1 and 100, got 500"),
        (lambda: ann.drag("doll", speed="fast"), "drag: 'speed' must be a number, got 'fast'"),
        (lambda: ann.drag("doll", speed=8.0), "drag: 'speed' 8 m/s is more than 'ann' can do (6 m/s)"),
        (lambda: ann.drag("doll", hand="both"), "drag: 'hand' must be one of left, right; got 'both'"),
        (lambda: ann.hug("ball"), "hug: 'target' must be the name of a character or ragdoll"),
        (lambda: ann.approach([1.0, float("nan"), 0.0]), "approach: 'target[1]' must be a finite number"),
        (lambda: ann.do("freeze", duration=-1), "freeze: 'duration' must be between 0 and 3600"),
        (lambda: ann.do("drag", target="doll", sped=1.0), "drag: unknown parameter(s) 'sped'"),
        (lambda: ann.do("gesture"), "gesture: missing parameter 'name'"),
    ]
    for call, message in cases:
        with pytest.raises(TwigError) as caught:
            call()
        assert message in str(caught.value)
    with pytest.raises(TypeError, match="missing a required argument: 'target'"):
        ann.drag()  # a Python call error, as with any method
    assert ann.goals == [] and scene.state_hash() == before
    goal = ann.drag("doll", speed=0.8)  # and the world still takes a good one
    scene.run(0.5)
    assert ann.behaviour == "drag" and goal.status == "active"


# -- over the server ---------------------------------------------------------------------------


def _step_until_holding(twig: Client, who: str, frames: int = 600) -> dict:
    for _ in range(frames // 30):
        twig.step(n=30)
        state = twig.get_state(name=who)
        if state["holding"]:
            return state
    raise AssertionError(f"'{who}' never got hold of it")


def test_drag_speed_over_json_rpc_and_the_twig_line_moves_the_dragger_at_that_pace():
    with running_server("empty", paused=True, twig=True) as srv, Client(port=srv.port) as twig:
        twig.spawn(name="dragger", template="humanoid", character=True)
        twig.spawn(name="doll", template="ragdoll", position=[0.3, 0.1, 1.5])
        twig.spawn(name="puller", template="humanoid", position=[4.0, 0.0, 0.0], character=True)
        twig.spawn(name="doll2", template="ragdoll", position=[4.3, 0.1, 1.5])
        twig.step(n=60)
        goal = twig.drag(character="dragger", target="doll", distance=3.0, speed=1.4)["goal"]
        with RawLines(srv.twig_port) as raw:
            raw.line(), raw.line()  # the greeting
            raw.send(b"puller: drag doll2 3 right 0.2\n")
            answer = raw.line().decode()
            assert answer.startswith("ok "), answer
            assert json.loads(answer[3:])["behavior"] == "drag"
        _step_until_holding(twig, "dragger")
        _step_until_holding(twig, "puller")
        twig.step(n=30)  # both pulling now
        # each steps backwards at the pace it was given, or as fast as it can step dragging
        before = {who: np.array(twig.get_state(name=who)["position"]) for who in ("dragger", "puller")}
        twig.step(n=90)
        after = {who: np.array(twig.get_state(name=who)["position"]) for who in before}
        pace = {who: float(np.hypot(*(after[who] - before[who])[[0, 2]])) / 1.5 for who in before}
        assert 0.1 < pace["puller"] <= 0.2 * 1.25
        assert pace["dragger"] > 1.3 * pace["puller"]
        for _ in range(20):  # 3 m at 1.4 m/s: about 2 s more (short steps: quick answers without JIT too)
            twig.step(n=30)
            try:
                end = twig.wait_goal(goal, timeout=0.05)
                break
            except TimeoutError:
                end = None
        assert end is not None and end.kind == "goal.done"


def test_bad_goal_values_over_rpc_and_the_twig_line_get_clear_errors_and_leave_the_world_intact():
    with running_server("empty", paused=True, twig=True) as srv, Client(port=srv.port) as twig:
        twig.spawn(name="ann", template="humanoid", character=True)
        twig.spawn(name="doll", template="ragdoll", position=[0.3, 0.1, 1.5])
        twig.step(n=10)
        before = twig.status()["state_hash"]
        bad = [
            ({"speed": 500}, "'speed' must be between 0.1 and 100, got 500"),
            ({"speed": "fast"}, "'speed' must be a number, got 'fast'"),
            ({"speed": 8.0}, "drag: 'speed' 8 m/s is more than 'ann' can do (6 m/s)"),
            ({"hand": "both"}, "'hand' must be one of left, right; got 'both'"),
            ({"sped": 1}, "drag: unknown parameter(s) 'sped'"),
        ]
        for extra, message in bad:
            with pytest.raises(RemoteError) as caught:
                twig.drag(character="ann", target="doll", **extra)
            assert caught.value.code == -32602 and message in caught.value.message
        with pytest.raises(RemoteError, match="drag: 'speed' must be between 0.1 and 100"):
            twig.do(character="ann", behavior="drag", params={"target": "doll", "speed": 0})
        with RawLines(srv.twig_port) as raw:
            raw.line(), raw.line()
            raw.send(b"ann: drag doll speed=fast\n")
            assert raw.line().decode() == "error -32602 'speed' must be a number, got 'fast'"
        state = twig.get_state(name="ann")
        assert state["goals"] == [] and twig.status()["state_hash"] == before
        assert twig.drag(character="ann", target="doll", speed=0.9)["behavior"] == "drag"


# -- a plug-in goal behaviour: one file ---------------------------------------------------------

BOW = '''
"""bow: look at the ground a step ahead for a while (a plug-in goal behaviour)."""

from twig_ecs.behavior import Behavior
from twig_ecs.goals import GoalSchema, Param, seconds


class Bow(Behavior):
    """Look down in front of the feet, then up again."""

    schema = GoalSchema(
        "bow",
        "Look at the ground `ahead` m in front for `duration` s.",
        (
            seconds("duration", 1.0, "how long to look down"),
            Param("ahead", "number", 0.8, low=0.2, high=3.0, unit="m", doc="how far ahead to look"),
        ),
    )

    def act(self, character, mind, goal, dt):
        ahead = goal.params["ahead"]
        character.look_at(tuple(character.position * [1, 0, 1] + character.facing * ahead))
        goal.memory["t"] = goal.memory.get("t", 0.0) + dt
        if goal.memory["t"] >= goal.params["duration"]:
            self.finish(character, goal)

    def stop(self, character, goal):
        character.look_at(None)
'''

BOW_SCENE = """\
twig: 1
name: bowing
systems:
  - use: bow.py:Bow
entities:
  - name: ann
    body: humanoid
    character: true
"""


@pytest.fixture
def bow_scene(tmp_path) -> Path:
    (tmp_path / "bow.py").write_text(textwrap.dedent(BOW))
    path = tmp_path / "bowing.yaml"
    path.write_text(BOW_SCENE)
    return path


def test_a_plug_in_goal_gets_a_handle_method_from_its_schema(scenes, bow_scene):
    scene = Scene.load(bow_scene, trust=True)
    scenes.append(scene)
    ann = scene.entity("ann")
    assert list(inspect.signature(ann.bow).parameters) == ["duration", "ahead", "on_end"]
    ended = []
    goal = ann.bow(0.5, on_end=ended.append)
    assert goal.params == {"duration": 0.5, "ahead": 0.8}
    scene.run(0.3)
    assert ann.behaviour == "bow" and ann.gaze_target is not None
    assert ann.gaze_target[1] == pytest.approx(0.0) and ann.head_direction[1] < -0.1, "it looks down"
    scene.run(0.5)
    assert ended == [goal] and goal.status == "done"
    with pytest.raises(TwigError, match="bow: 'ahead' must be between 0.2 and 3"):
        ann.bow(ahead=9.0)
    assert find_method("bow") is None, "not a built-in method"
    assert [p.name for p in find_method("bow", scene).params] == ["character", "duration", "ahead"]


def test_a_plug_in_goal_is_an_rpc_method_and_a_twig_line_command(bow_scene):
    served = running_server(str(bow_scene), paused=True, twig=True, trust=True)
    with served as srv, Client(port=srv.port) as twig:
        schemas = {s["name"]: s for s in twig.goal_schemas()}
        assert {"bow", "drag", "hug"} <= set(schemas)
        assert [p["name"] for p in schemas["bow"]["params"]] == ["duration", "ahead"]
        assert schemas["drag"]["params"][3] == {"name": "speed", "kind": "number", "required": False,
                                               "default": 1.0, "low": 0.1, "high": 100.0, "unit": "m/s",
                                               "doc": "the walking pace while pulling"}  # fmt: skip
        goal = twig.bow(character="ann", duration=0.25)["goal"]
        with pytest.raises(RemoteError, match="'ahead' must be between 0.2 and 3, got 9"):
            twig.bow(character="ann", ahead=9)
        with RawLines(srv.twig_port) as raw:
            raw.line(), raw.line()
            raw.send(b"ann: bow 0.25 1.5\n")
            assert raw.line().decode().startswith("ok {")
        twig.step(n=120)
        end = twig.wait_goal(goal, timeout=5)
        assert end is not None and end.kind == "goal.done"


def test_a_schema_never_replaces_an_immediate_control_and_the_name_is_given_once():
    walk = CharacterHandle.walk

    class WalkGoal(Behavior):
        schema = GoalSchema(
            "walk", "A goal that shares the name of a control.", (seconds("duration", 1.0, "x"),)
        )

    assert WalkGoal.name == "walk" and WalkGoal.goal_driven
    assert CharacterHandle.walk is walk, "the immediate control stays; the goal is do('walk', ...)"
    with pytest.raises(TwigError, match="name 'shuffle' differs from its schema's 'shamble'"):

        class Shuffle(Behavior):  # defining it is the test
            name = "shuffle"
            schema = GoalSchema("shamble", "Two names for one goal.")

    with pytest.raises(TwigError, match="Stride: params: a goal's parameters are declared in its schema"):

        class Stride(Behavior):  # the way goals were declared before schemas
            params = {"target": None}
            goal_driven = True

    with pytest.raises(ValueError, match="'on_end' is the handle's callback"):
        GoalSchema("x", "x", (Param("on_end", "bool", False),))
    with pytest.raises(ValueError, match="has kind 'color'"):
        GoalSchema("x", "x", (Param("tint", "color", None),))


# -- character keys: listed once -------------------------------------------------------------


def test_character_keys_are_listed_once_and_documented(tmp_path):
    from twig_ecs import character, scenefile

    assert scenefile.CHARACTER_KEYS is character.CHARACTER_KEYS
    assert character.CHARACTER_KEYS == ("max_speed", *character.START_COMMANDS)
    text = (ROOT / "docs" / "characters.md").read_text()
    example = text[text.index("## In a scene file") : text.index("## How the controllers work")]
    for key in character.CHARACTER_KEYS:
        assert f"{key}:" in example, f"docs/characters.md's scene example lacks '{key}'"
    # a start command that names an entity is checked against the file's entities
    path = tmp_path / "pointing.yaml"
    path.write_text("twig: 1\nentities:\n  - {name: ann, body: humanoid, character: {point_at: bal}}\n"
                    "  - {name: ball, body: ball, position: [1, 0, 1]}\n")  # fmt: skip
    with pytest.raises(TwigError, match=r"point_at: unknown entity 'bal' \(did you mean 'ball'\?\)"):
        Scene.load(path)


def test_a_goal_behaviour_without_a_schema_is_refused_with_the_reason(scenes):
    class Shrug(Behavior):
        name = "shrug"
        goal_driven = True

    scene = Scene.load("empty")
    scenes.append(scene)
    scene.add_system(Shrug(), after="sense", before="select_behavior")
    ann = scene.spawn("humanoid", name="ann", character=True)
    with pytest.raises(TwigError, match=r"goal behaviour 'shrug' \(Shrug\) declares no schema"):
        ann.do("shrug")
    assert ann.goals == []
