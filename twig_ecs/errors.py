"""Errors a user can cause, with messages written for a person."""

from __future__ import annotations


class TwigError(Exception):
    """Base class of every error caused by input (files, names, parameters, commands)."""


class SceneError(TwigError):
    """Bad scene or template content; says file:line and the path inside the document."""

    def __init__(
        self, message: str, file: str | None = None, line: int | None = None, path: str = ""
    ) -> None:
        self.message = message
        self.file = file
        self.line = line
        self.path = path
        where = ""
        if file:
            where = f"{file}:{line}: " if line else f"{file}: "
        inside = f"{path}: " if path else ""
        super().__init__(f"{where}{inside}{message}")


class ScheduleError(TwigError):
    """A system order that cannot be satisfied (unknown stage name, or a cycle)."""
