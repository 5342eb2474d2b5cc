"""What follows a change of the ice, compiled (:meth:`siku_core.ice.IceBook.after_processes`).

After the processes of a step, one pass over the elements (:func:`scan_ice`) finds the elements
whose thickness or flag changed, the first whose thickness is no longer finite and positive, and
whether some thickness moved by more than ``RECHECK`` since the last stable-step check; then
only the changed elements get their mass, moment of inertia and inverse mass again
(:func:`follow_elements`), and only their joints their eq. 9 stiffness and reduced masses
(:func:`follow_contacts`, through the element-to-joint index, or in one pass over all joints
when most elements changed). Every value is computed by the same arithmetic as a recomputation
of everything (``m = rho h A`` by :func:`element_mass`,
:func:`~siku_core.contact.contact_frames.eq9_stiffness`, ``1 / (1/m_i + 1/m_j)``), so the result is
the
same to the bit; an unchanged element keeps values that already follow its thickness. A
candidate pair's reduced mass follows by itself: the collision loop computes it from the
inverse masses as it evaluates an overlapping pair.
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .contact_frames import eq9_stiffness
from ..state import FREE, MELTED


@njit(cache=True, inline="always")
def few(nc, n):
    """Whether a change of ``nc`` of ``n`` elements is followed element by element (else in
    one pass over every element, joint and pair, which is cheaper when a quarter or more of
    the elements changed: thermodynamics changes them all)."""
    return 4 * nc < n


@njit(cache=True, inline="always")
def element_mass(rho, h, area, J):
    """Mass [kg] and polar moment of inertia [kg m²] of an element of density ``rho``
    [kg/m³], thickness ``h`` [m], area ``area`` [m²] and polar second moment of area ``J``
    [m⁴]: ``m = rho h A``, ``I = rho h J``. The one place where the engine computes an element's
    mass from its thickness after a process changed it."""
    rh = rho * h
    return rh * area, rh * J


@njit(cache=True, error_model="numpy")
def scan_ice(h, flags, h_seen, flags_seen, h_checked, recheck, changed):
    """Compare thickness ``h`` [m] and ``flags`` with what was last followed (``h_seen``,
    ``flags_seen``). Returns ``(number changed, whether a thickness changed, whether a flag
    changed, the first element whose thickness is not finite and positive or -1, whether some
    element's thickness differs from ``h_checked`` by more than ``recheck`` of it)``; when few
    changed (:func:`few`), the changed elements go to ``changed`` (in order). The counts are
    one pass without branches (vectors of elements), the list a second one."""
    n = h.shape[0]
    nc = 0
    nh = 0
    nf = 0
    nbad = 0
    ndrift = 0
    for e in range(n):
        he = h[e]
        dh = he != h_seen[e]
        df = flags[e] != flags_seen[e]
        nc += dh or df
        nh += dh
        nf += df
        nbad += not (he > 0.0 and he < np.inf)
        c = h_checked[e]
        ndrift += abs(he - c) > recheck * c
    bad = -1
    if nbad:
        for e in range(n):
            if not (h[e] > 0.0 and h[e] < np.inf):
                bad = e
                break
    if 0 < nc and few(nc, n):
        nc = 0
        for e in range(n):
            if h[e] != h_seen[e] or flags[e] != flags_seen[e]:
                changed[nc] = e
                nc += 1
    return nc, nh > 0, nf > 0, bad, ndrift > 0


@njit(cache=True, error_model="numpy")
def follow_elements(idx, nc, full, h, flags, rho, area, J, m, I, h_seen, flags_seen):  # noqa: E741
    """Mass ``m`` [kg] and moment ``I`` [kg m²] of elements ``idx[:nc]`` (``full``: of every
    element) from their thickness (:func:`element_mass`); ``h_seen``, ``flags_seen`` take their
    thickness and flag."""
    if full:
        for e in range(h.shape[0]):
            m[e], I[e] = element_mass(rho[e], h[e], area[e], J[e])
        h_seen[:] = h
        flags_seen[:] = flags
        return
    for a in range(nc):
        e = idx[a]
        m[e], I[e] = element_mass(rho[e], h[e], area[e], J[e])
        h_seen[e] = h[e]
        flags_seen[e] = flags[e]


@njit(cache=True, error_model="numpy")
def _joint(k, h, E, m, flags, minv, ji, jj, ri, rj, jK, jmeff):
    """Joint ``k``'s eq. 9 stiffness and reduced mass (as ``contact_frames.joint_constants``;
    an element melted away stands in with its own mass)."""
    i = ji[k]
    j = jj[k]
    jK[k] = eq9_stiffness(h[i], E[i], h[j], E[j], ri[k], rj[k])
    mi = 1.0 / m[i] if flags[i] == MELTED else minv[i]
    mj = 1.0 / m[j] if flags[j] == MELTED else minv[j]
    jmeff[k] = 1.0 / (mi + mj)


@njit(cache=True, error_model="numpy")
def joints_from(lo, hi, fresh, ji, jj, ri, rj, jK, jmeff):
    """Eq. 9 stiffness ``jK`` [Pa] and reduced mass ``jmeff`` [kg] of joints ``lo <= k < hi``
    (as :func:`_joint`) from ``fresh``, two values per element written by
    :func:`follow_contacts`: ``h E`` [Pa m] and the inverse mass a joint counts [1/kg] (that
    of an element melted away too); lever arms ``ri``, ``rj`` [m]. On vectors of joints."""
    n = fresh.shape[0] // 2
    for k in range(lo, hi):
        i = ji[k]
        j = jj[k]
        a = fresh[i]
        b = fresh[j]
        d = a * rj[k] + b * ri[k]
        jK[k] = a * b / d if d > 0.0 else 0.0
        jmeff[k] = 1.0 / (fresh[n + i] + fresh[n + j])


@njit(cache=True, error_model="numpy")
def follow_contacts(idx, nc, full, joints, h, E, m, flags, minv, jt, index):
    """The contact model's constants of the elements ``idx[:nc]``: inverse mass ``minv``
    [1/kg] (0 for an element that is not free) and the eq. 9 stiffness ``jt.K`` [Pa] and
    reduced mass ``jt.meff`` [kg] of their joints (lever arms ``jt.ri``, ``jt.rj`` [m]), found
    through the element-to-joint index ``index.joff, index.jidx``; thickness ``h`` [m],
    Young's modulus ``E`` [Pa], mass ``m`` [kg], ``flags`` per element. ``jt``, ``index``:
    the joint table and the element-to-contact index
    (:mod:`siku_core.contact.contact_tables`). ``full``: of every element and joint instead, in two
    passes: per element, on vectors, what a joint gathers (``jt.fresh``, two values per
    element: ``h E`` and the inverse mass a joint counts), then per joint
    (:func:`joints_from`), which ``joints = False`` leaves to the joint loop
    (:meth:`~siku_core.contact.contact_model.ContactModel.ice_changed`). (A candidate pair's reduced
    mass is computed by the collision loop from ``minv``.)"""
    ji = jt.ji
    jj = jt.jj
    ri = jt.ri
    rj = jt.rj
    jK = jt.K
    jmeff = jt.meff
    fresh = jt.fresh
    if full:
        n = m.shape[0]
        for e in range(n):
            f = flags[e]
            r = 1.0 / m[e]
            minv[e] = r if f == FREE else 0.0
            fresh[e] = h[e] * E[e]
            fresh[n + e] = r if f == FREE or f == MELTED else 0.0  # as _joint
        if joints:
            joints_from(0, ji.shape[0], fresh, ji, jj, ri, rj, jK, jmeff)
        return
    joff = index.joff
    jidx = index.jidx
    for a in range(nc):
        e = idx[a]
        minv[e] = 1.0 / m[e] if flags[e] == FREE else 0.0
    for a in range(nc):
        e = idx[a]
        for s in range(joff[e], joff[e + 1]):
            _joint(jidx[s], h, E, m, flags, minv, ji, jj, ri, rj, jK, jmeff)
