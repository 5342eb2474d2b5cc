"""Joint metrics for diagnostics and maps: strains of all joints, openings of broken ones."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .contact_frames import j_to_i, relative_matrix, rotation_matrices
from ..parallel import chunk_bounds, chunks, sum_chunks


@njit(cache=True, inline="always")
def _strain_opening(rm, k, ji, jj, ends_i, ends_j, L0, R, inv_r):
    """Strain and opening of joint ``k`` (see :func:`joint_strain_opening`)."""
    M = relative_matrix(rm, ji[k], jj[k])
    ax, ay = ends_i[k, 0, 0], ends_i[k, 0, 1]
    bx, by = ends_i[k, 1, 0], ends_i[k, 1, 1]
    Ax, Ay = j_to_i(M, ends_j[k, 0, 0], ends_j[k, 0, 1], R, inv_r)
    Bx, By = j_to_i(M, ends_j[k, 1, 0], ends_j[k, 1, 1], R, inv_r)
    s1x, s1y, s2x, s2y = Ax - ax, Ay - ay, Bx - bx, By - by
    strain = math.sqrt(max(s1x * s1x + s1y * s1y, s2x * s2x + s2y * s2y)) / L0[k]
    w = math.sqrt((bx - ax) ** 2 + (by - ay) ** 2)
    if w > 0.0:
        opening = 0.5 * ((s1x + s2x) * (by - ay) - (s1y + s2y) * (bx - ax)) / w
    else:
        opening = 0.0
    return strain, opening


@njit(cache=True, parallel=True)
def _strain_opening_all(rm, ji, jj, ends_i, ends_j, L0, R, strain, opening, nch):
    n = ji.shape[0]
    inv_r = 1.0 / R
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        for k in range(lo, hi):
            strain[k], opening[k] = _strain_opening(rm, k, ji, jj, ends_i, ends_j, L0, R, inv_r)


def element_rotations(q: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(N, 3, 3)`` of the elements of state ``q``."""
    rm = np.empty((q.shape[0], 3, 3))
    rotation_matrices(q, rm, chunks(q.shape[0]))
    return rm


def joint_strain_opening(q, ji, jj, ends_i, ends_j, L0, R, rm=None):
    """Per joint: strain ``max(|s1|, |s2|) / L0`` [1] and normal opening [m].

    The opening is the mean displacement of ``j``'s copy of the joint ends from ``i``'s copy
    along the outward normal of ``i``'s edge (positive when the joint has pulled apart).
    ``rm``: the rotation matrices of ``q`` when the caller has them (:func:`element_rotations`).
    """
    rm = element_rotations(q) if rm is None else rm
    n = len(ji)
    strain = np.empty(n)
    opening = np.empty(n)
    _strain_opening_all(rm, ji, jj, ends_i, ends_j, L0, float(R), strain, opening, chunks(n))
    return strain, opening


@njit(cache=True, parallel=True)
def _joint_sums(rm, ji, jj, ends_i, ends_j, L0, width, intact, E, R, nch):
    """Per chunk: lead area of broken joints, extreme normal stress and largest strain of
    intact ones, and how many are intact (reduced by :func:`joint_diagnostics`)."""
    n = ji.shape[0]
    inv_r = 1.0 / R
    part = np.zeros((nch, 5))
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        lead = 0.0
        smax = -np.inf
        smin = np.inf
        emax = -np.inf
        count = 0
        for k in range(lo, hi):
            strain, opening = _strain_opening(rm, k, ji, jj, ends_i, ends_j, L0, R, inv_r)
            if intact[k]:
                sigma = 0.5 * (E[ji[k]] + E[jj[k]]) * opening / L0[k]
                smax = max(smax, sigma)
                smin = min(smin, sigma)
                emax = max(emax, strain)
                count += 1
            elif opening > 0.0:
                lead += opening * width[k]
        part[c, 0] = lead
        part[c, 1] = smax
        part[c, 2] = smin
        part[c, 3] = emax
        part[c, 4] = count
    return part


def joint_diagnostics(q, ji, jj, ends_i, ends_j, L0, width, intact, E, area, flags, R,
                      rm=None):
    """Lead and stress diagnostics of the frozen joints.

    * ``lead_area`` [m²]: open water in leads, the sum over broken joints of the normal opening
      (when positive) times the joint length; ``lead_fraction`` [1]: its share of the area of
      the free ice plus the leads;
    * ``joint_stress_max`` / ``joint_stress_min`` [Pa]: the largest tensile and compressive
      normal stress ``E opening / L0`` over intact joints (tension positive);
    * ``joint_strain_max`` [1]: the largest ``max(|s1|, |s2|) / L0`` over intact joints.

    One compiled pass over the joints (parallel), nothing kept per joint.
    """
    rm = element_rotations(q) if rm is None else rm
    part = _joint_sums(rm, ji, jj, ends_i, ends_j, L0, width, intact, E, float(R),
                       sum_chunks(len(ji)))
    lead_area = float(part[:, 0].sum())
    ice = float(area[flags == 0].sum())
    out = {"lead_area": lead_area, "lead_fraction": lead_area / (ice + lead_area) if ice else 0.0}
    if part[:, 4].sum() > 0:
        out["joint_stress_max"] = float(max(part[:, 1].max(), 0.0))
        out["joint_stress_min"] = float(min(part[:, 2].min(), 0.0))
        out["joint_strain_max"] = float(part[:, 3].max())
    else:
        out.update(joint_stress_max=0.0, joint_stress_min=0.0, joint_strain_max=0.0)
    return out
