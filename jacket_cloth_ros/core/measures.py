# Copyright 2026 jacket_cloth_ros maintainers. Licensed under the Apache License, Version 2.0.
"""What a viewer sees wrong in a cloth state: stretched or folded edges, cloth inside the body.

Measured on the state as published (after the step), each with where it is, so a report can
name the instant, the vertex and the collider. Stretch and compression are kept apart: a hem
folding where a thigh lifts it is not a rubber-band hem.
"""

from typing import TYPE_CHECKING, Callable, NamedTuple, Sequence

import numpy as np

from .bundles import Colliders
from .compiled import njit

if TYPE_CHECKING:           # for the annotations only
    from .rig import Rig


SURFACE = 1e-6         # m: depths below this are rounding, the vertex is on the surface


class Worst(NamedTuple):
    """The worst value of one measure in a state, and where it is."""

    value: float
    vertex: int             # the grid vertex (row * cols + col), -1 if none
    collider: str = ''      # for depths inside the body: which collider


def edge_strain(x: np.ndarray, a: np.ndarray, b: np.ndarray, rest: np.ndarray) -> tuple:
    """Return (worst stretch, worst compression) of edges a-b against their rest lengths.

    As ``length / rest - 1`` and ``1 - length / rest`` (0 if none); each names the edge's
    lower vertex ``b``.

    :param x: the vertices' positions, (N, 3) in m.
    :param a: each edge's first vertex.
    :param b: each edge's second (lower) vertex.
    :param rest: each edge's rest length, m.
    """
    if len(a) == 0:
        return Worst(0.0, -1), Worst(0.0, -1)
    ratio = np.linalg.norm(x[a] - x[b], axis=1) / rest
    s, c = int(np.argmax(ratio)), int(np.argmin(ratio))
    return (Worst(max(0.0, float(ratio[s] - 1.0)), int(b[s])),
            Worst(max(0.0, float(1.0 - ratio[c])), int(b[c])))


def depth_under_floor(points: np.ndarray, root: np.ndarray,
                      floor: 'tuple[np.ndarray, float]') -> float:
    """Return how far points reach under a rig's floor, m (0 where none is under it).

    :param points: (N,3) in the simulation frame.
    :param root: (4,4) that frame's pose in the world.
    :param floor: the world's up and the floor's height along it (Rig.floor).
    """
    up, height = floor
    lowest = (points @ (root[:3, :3].T @ up)).min() + root[:3, 3] @ up
    return max(height - float(lowest), 0.0)


def depth_inside(x: np.ndarray, free: np.ndarray, colliders: 'Colliders',
                 labels: Sequence[str]) -> Worst:
    """Find the deepest free vertex inside any collider (m), with the collider's label.

    Depth is the distance to the surface point the push-out would move the vertex to.

    :param x: the vertices' positions, (N, 3) in m.
    :param free: which vertices are free (not pinned), (N,).
    :param colliders: the body's colliders in the frame of ``x``.
    :param labels: one name per ellipsoid, capsule and plane, in that order.
    """
    best = Worst(SURFACE, -1)       # on the surface (rounding) is not inside
    idx = np.flatnonzero(free)
    if len(idx) == 0:
        return Worst(0.0, -1)
    p = x[idx]
    k = 0
    for c, axes, radii in zip(colliders.centers, colliders.axes, colliders.radii):
        q = ((p - c) @ axes) / radii
        r = np.linalg.norm(q, axis=1)
        hit = (r < 1.0) & (r > 1e-12)
        if hit.any():
            surface = (q[hit] / r[hit, None] * radii) @ axes.T + c
            d = np.linalg.norm(surface - p[hit], axis=1)
            j = int(np.argmax(d))
            if d[j] > best.value:
                best = Worst(float(d[j]), int(idx[hit][j]), labels[k])
        k += 1
    for a, b, radius in zip(colliders.capsule_a, colliders.capsule_b, colliders.capsule_radii):
        ab = b - a
        t = np.clip(((p - a) @ ab) / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        d = radius - np.linalg.norm(p - (a + t[:, None] * ab), axis=1)
        j = int(np.argmax(d))
        if d[j] > best.value:
            best = Worst(float(d[j]), int(idx[j]), labels[k])
        k += 1
    for point, normal in zip(colliders.plane_points, colliders.plane_normals):
        d = -((p - point) @ normal)
        j = int(np.argmax(d))
        if d[j] > best.value:
            best = Worst(float(d[j]), int(idx[j]), labels[k])
        k += 1
    return best if best.vertex >= 0 else Worst(0.0, -1)


def collider_labels(rig: 'Rig') -> list:
    """Return the rig's name of each collider, in the order of bundles.Colliders.

    :param rig: the rig whose ellipsoids, capsules and planes are named.
    """
    return [c.name for c in (*rig.colliders, *rig.capsules, *rig.planes)]


def look_due(looked_ns: 'int | None', stamp_ns: int, every_s: float) -> bool:
    """Tell whether a watch that looks every ``every_s`` of stamps looks at this one.

    :param looked_ns: the last look's stamp, ns; None: none yet.
    :param stamp_ns: the input's stamp, ns; one behind the last look (a restarted source)
        is looked at.
    :param every_s: the watch's period, s of the stamps.
    """
    return looked_ns is None or not 0 <= stamp_ns - looked_ns < every_s * 1e9


# A cloth bunched or collapsed (issue 47 item 5a): the horizontal edges' p99 strain over this,
COLLAPSED_STRAIN = 0.10
# held at every look for this long (s),
COLLAPSED_FOR_S = 1.0
# looked at once in this much of the stamps' time (s): a tenth of the inputs at 100 Hz.
LOOK_EVERY_S = 0.1


class CollapseWatch:
    """Tell when the horizontal edges stay bunched or stretched: p99 of |strain| over a limit.

    A look costs a few numpy calls into buffers made once (no allocation): the p99 over the
    edges, then a running window that only keeps when it started being over. An edge or two
    strained at an armpit for a frame is no collapse; most of a row folded for a second is.
    The cloth is looked at every LOOK_EVERY_S of its inputs' stamps, not at every input: a
    look costs about as much as a few percent of an input's steps.

    :param a: each horizontal edge's first vertex.
    :param b: each edge's second vertex.
    :param rest: each edge's rest length, m.
    """

    def __init__(self, a: np.ndarray, b: np.ndarray, rest: np.ndarray):
        self.a, self.b = np.asarray(a, np.int64), np.asarray(b, np.int64)
        self.rest = np.asarray(rest, float)
        n = len(self.a)
        self._strain, self._size = np.empty(n), np.empty(n)
        at = (n - 1) * 0.99                     # numpy's default (linear) quantile
        self._lo, self._share = int(at), at - int(at)
        self._hi = min(self._lo + 1, n - 1)
        self.since_ns = None        # the stamp from which the p99 has been over, if it is
        self.first_ns = None        # the session's first input: the line says when, from it
        self.looked_ns = None       # the last look's stamp
        self.collapsed = False      # over for COLLAPSED_FOR_S: said once until it recovers
        self.p99 = 0.0              # the last look's

    def clear(self) -> None:
        """Forget the window (the cloth was put back on the body: a reset)."""
        self.since_ns, self.looked_ns, self.collapsed = None, None, False

    def note(self, x: np.ndarray, stamp_ns: int) -> bool:
        """Look at the cloth after an input; return True when it has just been over for long.

        :param x: the vertices' positions, (N, 3) in m.
        :param stamp_ns: the input's stamp, ns.
        """
        if not self.looks_at(stamp_ns):
            return False
        self.looked_ns = stamp_ns
        size = self._size
        edge_strains_into(x, self.a, self.b, self.rest, self._strain, size)
        size.partition((self._lo, self._hi))
        lo = size[self._lo]
        self.p99 = float(lo + (size[self._hi] - lo) * self._share)
        if not self.p99 > COLLAPSED_STRAIN:        # NaN too: a non-finite cloth resets
            self.since_ns, self.collapsed = None, False
            return False
        if self.since_ns is None or stamp_ns < self.since_ns:
            self.since_ns = stamp_ns
        if self.collapsed or (stamp_ns - self.since_ns) * 1e-9 < COLLAPSED_FOR_S:
            return False
        self.collapsed = True
        return True

    def looks_at(self, stamp_ns: int) -> bool:
        """Tell whether :meth:`note` looks at the cloth at this input's stamp.

        :param stamp_ns: the input's stamp, ns.
        """
        return len(self.a) > 0 and look_due(self.looked_ns, stamp_ns, LOOK_EVERY_S)

    def load(self, x: np.ndarray) -> None:
        """Load the compiled look now, with what is watched unchanged (not on the first input).

        :param x: the vertices' positions, (N, 3) in m, as :meth:`note` takes them.
        """
        edge_strains_into(x, self.a, self.b, self.rest, self._strain, self._size)

    def worst_row(self, cols: int) -> tuple[int, bool]:
        """Return the grid row most edges over the limit are on, and whether they are stretched.

        From the last look's strains; called once, when :meth:`note` says a collapse.

        :param cols: the grid's columns.
        """
        over = np.abs(self._strain) > COLLAPSED_STRAIN
        rows = np.bincount(self.b[over] // cols) if over.any() else np.zeros(1, np.int64)
        stretched = int((self._strain[over] > 0).sum()) >= int((self._strain[over] < 0).sum())
        return int(np.argmax(rows)), stretched


# A cloth that keeps moving with the body still: its hem's mean path over the last
# RESTLESS_WINDOW_S faster than RESTLESS_SPEED (m/s) once every link of the body has moved
# slower than BODY_STILL_SPEED (m/s) from look to look for RESTLESS_FOR_S. A hem standing up
# after a violent motion has slowed well under that by then; a cloth cycling on the floor
# never does.
RESTLESS_SPEED = 0.01
RESTLESS_WINDOW_S = 1.0
BODY_STILL_SPEED = 0.01
RESTLESS_FOR_S = 3.0


class RestlessWatch:
    """Tell when the cloth keeps moving while the body stays still: a cycle, not a swing.

    Each input brings the hem's path over its steps (the compiled steps sum it, step by step,
    so a cycle turning within an input counts); a look (every LOOK_EVERY_S of the inputs'
    stamps) checks that the body's links stayed still since the last. Once the body has been
    still for RESTLESS_FOR_S, a hem whose path over the last RESTLESS_WINDOW_S is faster than
    RESTLESS_SPEED is said once, until the body moves or the cloth is reset. Wind moves a
    cloth on a still body too: the caller does not watch with wind.
    """

    def __init__(self):
        self.clear()

    def clear(self) -> None:
        """Forget what was seen (the cloth was put back on the body: a reset)."""
        self._body_last = self.looked_ns = self.still_ns = None
        self._path = 0.0            # the hem's path since the last look, m
        self._moves = []            # (stamp, the hem's path since the look before), body still
        self.restless = False       # said, until the body moves or the cloth is reset
        self.speed = 0.0            # the hem's mean speed over the window when said, m/s

    def load(self, links: np.ndarray, root: np.ndarray) -> None:
        """Load the compiled look now, with what is watched unchanged (not on the first input).

        :param links: the link transforms, as :meth:`note` takes them.
        :param root: the frame's pose in the world, as :meth:`note` takes it.
        """
        scratch = np.zeros((links.shape[0], 3))
        links_in_world(links, root, scratch, scratch)

    def looks_at(self, stamp_ns: int) -> bool:
        """Tell whether :meth:`note` looks at the body at this input's stamp.

        :param stamp_ns: the input's stamp, ns.
        """
        return look_due(self.looked_ns, stamp_ns, LOOK_EVERY_S)

    def carry(self, hem_path: float) -> None:
        """Take an input's hem path where :meth:`looks_at` says no look is due.

        :param hem_path: the hem's mean path over the input's steps, m.
        """
        self._path += hem_path

    def note(self, hem_path: float, links: np.ndarray, root: np.ndarray, stamp_ns: int) -> bool:
        """Take an input's hem path; return True when the cloth has just been restless long.

        :param hem_path: the hem's mean path over the input's steps, m.
        :param links: the skeleton's link transforms (L, 4, 4) in the simulation's frame.
        :param root: that frame's pose in the world (4, 4): a body rolling over turns it, its
            links hardly moving in it.
        :param stamp_ns: the input's stamp, ns.
        """
        self.carry(hem_path)
        if not self.looks_at(stamp_ns):
            return False
        last = self.looked_ns
        body = np.zeros((links.shape[0], 3))
        moved = links_in_world(links, root, body if self._body_last is None else self._body_last,
                               body)
        still = (last is not None and stamp_ns > last
                 and moved < BODY_STILL_SPEED * (stamp_ns - last) * 1e-9)
        if still:
            if self.still_ns is None:
                self.still_ns = last
            self._moves.append((stamp_ns, self._path))
        else:
            self.still_ns, self._moves, self.restless = None, [], False
        self.looked_ns, self._body_last, self._path = stamp_ns, body, 0.0
        if (not still or self.restless
                or (stamp_ns - self.still_ns) * 1e-9 < RESTLESS_FOR_S):
            return False
        start = stamp_ns - RESTLESS_WINDOW_S * 1e9
        while self._moves and self._moves[0][0] <= start:
            self._moves.pop(0)
        speed = sum(m for _, m in self._moves) / RESTLESS_WINDOW_S
        if speed <= RESTLESS_SPEED:
            return False
        self.restless, self.speed = True, speed
        return True


# The body under the floor is looked for this often (s of the stamps), and said when it is
# there at FLOOR_LOOKS looks in a row: a body that stays there is what it is to catch (a
# capture sunk through the floor, a source's world pose too low), not a landing's dip.
FLOOR_LOOK_EVERY_S = 0.5
FLOOR_LOOKS = 2


class FloorWatch:
    """Tell when the body stays under the rig's floor: said once, until it comes back up.

    The floor then holds the cloth against the body, while every per-input figure reads
    clean (the cloth on the floor is outside it).
    """

    def __init__(self):
        self.looked_ns = None
        self.under = 0              # looks in a row that found the body under the floor
        self.sunk = False           # said, and said while it lasts

    def clear(self) -> None:
        """Look at the next input (a reset): the body under the floor stays said till it is up."""
        self.looked_ns = None

    def note(self, under: Callable[[], str], stamp_ns: int) -> str:
        """Look, if a look is due; return the line to say when the body has just gone under.

        :param under: says how far the body reaches under the floor and why, or ''.
        :param stamp_ns: the input's stamp, ns.
        """
        if not look_due(self.looked_ns, stamp_ns, FLOOR_LOOK_EVERY_S):
            return ''
        self.looked_ns = stamp_ns
        line = under()
        self.under = self.under + 1 if line else 0
        said = line if self.under >= FLOOR_LOOKS and not self.sunk else ''
        self.sunk = self.under >= FLOOR_LOOKS
        return said


# The watches look every LOOK_EVERY_S: as a dozen numpy calls each, a look cost several inputs'
# share of the whole glue. numpy's error model: a rest length of zero (a rig may have one) gives
# inf or NaN, as numpy did, instead of raising.
@njit(cache=True, error_model='numpy')
def edge_strains_into(x, a, b, rest, strain, size):
    """Each edge's ``length / rest - 1`` into ``strain`` and its size into ``size``."""
    for j in range(a.shape[0]):
        d0 = x[a[j], 0] - x[b[j], 0]
        d1 = x[a[j], 1] - x[b[j], 1]
        d2 = x[a[j], 2] - x[b[j], 2]
        s = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) / rest[j] - 1.0
        strain[j] = s
        size[j] = abs(s)


@njit(cache=True)
def links_in_world(links, root, last, out):
    """Each link's origin in the world into ``out``; return the most any moved from ``last``.

    :param links: (L,4,4) in the simulation's frame.
    :param root: (4,4) that frame's pose in the world.
    :param last: (L,3) the origins at the last look (``out`` itself at the first).
    :param out: (L,3) written.
    :returns: the largest move along an axis; NaN if any is not a number (never still).
    """
    most = 0.0
    number = True
    for i in range(links.shape[0]):
        for k in range(3):
            now = (links[i, 0, 3] * root[k, 0] + links[i, 1, 3] * root[k, 1]
                   + links[i, 2, 3] * root[k, 2] + root[k, 3])
            move = abs(now - last[i, k])
            out[i, k] = now
            number = number and move == move
            most = max(most, move)
    return most if number else np.nan
