"""Reading files a user names, with a size cap: scenes, templates, replays, snapshots.

A path may lead anywhere: a link to ``/dev/zero`` or ``/dev/urandom`` never ends, a FIFO
blocks until someone writes to it, a huge file fills memory. :func:`read_bounded` opens
without blocking, refuses anything but a regular file and reads at most its cap, so
every reader of user files fails at once with a message instead.

This module is core: it imports nothing above errors.
"""

from __future__ import annotations

import os
import stat
from collections.abc import Callable
from pathlib import Path

from twig_ecs.errors import TwigError


class FileReadError(TwigError):
    """A file that cannot be read: missing, not a regular file, or over its size cap."""


def read_bounded(path: str | Path, limit: int, what: str = "file",
                 error: Callable[[str], Exception] = FileReadError) -> bytes:  # fmt: skip
    """The bytes of the regular file ``path``, at most ``limit`` of them.

    Raises ``error(message)`` (a :class:`FileReadError` unless told otherwise) when the
    file cannot be opened, is not a regular file (a device such as ``/dev/zero``, a FIFO,
    a folder) or holds more than ``limit`` bytes. ``what`` names the file in the message
    (``"scene file"``, ``"replay file"``).
    """
    try:
        # O_NONBLOCK: opening a FIFO for reading would otherwise wait for a writer
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except OSError as exc:
        raise error(f"cannot read {what} '{path}': {exc.strerror}") from None
    try:
        info = os.fstat(fd)
    except OSError as exc:
        os.close(fd)
        raise error(f"cannot read {what} '{path}': {exc.strerror}") from None
    if not stat.S_ISREG(info.st_mode):
        os.close(fd)
        raise error(f"cannot read {what} '{path}': not a regular file (a device, pipe or folder)")
    if info.st_size > limit:
        os.close(fd)
        raise error(f"{what} '{path}' is too large: {info.st_size} bytes, at most {_size(limit)}")
    with os.fdopen(fd, "rb", buffering=0) as f:
        chunks, total = [], 0
        while total <= limit:  # the size may change while it is read: never past limit + 1
            try:
                chunk = f.read(min(limit + 1 - total, 1 << 20))
            except OSError as exc:
                raise error(f"cannot read {what} '{path}': {exc.strerror}") from None
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
    if total > limit:
        raise error(f"{what} '{path}' is too large: over {_size(limit)}")
    return b"".join(chunks)


def read_text_bounded(path: str | Path, limit: int, what: str = "file",
                      error: Callable[[str], Exception] = FileReadError) -> str:  # fmt: skip
    """:func:`read_bounded`, decoded as UTF-8 (``error`` too when it is not UTF-8 text)."""
    data = read_bounded(path, limit, what, error)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise error(f"{what} '{path}' is not UTF-8 text (bad byte at offset {exc.start})") from None


def _size(limit: int) -> str:
    """``limit`` bytes in words: ``1 MiB``, ``64 KiB``, ``100 bytes``."""
    for unit, scale in (("GiB", 1 << 30), ("MiB", 1 << 20), ("KiB", 1 << 10)):
        if limit >= scale and limit % scale == 0:
            return f"{limit // scale} {unit}"
    return f"{limit} bytes"
