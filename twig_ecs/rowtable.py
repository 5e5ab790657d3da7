"""A behaviour's working state as a table: one row per goal (or entity) it is on, numpy columns.

A batch behaviour moves all its characters with one kernel call over arrays; the arrays
come from per-goal facts looked up in Python once, when the goal starts (its partner's
rows, its target's kind, a stall clock...). :class:`RowTable` is that bookkeeping,
written once for every behaviour:

- a row is made by ``make(i, key)`` the first time its key (a goal id, an entity) is
  live, and kept while it stays live; it is dropped when its key is no longer among the
  live ones (the goal ended, the character went away) or :meth:`RowTable.forget` says so;
- every row is made again when the ``layout`` changes (the store's rows moved:
  ``state.version``, another store), its ``saved`` columns carried over;
- the live rows' columns are packed into arrays, in the order of the live keys, only
  when the set of keys or the layout changes - not each step. A kernel may write into
  the packed arrays (a stall clock): the rows take those values back before the next packing;
- a snapshot keeps the ``saved`` columns of every row (:meth:`RowTable.__getstate__`);
  everything else is made again after a restore.

The per-character path (``act``) and the batch path (``act_batch``) of a behaviour use
the same table: the one packs the table for one key, the other for all of them.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

#: No layout yet: the next :meth:`RowTable.sync` makes every row.
_UNSET = object()


@dataclass(frozen=True, slots=True)
class Column:
    """One column of a :class:`RowTable`: its dtype and the shape of one row's value.

    ``ragged``: a row's value is a run of any length (1-d); the packed column is the runs
    end to end, with ``<name>_start`` and ``<name>_count`` arrays giving each row's run.
    ``saved``: the column is state, not a cache - a snapshot keeps it, and a row made
    again (the layout changed, a restore) keeps its value rather than ``make``'s.
    """

    dtype: Any = np.float64
    shape: tuple[int, ...] = ()
    ragged: bool = False
    saved: bool = False


class RowTable:
    """Rows keyed by goal id or entity, packed into numpy columns (see the module docstring)."""

    # What a table restored from a snapshot starts with beside its columns and saved rows
    # (a snapshot sets only what :meth:`__getstate__` gave, without calling ``__init__``).
    _layout: Any = _UNSET
    _live: tuple = ()
    _packed: dict[str, np.ndarray] = {}  # noqa: RUF012 (replaced, never changed in place)
    #: The packed keys, in packing order, and their positions in the keys given to :meth:`sync`.
    keys: tuple = ()
    positions = np.zeros(0, dtype=np.int64)
    #: Positions of the keys ``make`` refused (None) at the last packing.
    missing: tuple[int, ...] = ()

    def __init__(self, **columns: Column) -> None:
        self.columns = dict(columns)
        self._rows: dict[Hashable, dict[str, Any]] = {}

    def __len__(self) -> int:
        return len(self.keys)

    def __getitem__(self, name: str) -> np.ndarray:
        """A packed column (or a ragged column's ``_start``/``_count``)."""
        return self._packed[name]

    def __contains__(self, key: Hashable) -> bool:
        return key in self._rows

    def row(self, key: Hashable) -> dict[str, Any]:
        """The values of one row (as last packed or made)."""
        self._take_back()
        return self._rows[key]

    def sync(self, keys: Sequence[Hashable], layout: Hashable,
             make: Callable[[int, Hashable], Mapping[str, Any] | None]) -> bool:  # fmt: skip
        """Make sure the table holds a row for every live key of ``keys`` (in that order),
        made by ``make(i, keys[i])`` when new; returns True when it packed the arrays anew.

        ``make`` returns the row's column values, or None for a key it cannot row (a
        target gone): that key is left out (its position is in :attr:`missing`) until the
        keys or the layout change.
        """
        live = tuple(keys)
        if live == self._live and layout == self._layout:
            return False
        self._take_back()
        if layout != self._layout:  # the rows moved: every row again (what is saved stays)
            kept = {key: {c: row[c] for c in self._saved() if c in row} for key, row in self._rows.items()}
            self._rows = {}
        else:
            kept = {}
        wanted = set(live)
        for key in [k for k in self._rows if k not in wanted]:
            del self._rows[key]
        positions, missing = [], []
        for i, key in enumerate(live):
            row = self._rows.get(key)
            if row is None:
                made = make(i, key)
                if made is None:
                    missing.append(i)
                    continue
                row = self._rows[key] = {**made, **kept.get(key, {})}
            positions.append(i)
        self.keys = tuple(live[i] for i in positions)
        self.positions = np.array(positions, dtype=np.int64)
        self.missing = tuple(missing)
        self._pack()
        self._live = live
        self._layout = layout
        return True

    def forget(self, key: Hashable) -> None:
        """Drop the row of ``key`` now (its goal was stopped, to be resumed later from its memory)."""
        if key in self._rows:
            self._take_back()
            del self._rows[key]
            self._live = ()  # pack again at the next sync

    def _saved(self) -> list[str]:
        return [name for name, column in self.columns.items() if column.saved]

    def _pack(self) -> None:
        rows = [self._rows[key] for key in self.keys]
        n = len(rows)
        packed = {}
        for name, column in self.columns.items():
            if column.ragged:
                runs = [np.asarray(row[name], dtype=column.dtype).ravel() for row in rows]
                counts = np.array([len(r) for r in runs], dtype=np.int64)
                packed[name] = (
                    np.concatenate(runs).astype(column.dtype) if runs else np.zeros(0, column.dtype)
                )
                packed[f"{name}_start"] = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
                packed[f"{name}_count"] = counts
            elif column.dtype is object:
                packed[name] = np.empty(n, dtype=object)
                packed[name][:] = [row[name] for row in rows]
            else:
                packed[name] = np.array([row[name] for row in rows], dtype=column.dtype).reshape(
                    n, *column.shape
                )
        self._packed = packed

    def _take_back(self) -> None:
        """Copy the packed arrays' values back into the rows (a kernel may have written them)."""
        for k, key in enumerate(self.keys):
            row = self._rows.get(key)
            if row is None:
                continue
            for name, column in self.columns.items():
                if not column.ragged and column.dtype is not object and name in self._packed:
                    value = self._packed[name][k]
                    row[name] = value.copy() if column.shape else value.item()

    def __getstate__(self) -> dict[str, Any]:
        """What a snapshot keeps: the columns and each row's ``saved`` values (nothing else is
        state: a restored table makes every row again at its first sync, the saved values
        kept). A table kept in a snapshot has plain-number columns (no ``object`` ones)."""
        self._take_back()
        saved = self._saved()
        rows = {key: {c: row[c] for c in saved if c in row} for key, row in self._rows.items()}
        return {"columns": self.columns, "_rows": rows}
