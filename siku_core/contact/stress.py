"""Average stress of each element from its contact forces (docs/explanation/physics.md §4,
"stress").

For an element of area ``A`` in equilibrium the mean of the (vertically integrated) stress
tensor over its area is fixed by the forces on its boundary (the Love-Weber formula of
granular mechanics, exact for a body in static equilibrium)::

    sigma_ab = (1 / A) * sum_c  r_a^c f_b^c

over its contacts ``c`` (frozen joints and collisions): ``r^c`` is the contact point relative to
the centroid and ``f^c`` the force the neighbour exerts on the element there. The forces are
whole-thickness forces [N], so ``sigma`` is a force per unit length [N/m] (multiply by
``1/h`` for Pa); tension is positive. The tensor is symmetrised (the couples of a contact law
and the rotational inertia of an element that is not in equilibrium make the sum slightly
asymmetric) and given in geographic east/north components.

The forces are those of the last force evaluation, so a snapshot's stress is the stress of the
state one step (or one integrator stage) earlier; forcing (wind, water) acts over the area and
is not a contact force, so it does not enter: ``sigma`` is the stress the ice carries.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from .contact_frames import (
    ROW_FIX, ROW_FIY, ROW_FJX, ROW_FJY, ROW_PX, ROW_PY, i_to_j, relative_matrix,
)
from ..fields import STRESS
from ..geometry.quat import east_north_row
from ..parallel import chunk_bounds, chunks

#: the element stress fields: name -> (unit, meaning), from the catalogue
#: (:data:`siku_core.fields.STRESS`)
STRESS_FIELDS = {n: (f.units, f.long_name) for n, f in STRESS.items()}


@njit(cache=True, parallel=True)
def _moments(rm, ia, ib, out, on, off, idx, side, R, acc, nch):
    """Add to ``acc[e]`` the moments ``r f`` of element ``e``'s contacts of one list, in
    ascending contact index (``off, idx, side``: the list's element index,
    ``siku_core.contact.contact_frames.element_index``), parallel over elements."""
    inv_r = 1.0 / R
    n = acc.shape[0]
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        for e in range(lo, hi):
            sxx = acc[e, 0]
            syy = acc[e, 1]
            sxy = acc[e, 2]
            for a in range(off[e], off[e + 1]):
                k = idx[a]
                if on[k] != 1:
                    continue
                px = out[k, ROW_PX]
                py = out[k, ROW_PY]
                if side[a] == 0:
                    fx = out[k, ROW_FIX]
                    fy = out[k, ROW_FIY]
                else:
                    M = relative_matrix(rm, ia[k], ib[k])
                    px, py = i_to_j(M, px, py, R, inv_r)
                    fx = out[k, ROW_FJX]
                    fy = out[k, ROW_FJY]
                sxx += px * fx
                syy += py * fy
                sxy += 0.5 * (px * fy + py * fx)
            acc[e, 0] = sxx
            acc[e, 1] = syy
            acc[e, 2] = sxy


@njit(cache=True)
def _to_east_north(q, acc, area, res):
    for e in range(q.shape[0]):
        ex, ey, nx, ny = east_north_row(q, e)
        sxx = acc[e, 0] / area[e]
        syy = acc[e, 1] / area[e]
        sxy = acc[e, 2] / area[e]
        # R sigma R^T with the rows of R the east and north unit vectors (local components)
        res[e, 0] = ex * (sxx * ex + sxy * ey) + ey * (sxy * ex + syy * ey)
        res[e, 1] = nx * (sxx * nx + sxy * ny) + ny * (sxy * nx + syy * ny)
        res[e, 2] = ex * (sxx * nx + sxy * ny) + ey * (sxy * nx + syy * ny)


def element_stress(q, rm, area, R, contacts) -> np.ndarray:
    """``(N, 3)`` mean stress of every element [N/m]: east-east, north-north, east-north.

    ``contacts``: ``(i, j, out, on, off, idx, side)`` tuples, one per contact list (joints,
    collision pairs), with ``out`` the per-contact rows of ``siku_core.contact.contact_frames``
    (``ROW_*``) of
    the last force evaluation, ``on[k] == 1`` where contact ``k`` carried force, ``off, idx,
    side`` the list's element index (``siku_core.contact.contact_frames.element_index``), and ``rm``
    the
    rotation matrices of that evaluation."""
    n = q.shape[0]
    acc = np.zeros((n, 3))
    for ia, ib, out, on, off, idx, side in contacts:
        if len(ia):
            _moments(rm, np.ascontiguousarray(ia), np.ascontiguousarray(ib), out, on, off, idx,
                     side, float(R), acc, chunks(n))
    res = np.empty((n, 3))
    _to_east_north(q, acc, area, res)
    return res


def principal(see, snn, sen):
    """Principal stresses ``(sigma_1 >= sigma_2)`` and the invariants ``sigma_I`` (mean normal
    stress, ``(sigma_1 + sigma_2) / 2``) and ``sigma_II`` (maximum shear stress,
    ``(sigma_1 - sigma_2) / 2``) of 2-D stress tensors given by components (same unit)."""
    see, snn, sen = (np.asarray(a, dtype=float) for a in (see, snn, sen))
    mean = 0.5 * (see + snn)
    rad = np.hypot(0.5 * (see - snn), sen)
    return mean + rad, mean - rad, mean, rad
