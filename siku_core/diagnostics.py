"""Global diagnostics: energy and momentum about the planet centre, the load on held elements,
and the catalogue of every diagnostic the engine writes (:data:`DIAGNOSTICS`: units and
meaning), which output files and ensemble summaries use."""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .geometry.quat import q_center, qrotate


@njit(cache=True)
def _sums(q, V, w, m, I, radius):  # noqa: E741
    ke = 0.0
    p = np.zeros(3)
    L = np.zeros(3)
    vmax = 0.0
    vsum = 0.0
    v3 = np.zeros(3)
    for i in range(q.shape[0]):
        vx, vy = V[i, 0], V[i, 1]
        s2 = vx * vx + vy * vy
        ke += 0.5 * m[i] * s2 + 0.5 * I[i] * w[i] * w[i]
        v3[0] = vx
        v3[1] = vy
        v3[2] = 0.0
        vg = qrotate(q[i], v3)
        c = q_center(q[i])
        for k in range(3):
            p[k] += m[i] * vg[k]
        # r × m v with r = R c, plus the spin angular momentum I w c
        L[0] += m[i] * radius * (c[1] * vg[2] - c[2] * vg[1]) + I[i] * w[i] * c[0]
        L[1] += m[i] * radius * (c[2] * vg[0] - c[0] * vg[2]) + I[i] * w[i] * c[1]
        L[2] += m[i] * radius * (c[0] * vg[1] - c[1] * vg[0]) + I[i] * w[i] * c[2]
        s = np.sqrt(s2)
        vsum += s
        if s > vmax:
            vmax = s
    return ke, p, L, vsum, vmax


def element_diagnostics(q, V, w, m, I, radius) -> dict[str, float]:  # noqa: E741
    """Kinetic energy [J], linear momentum [kg m/s] (global frame), angular momentum about the
    planet centre [kg m²/s] (orbital ``R c × m v`` plus spin ``I w c``), mean and max speed [m/s].
    """
    n = q.shape[0]
    ke, p, L, vsum, vmax = _sums(q, V, w, m, I, float(radius))
    return {
        "kinetic_energy": ke,
        "momentum_x": p[0], "momentum_y": p[1], "momentum_z": p[2],
        "angular_momentum_x": L[0], "angular_momentum_y": L[1], "angular_momentum_z": L[2],
        "mean_speed": vsum / n if n else 0.0,
        "max_speed": vmax,
    }


#: every diagnostic the engine and its contact model can report: name -> (unit, meaning).
#: Components add their own through ``diagnostic_units`` (:class:`~siku_core.interfaces.Component`).
DIAGNOSTICS: dict[str, tuple[str, str]] = {
    "step": ("1", "step index"),
    "time": ("s", "model time since the start of the run"),
    "kinetic_energy": ("J", "kinetic energy of translation and spin"),
    **{f"momentum_{c}": ("kg m s-1", f"linear momentum, global {c} component")
       for c in "xyz"},
    **{f"angular_momentum_{c}": ("kg m2 s-1", "angular momentum about the planet centre, "
                                 f"global {c} component") for c in "xyz"},
    "mean_speed": ("m s-1", "mean speed of the elements"),
    "max_speed": ("m s-1", "largest speed of an element"),
    "static_force_east": ("N", "force on the static elements (coast, fixed handles), sum of "
                          "their local eastward components"),
    "static_force_north": ("N", "force on the static elements, northward components"),
    "steady_force_east": ("N", "force on the steady elements (moving handles, pushers), sum of "
                          "their local eastward components"),
    "steady_force_north": ("N", "force on the steady elements, northward components"),
    "joints_intact": ("1", "frozen joints still intact"),
    "joints_broken": ("1", "frozen joints broken"),
    "contacts_overlapping": ("1", "element pairs overlapping"),
    "lead_area": ("m2", "open water in leads: normal opening of broken joints times length"),
    "lead_fraction": ("1", "lead area over the area of free ice plus leads"),
    "joint_stress_max": ("Pa", "largest tensile normal stress over intact joints"),
    "joint_stress_min": ("Pa", "largest compressive normal stress over intact joints "
                         "(negative)"),
    "joint_strain_max": ("1", "largest joint strain max(|s1|, |s2|)/L0 over intact joints"),
}


def catalogue(registry=None) -> dict[str, tuple[str, str]]:
    """Every diagnostic a run can report, name -> (unit, meaning): :data:`DIAGNOSTICS`, the
    joints broken by each mode (``contacts.BREAK_MODES``) and what registered components declare
    in ``diagnostic_units`` (``registry``: default the process-wide one)."""
    from .contacts import BREAK_MODES
    from .plugins import get_registry

    out = dict(DIAGNOSTICS)
    for code, mode in BREAK_MODES.items():
        if code:
            out[f"joints_broken_{mode}"] = ("1", f"frozen joints broken by {mode}")
    reg = registry or get_registry()
    for table in reg.entries.values():
        for entry in table.values():
            for name, unit in getattr(entry.cls, "diagnostic_units", {}).items():
                out.setdefault(name, (unit, f"reported by {entry.cls.kind} '{entry.cls.name}'"))
    return out


def held_forces(F, flags) -> dict[str, float]:
    """The forces [N] of the last force evaluation on the static and on the steady elements
    (sums of their local east and north components: the load on a coast or a handle, exact for
    a group of elements spanning a small angle), for the kinds the scene has."""
    from .state import STATIC, STEADY

    out = {}
    for name, code in (("static", STATIC), ("steady", STEADY)):
        held = flags == code
        if held.any():
            out[f"{name}_force_east"] = float(F[held, 0].sum())
            out[f"{name}_force_north"] = float(F[held, 1].sum())
    return out


@njit(cache=True)
def all_finite(a):
    """Whether every value of the 1-D array ``a`` is finite (no temporary arrays)."""
    for k in range(a.shape[0]):
        if not math.isfinite(a[k]):
            return False
    return True


@njit(cache=True)
def fastest(V):
    """``(i, |V_i|²)`` of the element with the largest ``Vx² + Vy²`` (first on ties); ``(-1, 0)``
    without elements."""
    best = -1
    s2 = 0.0
    for i in range(V.shape[0]):
        v = V[i, 0] ** 2 + V[i, 1] ** 2
        if best < 0 or v > s2:
            best = i
            s2 = v
    return best, s2
