"""The inspector's "write to scene file": values go where their path says, or nowhere.

Each test writes into a small scene file and then reads it as the loader does: the value
asked is in the right behaviour item, everything else in the file is as it was (comments
and layout included), and a value that cannot be placed leaves the file byte for byte
unchanged with a message saying what and why (issue 31).
"""

from __future__ import annotations

import os
import stat

import pytest

from twig_ecs import Scene
from twig_ecs.graphics import tuning
from twig_ecs.graphics.inspector_ui import write_moved
from twig_ecs.graphics.scene_writeback import WriteBackError, write_parameters
from twig_ecs.library import ContentLibrary
from twig_ecs.scenefile import read_scene

HEAD = """\
twig: 1
name: writeback
parameters:
  pace: {default: 1.5, min: 0.1, max: 5}
entities:
  - name: ball
    body: ball
    position: [0, 0.2, 3]
"""


def scene_file(tmp_path, entities: str, name: str = "scene.yaml"):
    """A scene file holding the ball and then ``entities`` (YAML items of ``entities:``)."""
    path = tmp_path / name
    path.write_bytes((HEAD + entities).encode("utf-8"))
    return path


def behaviour(path, entity: str, name: str):
    """The component of behaviour ``name`` of ``entity`` as the scene loader reads the file."""
    plan = read_scene(path, ContentLibrary())
    spec = next(e for e in plan.entities if e.name == entity)
    found = [b.component for b in spec.behaviors if b.name == name]
    assert len(found) == 1, found
    return found[0]


# -- the three attacks of issue 31 ---------------------------------------------------------------


def test_play_speed_goes_into_the_play_item_not_into_wander_on_the_same_line(tmp_path):
    path = scene_file(tmp_path, """\
  - name: kid
    body: humanoid
    character: true
    behaviors: [{use: wander, speed: 1.0}, {use: play, toy: ball, speed: 1.6}]  # both run
""")  # fmt: skip
    before = path.read_text()
    assert write_parameters(path, {("kid", "play", "speed"): 2.25}) == 1
    assert behaviour(path, "kid", "play").speed == 2.25
    assert behaviour(path, "kid", "wander").speed == 1.0
    assert path.read_text() == before.replace("speed: 1.6", "speed: 2.25")


def test_a_new_key_goes_into_its_own_flow_item_not_the_last_braces_on_the_line(tmp_path):
    path = scene_file(tmp_path, """\
  - name: merry_go_round
    body: merry_go_round
    position: [4, 0, 0]
  - name: kid
    body: humanoid
    character: true
    behaviors: [{use: play, toy: ball}, {use: ride, ride: merry_go_round}]
""")  # fmt: skip
    assert write_parameters(path, {("kid", "play", "joy"): 0.75}) == 1
    assert behaviour(path, "kid", "play").joy == 0.75  # the scene loads: ride got no 'joy'
    assert "{use: play, joy: 0.75, toy: ball}, {use: ride, ride: merry_go_round}" in path.read_text()


def test_a_new_key_is_not_written_into_a_comment_that_holds_a_brace(tmp_path):
    path = scene_file(tmp_path, """\
  - name: kid
    body: humanoid
    character: true
    behaviors:
      - use: play          # likes {balls}, not {sticks}
        toy: ball
""")  # fmt: skip
    before = path.read_text()
    assert write_parameters(path, {("kid", "play", "joy"): 0.8}) == 1
    assert behaviour(path, "kid", "play").joy == 0.8  # not lost in the comment
    after = path.read_text()
    assert "# likes {balls}, not {sticks}\n" in after
    assert after == before.replace("not {sticks}\n", "not {sticks}\n        joy: 0.8\n")


# -- block and flow style, nesting, comments -----------------------------------------------------


def test_block_items_change_only_their_numbers_and_comments_keep_their_column(tmp_path):
    path = scene_file(tmp_path, """\
  - name: parent
    body: humanoid
    character: true
  # the child frets when the parent is far
  - name: kid
    body: humanoid
    height: 1.1
    character: true
    behaviors:
      - use: attachment
        caregiver: parent
        safe_distance: 2.5           # m: closer than this anxiety fades
        per_metre: 0.012             # anxiety per second per metre beyond it
      -   use: play      # odd indentation, kept
          speed: 1.6
""")  # fmt: skip
    before = path.read_text()
    values = {("kid", "attachment", "safe_distance"): 0.0, ("kid", "attachment", "per_metre"): 0.0125,
              ("kid", "play", "speed"): 3.0}  # fmt: skip
    assert write_parameters(path, values) == 3
    after = path.read_text()
    assert after == (
        before.replace("safe_distance: 2.5           #", "safe_distance: 0             #")
        .replace("per_metre: 0.012             #", "per_metre: 0.0125            #")
        .replace("speed: 1.6", "speed: 3")
    )
    assert behaviour(path, "kid", "attachment").safe_distance == 0.0
    assert behaviour(path, "kid", "attachment").per_metre == 0.0125
    assert behaviour(path, "kid", "play").speed == 3.0


def test_a_flow_item_over_several_lines_with_comments_gains_a_key_after_use(tmp_path):
    path = scene_file(tmp_path, """\
  - name: kid
    body: humanoid
    character: true
    behaviors: [
      {use: play,   # the ball game {not fights}
       toy: ball,
      },
    ]
""")  # fmt: skip
    before = path.read_text()
    assert write_parameters(path, {("kid", "play", "speed"): 1.25}) == 1
    assert behaviour(path, "kid", "play").speed == 1.25
    assert path.read_text() == before.replace("{use: play,", "{use: play, speed: 1.25,")


def test_a_nested_character_mapping_keeps_its_own_speed(tmp_path):
    """``character: {patrol: {speed}}`` and ``play.speed`` share a key name, not a place."""
    path = scene_file(tmp_path, """\
  - name: kid
    body: humanoid
    character:
      max_speed: 4.0
      patrol: {route: [[0, 0], [2, 0], [2, 2]], speed: 1.0}   # a round of the yard
    behaviors:
      - {use: wander, radius: 3.0, speed: 0.8}
      - use: play
        toy: ball
  - name: kid2
    body: humanoid
    character: {patrol: {route: [[1, 1], [3, 1]], speed: 0.7}}
    behaviors: [{use: play, toy: ball, speed: 1.1}]
""")  # fmt: skip
    values = {("kid", "play", "speed"): 2.5, ("kid2", "play", "speed"): 1.9, ("kid", "wander", "speed"): 0.9}
    assert write_parameters(path, values) == 3
    text = path.read_text()
    assert "patrol: {route: [[0, 0], [2, 0], [2, 2]], speed: 1.0}   # a round of the yard" in text
    assert "character: {patrol: {route: [[1, 1], [3, 1]], speed: 0.7}}" in text
    assert "      - use: play\n        speed: 2.5\n        toy: ball\n" in text
    assert behaviour(path, "kid", "play").speed == 2.5
    assert behaviour(path, "kid", "wander").speed == 0.9
    assert behaviour(path, "kid2", "play").speed == 1.9
    plan = read_scene(path, ContentLibrary())
    assert {e.name: e.character.start["patrol"]["speed"] for e in plan.entities if e.character} == {
        "kid": 1.0,
        "kid2": 0.7,
    }


def test_windows_line_endings_and_a_missing_last_newline_are_kept(tmp_path):
    text = (HEAD + "  - name: kid\n    body: humanoid\n    character: true\n    behaviors:\n"
            "      - use: play").replace("\n", "\r\n")  # fmt: skip
    path = tmp_path / "crlf.yaml"
    path.write_bytes(text.encode())
    assert write_parameters(path, {("kid", "play", "joy"): 0.25}) == 1
    assert path.read_bytes().decode() == text + "\r\n        joy: 0.25"
    assert behaviour(path, "kid", "play").joy == 0.25


# -- refusals: the file stays as it was ----------------------------------------------------------

KID_WITH_PLAY = """\
  - name: kid
    body: humanoid
    character: true
    behaviors: [{use: play, toy: ball, speed: 1.6}]
"""

REFUSED = {
    "a formula of the scene's parameters": (
        KID_WITH_PLAY.replace("speed: 1.6", "speed: $(pace * 2)"),
        ("kid", "play", "speed"),
        "'$(pace * 2)' is a formula",
    ),
    "a value shared through an anchor": (
        KID_WITH_PLAY.replace("speed: 1.6", "speed: &fast 1.6")
        + "  - name: kid2\n    body: humanoid\n    character: true\n"
        "    behaviors: [{use: play, toy: ball, speed: *fast}]\n",
        ("kid2", "play", "speed"),
        "anchor",
    ),
    "a behaviour list shared by two characters": (
        KID_WITH_PLAY.replace("behaviors: [", "behaviors: &games [")
        + "  - name: kid2\n    body: humanoid\n    character: true\n    behaviors: *games\n",
        ("kid", "play", "joy"),
        "used in 2 places",
    ),
    "one copy of a repeated entity": (
        KID_WITH_PLAY + "    repeat: {count: 3, spacing: 2}\n",
        ("kid1", "play", "speed"),
        "one of the 3 copies",
    ),
    "an entity spawned while playing": (KID_WITH_PLAY, ("visitor", "play", "speed"), "no entity 'visitor'"),
    "a behaviour the file does not give": (KID_WITH_PLAY, ("kid", "wander", "speed"), "no 'wander' item"),
    "a number the loader refuses (beyond 1e6)": (KID_WITH_PLAY, ("kid", "play", "speed"), "would not load"),
    "not a number": (KID_WITH_PLAY, ("kid", "play", "speed"), "not a finite number"),
}
ASKED = {"a number the loader refuses (beyond 1e6)": 2e6, "not a number": float("nan")}


@pytest.mark.parametrize("case", list(REFUSED))
def test_a_value_that_cannot_be_placed_is_refused_and_the_file_is_unchanged(tmp_path, case):
    entities, key, why = REFUSED[case]
    path = scene_file(tmp_path, entities)
    before = path.read_bytes()
    read_scene(path, ContentLibrary())  # a good scene to start with
    with pytest.raises(WriteBackError, match="unchanged") as refused:
        write_parameters(path, {key: ASKED.get(case, 2.0)})
    assert why in str(refused.value)
    assert f"{key[0]}: {key[1]}.{key[2]}" in str(refused.value)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scene.yaml"]  # no temporary file left


def test_one_value_that_cannot_be_placed_stops_all_of_them(tmp_path):
    path = scene_file(tmp_path, KID_WITH_PLAY)
    before = path.read_bytes()
    with pytest.raises(WriteBackError) as refused:
        write_parameters(path, {("kid", "play", "speed"): 2.0, ("kid", "play", "joy"): float("inf")})
    assert "1 of 2" in str(refused.value) and "kid: play.joy" in str(refused.value)
    assert path.read_bytes() == before


def test_the_file_keeps_its_permissions_and_a_link_stays_a_link(tmp_path):
    real = scene_file(tmp_path, KID_WITH_PLAY, name="real.yaml")
    os.chmod(real, 0o640)
    link = tmp_path / "scene.yaml"
    link.symlink_to(real.name)
    assert write_parameters(link, {("kid", "play", "speed"): 2.0}) == 1
    assert link.is_symlink() and behaviour(real, "kid", "play").speed == 2.0
    assert stat.S_IMODE(real.stat().st_mode) == 0o640
    assert sorted(p.name for p in tmp_path.iterdir()) == ["real.yaml", "scene.yaml"]


# -- the inspector's own writer ------------------------------------------------------------------


def test_the_inspector_writes_a_moved_slider_and_the_reloaded_scene_has_it(tmp_path, scenes):
    path = scene_file(tmp_path, """\
  - name: kid
    body: humanoid
    character: true
    behaviors: [{use: wander, speed: 1.0}, {use: play, toy: ball, speed: 1.6}]  # one line
""")  # fmt: skip
    scene = Scene.load(str(path))
    scenes.append(scene)
    tunables = tuning.find_tunables(scene)
    slider = next(t for t in tunables if t.key == ("kid", "play", "speed"))
    slider.value = 2.3400001525878906  # what a float32 slider hands back for 2.34
    message = write_moved(scene, tunables)
    assert message.startswith("wrote 1 parameter to scene.yaml"), message
    assert slider.value == slider.initial == 2.34  # the running scene holds what the file says
    assert "{use: wander, speed: 1.0}, {use: play, toy: ball, speed: 2.34}" in path.read_text()
    assert write_moved(scene, tunables) == "no parameter moved: nothing to write"

    reloaded = Scene.load(str(path))
    scenes.append(reloaded)
    kid = reloaded.entity("kid").entity
    assert reloaded.world.component_for_entity(kid, type(slider.component)).speed == 2.34
    wander = next(t for t in tuning.find_tunables(reloaded) if t.key == ("kid", "wander", "speed"))
    assert wander.value == 1.0


def test_the_inspector_says_what_it_could_not_write_and_why(tmp_path, scenes):
    path = scene_file(tmp_path, KID_WITH_PLAY.replace("speed: 1.6", "speed: $pace"))
    scene = Scene.load(str(path))
    scenes.append(scene)
    before = path.read_bytes()
    tunables = tuning.find_tunables(scene)
    slider = next(t for t in tunables if t.key == ("kid", "play", "speed"))
    slider.value = 2.0
    message = write_moved(scene, tunables)
    assert message.startswith("not written (scene.yaml unchanged)"), message
    assert "kid: play.speed" in message and "'$pace' is a formula" in message
    assert path.read_bytes() == before
    assert slider.initial == 1.5  # still moved: a later write may try again
