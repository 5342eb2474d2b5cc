"""Global diagnostics: energy and momentum about the planet centre, the load on held elements,
and the catalogue of every diagnostic the engine writes (:data:`DIAGNOSTICS`: units and
meaning), which output files and ensemble summaries use."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from .parallel import chunk_bounds, sum_chunks


@njit(cache=True, parallel=True)
def _sums(q, V, w, m, I, radius, nch):  # noqa: E741
    """Per chunk of elements: kinetic energy, momentum (3), angular momentum (3), sum and
    largest speed (reduced by :func:`element_diagnostics`)."""
    n = q.shape[0]
    part = np.zeros((nch, 9))
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        ke = p0 = p1 = p2 = L0 = L1 = L2 = vsum = vmax = 0.0
        for i in range(lo, hi):
            qw, qx, qy, qz = q[i, 0], q[i, 1], q[i, 2], q[i, 3]
            vx, vy = V[i, 0], V[i, 1]
            s2 = vx * vx + vy * vy
            ke += 0.5 * m[i] * s2 + 0.5 * I[i] * w[i] * w[i]
            # the velocity in the global frame, R(q) (vx, vy, 0), and the centre R(q) e_z
            g0 = (1 - 2 * (qy * qy + qz * qz)) * vx + 2 * (qx * qy - qw * qz) * vy
            g1 = 2 * (qx * qy + qw * qz) * vx + (1 - 2 * (qx * qx + qz * qz)) * vy
            g2 = 2 * (qx * qz - qw * qy) * vx + 2 * (qy * qz + qw * qx) * vy
            c0 = 2 * (qx * qz + qw * qy)
            c1 = 2 * (qy * qz - qw * qx)
            c2 = 1 - 2 * (qx * qx + qy * qy)
            mi = m[i]
            p0 += mi * g0
            p1 += mi * g1
            p2 += mi * g2
            # r × m v with r = R c, plus the spin angular momentum I w c
            sw = I[i] * w[i]
            L0 += mi * radius * (c1 * g2 - c2 * g1) + sw * c0
            L1 += mi * radius * (c2 * g0 - c0 * g2) + sw * c1
            L2 += mi * radius * (c0 * g1 - c1 * g0) + sw * c2
            sp = math.sqrt(s2)
            vsum += sp
            vmax = max(vmax, sp)
        part[c, 0] = ke
        part[c, 1] = p0
        part[c, 2] = p1
        part[c, 3] = p2
        part[c, 4] = L0
        part[c, 5] = L1
        part[c, 6] = L2
        part[c, 7] = vsum
        part[c, 8] = vmax
    return part


def element_diagnostics(q, V, w, m, I, radius) -> dict[str, float]:  # noqa: E741
    """Kinetic energy [J], linear momentum [kg m/s] (global frame), angular momentum about the
    planet centre [kg m²/s] (orbital ``R c × m v`` plus spin ``I w c``), mean and max speed [m/s].
    """
    n = q.shape[0]
    part = _sums(q, V, w, m, I, float(radius), sum_chunks(n))
    ke, p, L, vsum = part[:, 0].sum(), part[:, 1:4].sum(axis=0), part[:, 4:7].sum(axis=0), \
        part[:, 7].sum()
    vmax = part[:, 8].max() if n else 0.0
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
    joints broken by each mode (``contact_law.BREAK_MODES``) and what registered components declare
    in ``diagnostic_units`` (``registry``: default the process-wide one)."""
    from .contact_law import BREAK_MODES
    from .plugins import get_registry

    out = dict(DIAGNOSTICS)
    for code, mode in BREAK_MODES.items():
        if code:
            out[f"joints_broken_{mode}"] = ("1", f"frozen joints broken by {mode}")
    reg = registry or get_registry()
    for table in reg.entries.values():
        for entry in table.values():
            for name, unit in entry.cls.diagnostic_units.items():
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
    """Whether every value of the 1-D array ``a`` is finite (no temporary arrays; one pass
    without an early exit, which the compiler turns into vector instructions: four times
    faster than stopping at the first bad value, on the state of a run that has none)."""
    ok = True
    for k in range(a.shape[0]):
        ok &= math.isfinite(a[k])
    return ok


@njit(cache=True)
def speeds_within(V, lim2):
    """Whether every element's ``Vx² + Vy²`` is at most ``lim2`` [m²/s²] (``False`` for a NaN
    speed); vectorised like :func:`all_finite`, for the guard's common case (:func:`fastest`
    names the element when it fails)."""
    ok = True
    for i in range(V.shape[0]):
        ok &= V[i, 0] * V[i, 0] + V[i, 1] * V[i, 1] <= lim2
    return ok


@njit(cache=True)
def _rows_sound(F, T, V, w, q, lim2, lo, hi):
    """:func:`state_sound` for elements ``lo <= i < hi``."""
    return (all_finite(F[lo:hi].reshape(-1)) and all_finite(T[lo:hi])
            and all_finite(V[lo:hi].reshape(-1)) and all_finite(w[lo:hi])
            and all_finite(q[lo:hi].reshape(-1)) and speeds_within(V[lo:hi], lim2))


@njit(cache=True)
def rows_sound(F, T, V, w, q, lim2, rows):
    """:func:`state_sound` of the elements ``rows`` only (an MPI rank's own elements among
    its ghosts: no copies of the state's rows)."""
    ok = True
    for k in range(rows.shape[0]):
        i = rows[k]
        # (``&``, not ``and``: no branches, three times faster on a sound state)
        ok &= (math.isfinite(F[i, 0]) & math.isfinite(F[i, 1]) & math.isfinite(T[i])
               & math.isfinite(V[i, 0]) & math.isfinite(V[i, 1]) & math.isfinite(w[i])
               & math.isfinite(q[i, 0]) & math.isfinite(q[i, 1]) & math.isfinite(q[i, 2])
               & math.isfinite(q[i, 3]) & (V[i, 0] * V[i, 0] + V[i, 1] * V[i, 1] <= lim2))
    return ok


@njit(cache=True, parallel=True)
def _sound_chunks(F, T, V, w, q, lim2, nch):
    n = w.shape[0]
    ok = np.ones(nch, dtype=np.bool_)
    for c in prange(nch):
        lo, hi = chunk_bounds(c, nch, n)
        ok[c] = _rows_sound(F, T, V, w, q, lim2, lo, hi)
    return ok.all()


def state_sound(F, T, V, w, q, lim2, nch):
    """The NaN guard's common case: whether every value of ``F`` (N, 2), ``T`` (N), ``V``
    (N, 2), ``w`` (N) and ``q`` (N, 4) is finite and every element's ``Vx² + Vy²`` is at most
    ``lim2`` [m²/s²]. With ``nch > 1`` chunks of elements, in parallel: each chunk is checked
    by the thread that ran the same chunk of the integrator (its values are still in that
    core's cache). :func:`all_finite` and :func:`fastest` name what failed."""
    if nch > 1:
        return bool(_sound_chunks(F, T, V, w, q, lim2, nch))
    return bool(_rows_sound(F, T, V, w, q, lim2, 0, w.shape[0]))


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
