"""The window's text panels (twig_ecs/graphics/overlay.py): long lines wrap where a line-by-line
search for the cut would put it, with a handful of text measurements per break, not one per
character (the window tests drew 44 000 of them)."""

from __future__ import annotations

import random

from twig_ecs.graphics.overlay import _wrap, font


def wrap_by_scanning(lines, f, width):
    """The cut found by shortening the line one character at a time (the wrap as first written)."""
    out = []
    for line in lines:
        while line and f.getbbox(line)[2] > width:
            cut = len(line)
            while cut > 1 and f.getbbox(line[:cut])[2] > width:
                cut -= 1
            space = line.rfind(" ", 0, cut)
            cut = space if space > cut // 2 else cut
            out.append(line[:cut].rstrip())
            line = "    " + line[cut:].lstrip()
        out.append(line)
    return out


def random_lines(rng: random.Random, count: int) -> list[str]:
    words = ["pelvis", "approach", "1.35", "m/s", "stuck", "-0.002", "hug", "(left)", "x" * 30, "", "WWW"]
    return [" ".join(rng.choice(words) for _ in range(rng.randint(0, 20))) for _ in range(count)]


def test_long_lines_wrap_where_scanning_for_the_cut_puts_it():
    rng = random.Random(7)
    for size in (9, 14):
        f = font(size)
        for width in (12 * f.getbbox("M")[2], 517):
            lines = random_lines(rng, 6)
            assert _wrap(lines, f, width) == wrap_by_scanning(lines, f, width), (size, width)


def test_a_break_takes_a_handful_of_measurements():
    f = font(10)
    measured = []

    class Counting:
        def getbbox(self, text):
            measured.append(text)
            return f.getbbox(text)

    line = "status: " + " ".join(f"word{k}" for k in range(80))  # about 560 characters
    wrapped = _wrap([line], Counting(), 200)
    breaks = len(wrapped) - 1
    assert breaks >= 10
    assert len(measured) < 12 * (breaks + 1), f"{len(measured)} measurements for {breaks} breaks"
