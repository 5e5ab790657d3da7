"""The docs' close-up commands show what they say: the characters, filling part of the picture.

Every ``twig render ... --at ...`` command in the README, ARCHITECTURE.md and docs/ (inline
or in a code block) is read from the Markdown, so the docs and this test cannot drift
apart, and run through the command line as a user would, in an empty folder. The picture
it writes is then looked at by colour: each pixel goes to the body whose colour (as the
scene gives it, lit) it is nearest in chromaticity, or to none. The entities the command
says it framed must each show, and its characters together must cover
:data:`MIN_CHARACTERS` of the frame. (These commands used to name fixed times and camera
positions that drifted with behaviour: three of them showed bare ground or legs, 0-2%.)
"""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from twig_ecs import Scene
from twig_ecs.cli import build_parser, main
from twig_ecs.graphics.renderer import SKY, ground_colour
from twig_ecs.store import LINK_VISIBLE, NODE_SPHERE

ROOT = Path(__file__).resolve().parent.parent
DOCS = [ROOT / "README.md", ROOT / "ARCHITECTURE.md", *sorted((ROOT / "docs").glob("*.md"))]
INLINE = re.compile(r"`(twig render [^`]*)`")
FENCED = re.compile(r"```[^\n]*\n(.*?)```", re.S)
#: The characters a close-up names cover at least this share of the picture together. A
#: 1.35 m child alone, as tall as a 16:9 picture, covers about 5% of it (thin limbs, sky
#: and ground round them); the docs' close-ups measure 4.5-7.8% (the kick 4.5%).
MIN_CHARACTERS = 0.04
#: Each character named covers at least this share; a thing named (a ball, a ride's bar)
#: this much less.
MIN_CHARACTER = 0.01
MIN_THING = 0.0005
#: A pixel this far from every reference colour (in chromaticity) belongs to no body.
CHROMA_TOLERANCE = 0.03


def closeup_commands() -> list[str]:
    """Every ``twig render`` command with ``--at`` in the docs, each once, in reading order."""
    found: list[str] = []
    for doc in DOCS:
        text = doc.read_text(encoding="utf-8")
        lines = [line.split("#")[0].strip() for block in FENCED.findall(text) for line in block.splitlines()]
        for command in [*INLINE.findall(text), *lines]:
            if command.startswith("twig render") and " --at " in f" {command} " and command not in found:
                found.append(command)
    return found


def test_the_docs_show_a_close_up_of_each_interaction():
    kinds = {build_parser().parse_args(shlex.split(c)[1:]).at.split(":")[0] for c in closeup_commands()}
    assert {"kick", "push", "hug", "scuffle"} <= kinds


def body_colours(scene_name: str, seed: int) -> tuple[np.ndarray, list[str], set[str]]:
    """Reference colours: every colour a body is drawn in (with the body's name), the sky and
    the ground; and the names of the scene's characters."""
    refs, owners = [SKY, ground_colour()], ["sky", "ground"]
    with Scene.load(scene_name, seed=seed) as scene:
        st = scene.state
        lk, n = st.links, st.nodes
        for name in scene.entity_names:
            body = scene.entity(name).body.index
            drawn = (lk.body[: lk.count] == body) & ((lk.flags[: lk.count] & LINK_VISIBLE) != 0)
            spheres = (n.body[: n.count] == body) & ((n.flags[: n.count] & NODE_SPHERE) != 0)
            colours = {tuple(c[:3]) for c in lk.color[: lk.count][drawn]} | {
                tuple(c[:3]) for c in n.color[: n.count][spheres]
            }
            refs += sorted(colours)
            owners += [name] * len(colours)
        characters = {name for name in scene.entity_names if hasattr(scene.entity(name), "holding")}
    return np.array(refs, dtype=np.float64), owners, characters


def chromaticity(rgb: np.ndarray) -> np.ndarray:
    rgb = np.asarray(rgb, dtype=np.float64)
    return rgb / np.maximum(rgb.sum(axis=-1, keepdims=True), 1e-6)


def shares_by_body(image: Image.Image, refs: np.ndarray, owners: list[str]) -> dict[str, float]:
    """The share of the picture's pixels that each body (or the sky, the ground) is drawn in."""
    rgb = np.asarray(image.convert("RGB")).reshape(-1, 3).astype(np.int32)
    # Each colour drawn once, with how many pixels have it (a 1280x720 picture has some 20 000
    # colours in its 921 600 pixels): a pixel's nearest reference is that of its colour.
    packed, counts = np.unique((rgb[:, 0] << 16) | (rgb[:, 1] << 8) | rgb[:, 2], return_counts=True)
    colours = np.stack([packed >> 16, (packed >> 8) & 0xFF, packed & 0xFF], axis=1)
    pixels = chromaticity(colours.astype(np.float64) / 255.0)
    gaps = np.linalg.norm(pixels[:, None, :] - chromaticity(refs)[None], axis=2)
    nearest, close = gaps.argmin(axis=1), gaps.min(axis=1) < CHROMA_TOLERANCE
    out: dict[str, float] = {}
    for k, owner in enumerate(owners):
        out[owner] = out.get(owner, 0.0) + float(counts[close & (nearest == k)].sum() / len(rgb))
    return out


COMMANDS = closeup_commands()


def _name(command: str) -> str:
    args = build_parser().parse_args(shlex.split(command)[1:])
    return f"{args.at}-{Path(args.output).name}"


@pytest.mark.long  # each runs the schoolyard to its moment: 1-5 s
@pytest.mark.parametrize("command", COMMANDS, ids=[_name(c) for c in COMMANDS])
def test_a_docs_close_up_shows_the_characters_it_names(command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # the command writes where a user running it would
    argv = shlex.split(command)[1:]
    args = build_parser().parse_args(argv)

    assert main(argv) == 0, capsys.readouterr().err
    said = capsys.readouterr().out
    found = re.search(r"^\w+ \d+ at [\d.]+ s: (.+?) \(camera", said, re.M)
    assert found, f"'{command}' did not say what it framed:\n{said}"
    names = found.group(1).split(" and ")

    refs, owners, characters = body_colours(args.scene, args.seed)
    with Image.open(tmp_path / args.output) as picture:
        picture.seek(0)  # a clip: its first frame, the moment itself
        shares = shares_by_body(picture, refs, owners)
    shown = {name: round(shares.get(name, 0.0), 4) for name in names}
    for name in names:
        least = MIN_CHARACTER if name in characters else MIN_THING
        assert shares.get(name, 0.0) >= least, f"{name} is not in view: {shown}"
    assert sum(shares.get(name, 0.0) for name in names if name in characters) >= MIN_CHARACTERS, shown
