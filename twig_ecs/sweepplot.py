"""A sweep's answer as a picture: for each value of one swept name, the share of runs in
which a figure was above zero (the chance of a hug within the run, say), with the runs'
mean figure written over each bar."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from twig_ecs.chart import canvas
from twig_ecs.errors import TwigError


def chance_by_value(rows: Sequence[dict], name: str, metric: str) -> list[tuple[str, float, float, int]]:
    """Per value of ``name`` (in the order met): (value, share of runs with ``metric`` > 0,
    its mean, runs counted). Runs that failed or lack the figure are left out."""
    groups: dict[str, list[float]] = {}
    for row in rows:
        value = row.get(metric)
        if row.get("error") or value in (None, ""):
            continue
        groups.setdefault(str(row.get(name)), []).append(float(value))
    return [(key, sum(v > 0 for v in vs) / len(vs), sum(vs) / len(vs), len(vs)) for key, vs in groups.items()]


def plot_chance(rows: Sequence[dict], name: str, metric: str, path: str | Path,
                size: tuple[int, int] = (900, 500)) -> Path:  # fmt: skip
    """Bars of :func:`chance_by_value` as a PNG at ``path``."""
    bars = chance_by_value(rows, name, metric)
    if not bars:
        raise TwigError(f"no finished run reported '{metric}': nothing to plot")
    width, height = size
    image, draw, title_font, font = canvas(size)
    left, right, top, bottom = 70, width - 30, 60, height - 60
    draw.text((left, 18), f"share of runs with {metric} > 0, by {name}", fill=(0, 0, 0), font=title_font)
    draw.rectangle((left, top, right, bottom), outline=(120, 120, 120))
    for tick in (0.0, 0.25, 0.5, 0.75, 1.0):
        y = bottom - (bottom - top) * tick
        draw.line((left - 5, y, left, y), fill=(120, 120, 120))
        draw.text((left - 45, y - 7), f"{tick:.0%}", fill=(60, 60, 60), font=font)
    slot = (right - left) / len(bars)
    for k, (value, share, mean, runs) in enumerate(bars):
        x0, x1 = left + slot * (k + 0.2), left + slot * (k + 0.8)
        y = bottom - (bottom - top) * share
        draw.rectangle((x0, y, x1, bottom), fill=(90, 140, 200))
        draw.text((x0, max(top, y - 34)), f"{share:.0%} of {runs}", fill=(0, 0, 0), font=font)
        draw.text((x0, max(top, y - 18)), f"mean {mean:.2g}", fill=(60, 60, 60), font=font)
        draw.text(((x0 + x1) / 2 - 10, bottom + 8), value, fill=(0, 0, 0), font=font)
    draw.text((left, bottom + 30), name, fill=(60, 60, 60), font=font)
    image.save(path)
    return Path(path)
