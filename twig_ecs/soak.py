"""Physics health over a run: the figures ``twig run`` reports and the limits ``--soak`` enforces.

:class:`Health` looks at the store after every step and keeps the worst of each figure:
fastest node, lowest node, deepest capsule overlap left after a step (penetration),
largest relative link error, the largest kinetic energy of any one body (an energy proxy:
a solver that blows up pumps energy in long before it makes NaN) and NaN. Given
:class:`SoakLimits`, it also says where the first limit was crossed: the frame, the
figure and the body (entity name) responsible, as a :class:`Violation`.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, fields

import numpy as np

from twig_ecs.store import LINK_GRAB, LINK_OFF, NODE_LOCKED


@dataclass(frozen=True)
class SoakLimits:
    """What a healthy run stays within: about twice the worst of a 60-minute schoolyard.

    A solver going wrong crosses them long before NaN; the schoolyard stays inside them
    with room for a hard kick or a fall (docs/reliability.md has the measured figures).
    """

    max_speed: float = 60.0  # m/s, any free node (worst seen 31; settings.max_speed clamps steps at 25)
    min_y: float = -0.05  # m, lowest node position: the ground is y = 0 (worst seen -0.001)
    max_penetration: float = 0.12  # m, deepest overlap of two non-adjacent capsules (worst seen 0.056)
    max_link_error: float = 1.5  # |length - rest| / rest of any rigid link (worst seen 0.63)
    max_energy: float = 3000.0  # J, kinetic energy of the most energetic body (worst seen 1.3 kJ, all bodies)


#: The figures (named as their SoakLimits fields): True when larger is worse.
FIGURES = {"max_speed": True, "min_y": False, "max_penetration": True, "max_link_error": True,
           "max_energy": True}  # fmt: skip


@dataclass(frozen=True)
class Violation:
    """The first limit a run crossed: when, which figure, its value, the limit and who."""

    frame: int
    time: float
    figure: str
    value: float
    limit: float
    entity: str

    def message(self) -> str:
        """One line for a person."""
        if self.figure == "nan":
            return f"frame {self.frame} (t={self.time:.3f} s): NaN in the positions of '{self.entity}'"
        side = "above" if FIGURES[self.figure] else "below"
        return (
            f"frame {self.frame} (t={self.time:.3f} s): {self.figure} {self.value:.4g} is {side} the "
            f"limit {self.limit:.4g} at '{self.entity}'"
        )


class Health:
    """Worst physics figures seen so far in one scene; :meth:`update` after every step.

    ``limits`` (optional) makes :meth:`update` return the first :class:`Violation`.
    """

    def __init__(self, scene, limits: SoakLimits | None = None) -> None:
        self.scene = scene
        self.limits = limits
        self.max_speed = 0.0
        self.min_y = math.inf
        self.max_penetration = 0.0
        self.max_link_error = 0.0
        self.max_energy = 0.0
        self.nan = False
        self.violation: Violation | None = None

    def update(self) -> Violation | None:
        """Measure the store after a step; return a violation the first time a limit is crossed."""
        scene, st = self.scene, self.scene.state
        n = st.nodes
        count = n.count
        pos, prev = n.pos[:count], n.prev[:count]
        if not np.isfinite(pos).all():
            self.nan = True
            bad = int(np.flatnonzero(~np.isfinite(pos).all(axis=1))[0])
            return self._crossed("nan", math.nan, math.nan, self._body_of_node(bad))
        figures: dict[str, tuple[float, object]] = {}  # figure -> (value, how to find who)
        if count:
            free = n.inv_mass[:count] > 0
            speed = np.linalg.norm(pos - prev, axis=1) / scene.dt
            speed[~free] = 0.0
            fastest = int(np.argmax(speed))
            figures["max_speed"] = (float(speed[fastest]), fastest)
            lowest = int(np.argmin(pos[:, 1]))
            figures["min_y"] = (float(pos[lowest, 1]), lowest)
            # per body, so that a crowd of a thousand walking calmly is not "hotter" than
            # one body flung across the yard
            energy = np.bincount(n.body[:count], weights=0.5 * n.mass[:count] * speed**2)
            hottest = int(np.argmax(energy))
            first_node = int(np.flatnonzero(n.body[:count] == hottest)[0])
            figures["max_energy"] = (float(energy[hottest]), first_node)
        figures["max_penetration"] = (float(st.stats[0]), None)
        errors, rows = self._link_errors()
        if len(errors):
            worst = int(np.argmax(errors))
            figures["max_link_error"] = (float(errors[worst]), int(st.links.a[rows[worst]]))
        crossed = None
        for figure, (value, who) in figures.items():
            larger_is_worse = FIGURES[figure]
            old = getattr(self, figure)
            setattr(self, figure, max(old, value) if larger_is_worse else min(old, value))
            limit = getattr(self.limits, figure) if self.limits else None
            if limit is None or crossed is not None:
                continue
            if (value > limit) if larger_is_worse else (value < limit):
                crossed = figure, value, limit, who
        if crossed is None:
            return None
        figure, value, limit, who = crossed
        entity = self._deepest_overlap() if figure == "max_penetration" else self._body_of_node(who)
        return self._crossed(figure, value, limit, entity)

    def _crossed(self, figure: str, value: float, limit: float, entity: str) -> Violation | None:
        if self.violation is not None:
            return None
        scene = self.scene
        self.violation = Violation(scene.frame, scene.time, figure, value, limit, entity)
        return self.violation

    def _link_errors(self) -> tuple[np.ndarray, np.ndarray]:
        """Relative errors of rigid links and their rows (as PhysicsState.link_errors, with rows)."""
        lk = self.scene.state.links
        flags = lk.flags[: lk.count]
        rows = np.flatnonzero((lk.rest[: lk.count] > 0) & ((flags & (LINK_GRAB | LINK_OFF)) == 0))
        errors = self.scene.state.link_errors()  # one definition of the error, kept in the store
        assert len(errors) == len(rows)
        return errors, rows

    def _body_of_node(self, row: int) -> str:
        """The name of the body owning node ``row``."""
        st = self.scene.state
        body = int(st.nodes.body[row])
        entity = int(st.bodies.entity[body]) if body >= 0 else -1
        return self.scene.name_of(entity) or f"node {row}"

    def _deepest_overlap(self) -> str:
        """'a / b': the two bodies of the deepest overlapping collider pair (computed only on failure)."""
        from twig_ecs.systems.physics.collide import closest_segment_params

        st = self.scene.state
        pos, col, flags = st.nodes.pos, st.colliders, st.nodes.flags
        best, who = -math.inf, (0, 0)
        for i, j in st.pairs[: st.n_pairs]:
            if flags[col.a[i]] & flags[col.b[i]] & flags[col.a[j]] & flags[col.b[j]] & NODE_LOCKED:
                continue  # two fixed things (fence panels at a shared post): the solver skips them too
            s, t = closest_segment_params(pos[col.a[i]], pos[col.b[i]], pos[col.a[j]], pos[col.b[j]])
            p = pos[col.a[i]] + s * (pos[col.b[i]] - pos[col.a[i]])
            q = pos[col.a[j]] + t * (pos[col.b[j]] - pos[col.a[j]])
            depth = col.radius[i] + col.radius[j] - float(np.linalg.norm(p - q))
            if depth > best:
                best, who = depth, (int(col.a[i]), int(col.a[j]))
        a, b = (self._body_of_node(k) for k in who)
        return a if a == b else f"{a} / {b}"

    def figures(self) -> dict:
        """The worst figures so far, JSON-ready (``min_y`` None before any node)."""
        return {
            "max_speed_m_s": self.max_speed,
            "min_node_y": self.min_y if math.isfinite(self.min_y) else None,
            "max_penetration_m": self.max_penetration,
            "max_link_error": self.max_link_error,
            "max_kinetic_energy_j": self.max_energy,
            "nan": self.nan,
        }


def limits_dict(limits: SoakLimits) -> dict:
    """The limits as a plain dict (for the JSON report)."""
    return asdict(limits)


def limit_names() -> list[str]:
    """Names of the limits (the ``--max-speed``... flags)."""
    return [f.name for f in fields(SoakLimits)]
