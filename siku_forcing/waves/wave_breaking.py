"""Wave-induced flexural breaking of frozen joints (``[[forcing]] source = "waves"``,
``breaking = true``).

A floe here is a group of elements connected by intact joints (the engine's
``ctx.contacts.floe_labels``). Its elements are rigid and move in the plane only; bending is not
resolved by the dynamics, so the strain a joint would carry is estimated from the sea surface, as
the smaller of the two limits of an elastic floe floating on a wave:

* **a floe that follows the surface** (flexible, or long waves): the surface strain at the
  joint, ``eps_f = (h / 2) |d²eta / ds²|``, ``s`` across the joint;
* **a floe too stiff to bend** (short floes, short waves): the floe takes the rigid heave, pitch
  and roll that balance the buoyancy of the wave, i.e. the area-weighted least-squares plane
  through the elevation at its elements; what the plane leaves is a load ``p_e = rho_w g A_e
  (eta_e - plane_e)`` [N] per element, in equilibrium (no net force or moment). Cut the floe along
  the joint's line: the bending moment is ``M = sum p_e d_e`` over the elements on one side, ``d_e``
  their distance from the line, and the surface stress of a plate of thickness ``h`` over the cut's
  chord ``w`` is ``6 M / (w h²)``: ``eps_r = 6 |M| / (E w h²)``.

``eps = min(eps_f, eps_r)``. For ``L << wavelength`` the rigid limit gives ``eps_r ≈ rho_w g
kappa L⁴ / (64 E h²)`` at the middle of a strip of length ``L`` under a crest of curvature
``kappa``: a floe shorter than ``L_c = (64 E h² eps_c / (rho_w g kappa))^(1/4)`` cannot break,
and fragments get smaller as the waves get higher (``L_c ∝ a^-1/4``). For long floes the rigid
moment outgrows the surface strain when ``rho_w g > D k⁴`` (``D`` the flexural rigidity), and the
floe is taken to follow the surface, as a thin plate on water does.

Each check (every step, or every ``break_every`` seconds) breaks, in every floe, the joint of
largest strain above ``critical_strain`` (mode ``flexure``), recomputes the floes and repeats
until no joint exceeds it: a floe fails at its weakest section first and its pieces are then
judged on their own. Assumptions: quasi-static response (no floe inertia in heave or pitch), a
uniform plate per joint (the two elements' mean thickness and Young's modulus), chords of the
cut measured on the elements' polygons, and the water density ``rho`` of the forcing.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core import SceneError
from siku_core.contact_law import BREAK_FLEXURE
from siku_core.geometry.quat import from_tangent, latlon_of
from siku_core.geometry.sphere import xyz_to_latlon


@njit(cache=True)
def _vertices_latlon(q, offsets, verts, R):
    n = verts.shape[0]
    lat = np.empty(n)
    lon = np.empty(n)
    for i in range(q.shape[0]):
        for v in range(offsets[i], offsets[i + 1]):
            lat[v], lon[v] = xyz_to_latlon(from_tangent(q[i], verts[v, 0], verts[v, 1], R))
    return lat, lon


@njit(cache=True)
def _cut(members, cx, cy, load, vx, vy, offsets, mx, my, nx, ny, tol):
    """Moment [N m] about the line through ``(mx, my)`` with unit normal ``(nx, ny)`` of the
    loads on its positive side, and the chord [m] of the members' polygons along it."""
    tx, ty = -ny, nx
    M = 0.0
    nm = members.shape[0]
    lo = np.empty(nm)
    hi = np.empty(nm)
    m = 0
    for a in range(nm):
        e = members[a]
        d = (cx[e] - mx) * nx + (cy[e] - my) * ny
        if d > 0.0:
            M += load[e] * d
        s_min = 1e300
        s_max = -1e300
        for v in range(offsets[e], offsets[e + 1]):
            s = (vx[v] - mx) * nx + (vy[v] - my) * ny
            s_min = min(s_min, s)
            s_max = max(s_max, s)
        if s_max < -tol or s_min > tol:
            continue  # wholly on one side
        if s_min >= -tol:
            # touches the line from the positive side: its vertices on the line
            u0 = 1e300
            u1 = -1e300
            for v in range(offsets[e], offsets[e + 1]):
                s = (vx[v] - mx) * nx + (vy[v] - my) * ny
                if s <= tol:
                    u = (vx[v] - mx) * tx + (vy[v] - my) * ty
                    u0 = min(u0, u)
                    u1 = max(u1, u)
        elif s_max <= tol:
            continue  # touches from the negative side: counted by its partner
        else:
            u0 = 1e300
            u1 = -1e300
            k = offsets[e + 1] - offsets[e]
            for b in range(k):
                v = offsets[e] + b
                w = offsets[e] + (b + 1) % k
                s1 = (vx[v] - mx) * nx + (vy[v] - my) * ny
                s2 = (vx[w] - mx) * nx + (vy[w] - my) * ny
                if (s1 <= 0.0 < s2) or (s2 <= 0.0 < s1):
                    f = s1 / (s1 - s2)
                    px = vx[v] + f * (vx[w] - vx[v])
                    py = vy[v] + f * (vy[w] - vy[v])
                    u = (px - mx) * tx + (py - my) * ty
                    u0 = min(u0, u)
                    u1 = max(u1, u)
        if u1 > u0:
            lo[m] = u0
            hi[m] = u1
            m += 1
    if m == 0:
        return M, 0.0
    order = np.argsort(lo[:m])
    chord = 0.0
    cur0 = lo[order[0]]
    cur1 = hi[order[0]]
    for b in range(1, m):
        a0 = lo[order[b]]
        a1 = hi[order[b]]
        if a0 > cur1:
            chord += cur1 - cur0
            cur0, cur1 = a0, a1
        else:
            cur1 = max(cur1, a1)
    chord += cur1 - cur0
    return M, chord


class FlexuralBreaking:
    """The check of the module docstring for one run: ``check(t, q)`` breaks joints."""

    def __init__(self, ctx, field, critical_strain: float, every: float, rho: float):
        cm = ctx.contacts
        if cm is None or cm.n_joints == 0:
            raise SceneError(f"{ctx.scene.where('forcing')}: waves with breaking = true need "
                             "frozen joints ([contact] with a joint law)")
        self.ctx, self.cm, self.field = ctx, cm, field
        self.eps_c = float(critical_strain)
        self.every = float(every)
        self.rho = float(rho)
        self.next_check = -math.inf
        #: strain of every joint at the last check [1] (NaN: not evaluated, e.g. broken); as
        #: long as the joint slots, so that joints a process creates are checked too
        self.strain = np.full(cm.joint_slots, np.nan)

    def surface_strains(self, t: float, q: np.ndarray, joints: np.ndarray,
                        cm=None) -> np.ndarray:
        """``eps_f = (h / 2) |d²eta / ds²|`` [1] of ``joints`` across their edges at time ``t``
        [s] for state ``q`` (``cm``: the joints read, default the run's contacts)."""
        cm = self.cm if cm is None else cm
        f, st = self.field, self.ctx.state
        lat, lon, de, dn = (a[joints] for a in cm.joint_lines(q))
        h = 0.5 * (st.thickness[cm.ji[joints]] + st.thickness[cm.jj[joints]])
        # across the joint: the normal of its edge
        return 0.5 * h * np.abs(f.curvature(t, lat, lon, dn, -de))

    def strains(self, t: float, q: np.ndarray, joints: np.ndarray, eps_f=None, floes=None,
                only=None, cm=None) -> np.ndarray:
        """``min(eps_f, eps_r)`` [1] of intact ``joints`` at time ``t`` [s] for state ``q``.
        ``eps_f``: their surface strains if known (:meth:`surface_strains`); ``floes``:
        ``(count, label)`` of the current joints if known; ``only`` (bool over ``joints``): the
        joints whose rigid limit is computed (the others get ``eps_f``); ``cm``: as
        :meth:`surface_strains`."""
        cm = self.cm if cm is None else cm
        f, st, ctx = self.field, self.ctx.state, self.ctx
        if eps_f is None:
            eps_f = self.surface_strains(t, q, joints, cm)
        # the joints' ice as it is now (a process may have changed the thickness or made the
        # joint)
        ji, jj = cm.ji[joints], cm.jj[joints]
        h = 0.5 * (st.thickness[ji] + st.thickness[jj])
        E = 0.5 * (cm.youngs_modulus[ji] + cm.youngs_modulus[jj])
        out = eps_f.copy()
        hot = eps_f > self.eps_c
        if only is not None:
            hot &= only
        if not hot.any():
            return out
        lat, lon, de, dn = (a[joints] for a in cm.joint_lines(q))
        count, label = cm.floe_labels() if floes is None else floes
        clat, clon = latlon_of(q)
        cx, cy = f.plane(clat, clon)
        eta = f.evaluate(t, clat, clon)["eta"]
        vlat, vlon = _vertices_latlon(q, st.vert_offsets, st.verts, ctx.radius)
        vx, vy = f.plane(vlat, vlon)
        mx, my = f.plane(lat, lon)
        A = st.area
        g = float(f.p["g"])
        order = np.argsort(label, kind="stable")
        bounds = np.searchsorted(label[order], np.arange(count + 1))
        load = np.zeros(st.n)
        done = np.zeros(count, dtype=bool)
        for a in np.flatnonzero(hot):
            k = joints[a]
            fl = label[cm.ji[k]]
            members = order[bounds[fl]:bounds[fl + 1]]
            if not done[fl]:
                x, y, w = cx[members], cy[members], A[members]
                x0, y0 = np.average(x, weights=w), np.average(y, weights=w)
                G = np.column_stack([np.ones_like(x), x - x0, y - y0])
                coef = np.linalg.lstsq(G * np.sqrt(w)[:, None], eta[members] * np.sqrt(w),
                                       rcond=None)[0]
                load[members] = self.rho * g * w * (eta[members] - G @ coef)
                done[fl] = True
            tol = 1e-6 * math.sqrt(A[cm.ji[k]])
            M, chord = _cut(members, cx, cy, load, vx, vy, st.vert_offsets, mx[a], my[a],
                            dn[a], -de[a], tol)
            if chord > 0.0:
                eps_r = 6.0 * abs(M) / (E[a] * chord * h[a] ** 2)
                out[a] = min(eps_f[a], eps_r)
        return out

    def check(self, t: float, q: np.ndarray, cm=None) -> int:
        """Break joints as the module docstring says; the number broken (``cm``: the joints
        read and broken, default the run's contacts; :class:`RankBreaking` gives the whole
        run's on an MPI rank).

        Within one check the sea and the elements stand still, so a joint's surface strain is
        computed once, and its rigid-floe strain again only when its floe changed (lost or
        gained elements) since the last pass: the same strains as computing everything at every
        pass, at the cost of the floes that split."""
        if t < self.next_check:
            return 0
        self.next_check = t + self.every
        cm = self.cm if cm is None else cm
        total = 0
        eps_f = np.full(cm.joint_slots, np.nan)
        joints = np.flatnonzero(cm.intact)  # (the intact flags of the joints made so far)
        eps_f[joints] = self.surface_strains(t, q, joints, cm)
        known = np.full(cm.joint_slots, np.nan)  # min(eps_f, eps_r) of the last pass
        before = None  # floe labels of the last pass
        while True:
            joints = np.flatnonzero(cm.intact)
            if not len(joints):
                return total
            floes = cm.floe_labels()
            same = _unchanged_floes(floes, before)
            redo = ~same[floes[1][cm.ji[joints]]]
            eps = self.strains(t, q, joints, eps_f[joints], floes, redo, cm)
            eps[~redo] = known[joints[~redo]]
            known[joints] = eps
            before = floes
            self.strain[:] = np.nan
            self.strain[joints] = eps
            over = eps > self.eps_c
            if not over.any():
                return total
            # per floe, the joint of largest strain
            label = floes[1]
            fl = label[cm.ji[joints[over]]]
            k = joints[over]
            e = eps[over]
            best = np.lexsort((-e, fl))
            first = np.r_[True, fl[best][1:] != fl[best][:-1]]
            total += cm.break_joints(k[best][first], BREAK_FLEXURE, t)


class RankBreaking:
    """The check of :class:`FlexuralBreaking` on an MPI rank (``siku_core.ranks``): a floe
    spans ranks, and its rigid-floe strain sums over all its elements, so every rank makes
    the run's check, alike: the run's breaker ``run`` (its clock and last strains are the
    run's, on every rank), the elements' positions and thickness gathered from their owners
    (``link.whole``) at each check, the floes of the run's joint table, labelled by global
    identities (``siku_core.ranks.local.WholeJoints``); the joints it breaks break the rank's
    copies of those it holds, in the same step on every rank, and the engine reports each
    once. ``state``: the rank's elements."""

    def __init__(self, run: FlexuralBreaking, link, state):
        self.run, self.link, self.state = run, link, state

    @property
    def strain(self) -> np.ndarray:
        return self.run.strain

    def check(self, t: float, q: np.ndarray) -> int:
        from siku_core.ranks.local import WholeJoints

        run = self.run
        if t < run.next_check:
            return 0
        q_all, h_all = self.link.whole(q, self.state.thickness)
        run.ctx.state.thickness[:] = h_all  # (the run's elements as they are now)
        return run.check(t, q_all, WholeJoints(self.link))


def _unchanged_floes(floes, before) -> np.ndarray:
    """Per floe of ``floes`` (``(count, label)``): whether it holds exactly the elements of one
    floe of ``before`` (None: no floe is known)."""
    count, label = floes
    if before is None:
        return np.zeros(count, dtype=bool)
    old = before[1]
    lo = np.full(count, np.iinfo(np.int64).max)
    hi = np.full(count, -1)
    np.minimum.at(lo, label, old)
    np.maximum.at(hi, label, old)
    size = np.bincount(label, minlength=count)
    old_size = np.bincount(old, minlength=before[0])
    return (lo == hi) & (size == old_size[np.clip(lo, 0, before[0] - 1)])
