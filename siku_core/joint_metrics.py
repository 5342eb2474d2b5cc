"""Joint metrics for diagnostics and maps: strains of all joints, openings of broken ones."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .contacts import frame_point


@njit(cache=True)
def joint_strain_opening(q, ji, jj, ends_i, ends_j, L0, R):
    """Per joint: strain ``max(|s1|, |s2|) / L0`` [1] and normal opening [m].

    The opening is the mean displacement of ``j``'s copy of the joint ends from ``i``'s copy
    along the outward normal of ``i``'s edge (positive when the joint has pulled apart).
    """
    n = ji.shape[0]
    strain = np.empty(n)
    opening = np.empty(n)
    for k in range(n):
        i = ji[k]
        j = jj[k]
        ax, ay = ends_i[k, 0, 0], ends_i[k, 0, 1]
        bx, by = ends_i[k, 1, 0], ends_i[k, 1, 1]
        Ax, Ay = frame_point(q[j], q[i], ends_j[k, 0, 0], ends_j[k, 0, 1], R)
        Bx, By = frame_point(q[j], q[i], ends_j[k, 1, 0], ends_j[k, 1, 1], R)
        s1x, s1y, s2x, s2y = Ax - ax, Ay - ay, Bx - bx, By - by
        strain[k] = max(math.hypot(s1x, s1y), math.hypot(s2x, s2y)) / L0[k]
        w = math.hypot(bx - ax, by - ay)
        if w > 0.0:
            nx, ny = (by - ay) / w, -(bx - ax) / w
            opening[k] = 0.5 * ((s1x + s2x) * nx + (s1y + s2y) * ny)
        else:
            opening[k] = 0.0
    return strain, opening


def joint_diagnostics(q, ji, jj, ends_i, ends_j, L0, width, intact, E, area, flags, R):
    """Lead and stress diagnostics of the frozen joints.

    * ``lead_area`` [m²]: open water in leads, the sum over broken joints of the normal opening
      (when positive) times the joint length; ``lead_fraction`` [1]: its share of the area of
      the free ice plus the leads;
    * ``joint_stress_max`` / ``joint_stress_min`` [Pa]: the largest tensile and compressive
      normal stress ``E opening / L0`` over intact joints (tension positive);
    * ``joint_strain_max`` [1]: the largest ``max(|s1|, |s2|) / L0`` over intact joints.
    """
    strain, opening = joint_strain_opening(q, ji, jj, ends_i, ends_j, L0, R)
    broken = ~intact
    lead_area = float(np.sum(np.clip(opening[broken], 0.0, None) * width[broken]))
    ice = float(area[flags == 0].sum())
    out = {"lead_area": lead_area, "lead_fraction": lead_area / (ice + lead_area) if ice else 0.0}
    if intact.any():
        e = 0.5 * (E[ji] + E[jj])
        sigma = e[intact] * opening[intact] / L0[intact]
        out["joint_stress_max"] = float(max(sigma.max(), 0.0))
        out["joint_stress_min"] = float(min(sigma.min(), 0.0))
        out["joint_strain_max"] = float(strain[intact].max())
    else:
        out.update(joint_stress_max=0.0, joint_stress_min=0.0, joint_strain_max=0.0)
    return out
