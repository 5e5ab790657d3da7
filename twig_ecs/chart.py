"""A blank chart to draw on with Pillow: the background, a title font and a label font."""

from __future__ import annotations

from typing import Any

#: The charts' paper colour.
PAPER = (250, 250, 247)


def canvas(size: tuple[int, int]) -> tuple[Any, Any, Any, Any]:
    """(image, draw, title font, label font) for a chart of ``size`` pixels."""
    from PIL import Image, ImageDraw, ImageFont

    image = Image.new("RGB", size, PAPER)
    draw = ImageDraw.Draw(image)
    try:
        title_font, label_font = ImageFont.load_default(size=18), ImageFont.load_default(size=13)
    except TypeError:  # Pillow < 10.1: one small bitmap font
        title_font = label_font = ImageFont.load_default()
    return image, draw, title_font, label_font
