"""argparse types shared by the ``twig`` subcommands (the core CLI, play/render, serve)."""

from __future__ import annotations

import argparse

from twig_ecs.validate import seed


def seconds_number(text: str) -> float:
    """An argparse type: a number of seconds (the command checks its range)."""
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"expected a number of seconds (like 10 or 2.5), got '{text}'"
        ) from None  # noqa: E501


def positive_seconds(text: str) -> float:
    """An argparse type: seconds, a number > 0 and at most a day."""
    value = seconds_number(text)
    if not 0 < value <= 86400:
        raise argparse.ArgumentTypeError(f"seconds must be > 0 and at most 86400, got {text}")
    return value


def seed_number(text: str) -> int:
    """An argparse type: a random seed, a whole number from 0 to 2**63 - 1."""
    try:
        value = int(text)
    except ValueError:
        message = f"expected a whole number (like 0 or 42), got '{text[:40]}'"
        raise argparse.ArgumentTypeError(message) from None
    try:
        return seed(value)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(f"{exc}, got {text[:40]}") from None
