"""Bonds that bend: the intact joints of a floating floe as beams between element centres.

With ``bending = true`` the ``floating`` process couples the heave and tilts of jointed
elements. Joint ``k`` between elements ``i`` and ``j`` is an Euler–Bernoulli beam from the
centre of ``i`` to the centre of ``j`` (length ``L = a_i + a_j``, ``a`` the distance from a
centre to the joint line), of flexural rigidity ``EI = D w``, ``w`` the joint's length and ``D
= E h³ / (12 (1 − ν²))`` (``h`` the thinner side, ``E`` and ``ν`` the mean of the two
materials'). Its degrees of freedom are the heaves ``ζ_i, ζ_j`` and the slopes of the two
elements along the beam, ``θ = s · n`` (``n`` the unit normal of the joint line, from ``i`` to
``j``, in each element's principal axes), and its stiffness is the cubic (Hermite) beam's:

    K = EI / L³ [[12, 6L, −12, 6L], [6L, 4L², −6L, 2L²], [−12, −6L, 12, −6L],
                 [6L, 2L², −6L, 4L²]]

so a floe carries vertical shear and bending moments between its elements, and with the
buoyancy of each element it is a beam (a plate, by a grid of beams) on an elastic foundation:
a point load ``P`` on a strip of width ``b`` deflects it as Hetényi's ``w(x) = P λ / (2 k)
e^{−λ|x|} (cos λx + sin λx)``, ``k = ρ_w g b``, ``λ = 1 / (√2 ℓ)``, ``ℓ = (D / ρ_w g)^{1/4}``
(``tests/test_floating.py``). Torsion and Poisson coupling across beams are not modelled.

The bending moment at the joint line is ``M = EI w''(a_i)`` of the beam's cubic, the bending
stress ``σ = 6 M / (w h²)``; a joint whose ``|σ|`` exceeds ``flexural_strength`` breaks with
mode ``flexure`` after the step (and carries nothing from then on).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from siku_core.contact_law import BreakMode
from siku_core.records import record_type

from .kernels import (FloatingBodies, FloatingPoints, FloatingWave, Frames, attenuation,
                      centres_and_frames, excite)
from .memory import RadiationMemory, lagged

#: the beams' stiffness over the ``3 n`` degrees of freedom (:meth:`Beams.stiffness`)
BeamStiffness = record_type("BeamStiffness", __name__, [
    ("indptr", "i", 1, "(3 n + 1,) CSR row offsets"),
    ("indices", "i", 1, "CSR column of each entry"),
    ("data", "f", 1, "CSR entries [N/m, N, N m: force or moment per heave or slope]"),
], doc="The intact joints' beams as a CSR matrix over ``(ζ, s_1, s_2)`` of every element.")


class Beams:
    """The beams of the intact joints (module docstring), their stiffness in the process's
    degrees of freedom ``(ζ, s_1, s_2)`` per element (index ``3 i + mode``, slopes along the
    principal axes) as a CSR matrix, and the joints' bending stresses."""

    def __init__(self, bodies, ctx):
        cm = ctx.contacts
        st = ctx.state
        self.cm = cm
        ji, jj = cm.ji, cm.jj
        ends_i, ends_j = cm.ends_i, cm.ends_j
        n = st.n

        def normal(ends, elem):
            m = 0.5 * (ends[:, 0] + ends[:, 1])
            t = ends[:, 1] - ends[:, 0]
            t = t / np.hypot(t[:, 0], t[:, 1])[:, None]
            nrm = np.column_stack([t[:, 1], -t[:, 0]])
            a = np.sum(nrm * m, axis=1)
            flip = a < 0
            nrm[flip] *= -1
            a = np.abs(a)
            c, s = bodies.cphi[elem], bodies.sphi[elem]
            # in principal coordinates of the element
            return np.column_stack([nrm[:, 0] * c + nrm[:, 1] * s,
                                    -nrm[:, 0] * s + nrm[:, 1] * c]), a

        self.pi, self.ai = normal(ends_i, ji)     # from i towards the joint, i.e. towards j
        pj, self.aj = normal(ends_j, jj)
        self.pj = -pj                             # the same direction, i to j, in j's axes
        self.L = self.ai + self.aj
        h = np.minimum(st.thickness[ji], st.thickness[jj])
        E = 0.5 * (cm.youngs_modulus[ji] + cm.youngs_modulus[jj])
        nu = 0.5 * (cm.poisson_ratio[ji] + cm.poisson_ratio[jj])
        self.h = h
        self.D = E * h**3 / (12.0 * (1.0 - nu**2))
        self.w = cm.width
        self.EI = self.D * self.w
        self.ji, self.jj, self.n = ji, jj, n
        self.assemble(bodies)

    def _t(self):
        """Per joint, the 4 × 6 map from ``(ζ_i, s1_i, s2_i, ζ_j, s1_j, s2_j)`` to the beam's
        ``(ζ_i, θ_i, ζ_j, θ_j)``."""
        nj = len(self.ji)
        T = np.zeros((nj, 4, 6))
        T[:, 0, 0] = 1.0
        T[:, 1, 1:3] = self.pi
        T[:, 2, 3] = 1.0
        T[:, 3, 4:6] = self.pj
        return T

    def local(self):
        """Per joint the beam's 4 × 4 stiffness."""
        L = self.L
        k = (self.EI / L**3)[:, None, None]
        one = np.ones_like(L)
        rows = [[12 * one, 6 * L, -12 * one, 6 * L], [6 * L, 4 * L**2, -6 * L, 2 * L**2],
                [-12 * one, -6 * L, 12 * one, -6 * L], [6 * L, 2 * L**2, -6 * L, 4 * L**2]]
        return k * np.stack([np.stack(r, axis=-1) for r in rows], axis=1)

    def stale(self) -> bool:
        """Whether joints broke (the law, a restart) since the stiffness was assembled."""
        return not np.array_equal(self.seen, self.cm.intact)

    def stiffness(self) -> tuple:
        """The :data:`BeamStiffness` record of the intact joints now."""
        return BeamStiffness(self.indptr, self.indices, self.data)

    def assemble(self, bodies) -> None:
        """The CSR stiffness of the intact joints, and the highest frequency it allows
        (Gershgorin's bound on the mass-normalised stiffness with the hydrostatic one) with
        the masses and stiffnesses of ``bodies`` (``FloatingBodies``)."""
        from scipy.sparse import coo_matrix

        keep = np.flatnonzero(self.cm.intact)
        T = self._t()[keep]
        K6 = np.einsum("kai,kab,kbj->kij", T, self.local()[keep], T)
        dof = np.column_stack([3 * self.ji[keep] + m for m in range(3)]
                              + [3 * self.jj[keep] + m for m in range(3)])
        r = np.repeat(dof, 6, axis=1).ravel()
        c = np.tile(dof, (1, 6)).ravel()
        K = coo_matrix((K6.ravel(), (r, c)), shape=(3 * self.n, 3 * self.n)).tocsr()
        K.sum_duplicates()
        K.sort_indices()
        self.seen = self.cm.intact.copy()
        self.indptr = K.indptr.astype(np.int64)
        self.indices = K.indices.astype(np.int64)
        self.data = K.data.astype(float)
        M = np.column_stack([bodies.M3, bodies.M1, bodies.M2]).ravel()
        C = np.column_stack([bodies.C3, bodies.C1, bodies.C2]).ravel()
        rs = np.sqrt(M)
        rows = np.repeat(np.arange(3 * self.n), np.diff(self.indptr))
        bound = np.zeros(3 * self.n)
        np.add.at(bound, rows, np.abs(self.data) / (rs[rows] * rs[self.indices]))
        free3 = np.repeat(bodies.free, 3)
        w2 = np.max(((C / M) + bound)[free3]) if free3.any() else 0.0
        self.period_min = 2 * math.pi / math.sqrt(w2) if w2 > 0 else math.inf

    def stress(self, u: np.ndarray) -> np.ndarray:
        """Bending stress ``6 M / (w h²)`` [Pa] at every joint line for the state ``u``
        (``3 n``: heave and principal slopes), from the beam's cubic at ``x = a_i``."""
        U = u.reshape(-1, 3)
        wi, wj = U[self.ji, 0], U[self.jj, 0]
        ti = np.sum(self.pi * U[self.ji, 1:], axis=1)
        tj = np.sum(self.pj * U[self.jj, 1:], axis=1)
        L = self.L
        xi = self.ai / L
        curv = ((12 * xi - 6) * wi / L**2 + (6 * xi - 4) * ti / L
                + (-12 * xi + 6) * wj / L**2 + (6 * xi - 2) * tj / L)
        M = self.EI * curv
        return 6.0 * M / (self.w * self.h**2)

    def break_overstressed(self, bodies, u: np.ndarray, strength: float, t: float) -> int:
        """Break (mode ``flexure``) the intact joints whose ``|σ|`` exceeds ``strength``."""
        sig = np.abs(self.stress(u))
        k = np.flatnonzero(self.cm.intact & (sig > strength))
        if not len(k):
            return 0
        n = self.cm.break_joints(k, BreakMode.FLEXURE, t)
        self.assemble(bodies)
        return n


#: the working arrays of one call of :func:`advance_bonded` (its sub-steps may be run one by one,
#: :func:`advance_jointed`)
BondedScratch = record_type("BondedScratch", __name__, [
    ("att", "f", 2, "(n, M) attenuation of each wave component at each element's draft [1]"),
    ("F", "f", 1, "(3 n) force and moments on the degrees of freedom now [N, N m]"),
    ("M", "f", 1, "(3 n) inertia of each degree of freedom with added mass [kg, kg m²]"),
    ("B", "f", 1, "(3 n) radiation damping [kg/s, kg m²/s]"),
    ("mu", "f", 1, "(3 n) memory force now (radiation = 'memory') [N, N m]"),
    ("den", "f", 1, "(3 n) the implicit damping's denominator [1]"),
    ("hp", "i", 1, "(1,) where the latest rates are in the ring buffers"),
    ("pw", "f", 1, "(n,) damping power per area over the sub-steps [W m-2], written"),
], doc="Working arrays of the bonded sub-steps (``siku_plugins.floating.bending``).")


def bonded_scratch(n: int, n_waves: int, head: int, pw: np.ndarray) -> tuple:
    """A :data:`BondedScratch` for ``n`` elements and ``n_waves`` wave components, the ring
    buffers' head at ``head``, the power written into ``pw``."""
    return BondedScratch(np.empty((n, n_waves)), np.zeros(3 * n), np.empty(3 * n),
                         np.empty(3 * n), np.zeros(3 * n), np.empty(3 * n),
                         np.array([head], dtype=np.int64), pw)


@njit(cache=True, error_model="numpy")
def _bonded_forces(t, frames, bod, pts, wav, stiff, s, u):
    """``s.F`` at time ``t`` [s] for the state ``u``: buoyancy, the wave's load, the loads,
    the hydrostatic tilt stiffness and the beams' (:func:`advance_bonded`)."""
    free, rho_g, draft, h, area = bod.free, bod.rho_g, bod.draft, bod.h, bod.area
    C1, C2, load = bod.C1, bod.C2, bod.load
    xc, yc, e0, e1 = frames.xc, frames.yc, frames.e0, frames.e1
    acell, cell = wav.acell, wav.cell
    indptr, indices, data = stiff.indptr, stiff.indices, stiff.data
    F, att = s.F, s.att
    n = free.shape[0]
    for i in range(n):
        if not free[i]:
            continue
        f, g1, g2 = excite(t, i, xc[i], yc[i], e0[i], e1[i], pts, acell[cell[i]], att[i], wav)
        d = draft[i]
        ka = rho_g * area[i]
        F[3 * i] = ka * (min(max(d - u[3 * i] + f / area[i], 0.0), h[i]) - d) + load[i]
        F[3 * i + 1] = -C1[i] * u[3 * i + 1] + rho_g * g1
        F[3 * i + 2] = -C2[i] * u[3 * i + 2] + rho_g * g2
    for r in range(3 * n):
        acc = 0.0
        for p in range(indptr[r], indptr[r + 1]):
            acc += data[p] * u[indices[p]]
        F[r] -= acc


@njit(cache=True, error_model="numpy")
def bonded_start(dt, t0, frames, bod, pts, wav, stiff, mem, s, u, v):
    """The set-up of :func:`advance_bonded`'s sub-steps of ``dt`` [s] from ``t0`` [s] in the
    scratch ``s`` (:data:`BondedScratch`): attenuations, inertias, damping, the forces at
    ``t0``, the power's first half-weight."""
    free, draft = bod.free, bod.draft
    kk, depth = wav.k, wav.depth
    K, kidx, hist = mem.K, mem.kidx, mem.hist
    att, M, B, mu, den = s.att, s.M, s.B, s.mu, s.den
    n = free.shape[0]
    natt = kk.shape[0]
    for i in range(n):
        for j in range(natt):
            att[i, j] = attenuation(kk[j], draft[i], depth)
    for i in range(n):
        M[3 * i], M[3 * i + 1], M[3 * i + 2] = bod.M3[i], bod.M1[i], bod.M2[i]
        B[3 * i], B[3 * i + 1], B[3 * i + 2] = bod.B3[i], bod.B1[i], bod.B2[i]
    hd = 0.5 * dt
    memory = K.shape[0] > 0
    L = K.shape[2]
    head = s.hp[0]
    mu[:] = 0.0
    for r in range(3 * n):
        den[r] = 1.0 + hd * B[r] / M[r]
    if memory:
        for r in range(3 * n):
            i, m = r // 3, r % 3
            if free[i]:
                Ki = K[kidx[i], m]
                mu[r] = dt * (0.5 * Ki[0] * hist[i, m, head]
                              + lagged(Ki, hist[i, m], (head - 1) % L, L))
                den[r] = 1.0 + hd * 0.5 * dt * Ki[0] / M[r]
    _bonded_forces(t0, frames, bod, pts, wav, stiff, s, u)
    s.pw[:] = 0.0
    _damping_work(n, free, memory, mu, B, v, -0.5, s.pw)


@njit(cache=True, error_model="numpy")
def bonded_drift(dt, bod, mem, s, u, v):
    """The first half of a sub-step of ``dt`` [s]: the damping's power, the half kick and
    the drift of ``u``."""
    free = bod.free
    F, M, B, mu = s.F, s.M, s.B, s.mu
    n = free.shape[0]
    memory = mem.K.shape[0] > 0
    hd = 0.5 * dt
    _damping_work(n, free, memory, mu, B, v, 1.0, s.pw)
    for r in range(3 * n):
        if free[r // 3]:
            if memory:
                v[r] += hd * (F[r] - mu[r]) / M[r]
            else:
                v[r] += hd * (F[r] - B[r] * v[r]) / M[r]
            u[r] += dt * v[r]


@njit(cache=True, error_model="numpy")
def bonded_kick(k, dt, t0, frames, bod, pts, wav, stiff, mem, s, u, v):
    """The second half of sub-step ``k`` (from 0) of ``dt`` [s] from ``t0`` [s]: the forces
    at its end for the drifted ``u``, the (implicitly damped) half kick, the ring buffers."""
    free = bod.free
    K, kidx, hist = mem.K, mem.kidx, mem.hist
    F, M, mu, den = s.F, s.M, s.mu, s.den
    n = free.shape[0]
    memory = K.shape[0] > 0
    L = K.shape[2]
    hd = 0.5 * dt
    hp = s.hp[0]
    _bonded_forces(t0 + (k + 1) * dt, frames, bod, pts, wav, stiff, s, u)
    for r in range(3 * n):
        i = r // 3
        if not free[i]:
            continue
        if memory:
            m = r % 3
            Ki = K[kidx[i], m]
            rest = dt * lagged(Ki, hist[i, m], hp, L)
            v[r] = (v[r] + hd * (F[r] - rest) / M[r]) / den[r]
            mu[r] = rest + 0.5 * dt * Ki[0] * v[r]
        else:
            v[r] = (v[r] + hd * F[r] / M[r]) / den[r]
    if memory:
        hp = (hp + 1) % L
        s.hp[0] = hp
        for r in range(3 * n):
            if free[r // 3]:
                hist[r // 3, r % 3, hp] = v[r]


@njit(cache=True, error_model="numpy")
def bonded_end(n_sub, bod, mem, s, v):
    """The end of :func:`advance_bonded`: the power's last half-weight, per area, averaged
    over the ``n_sub`` sub-steps."""
    free, area = bod.free, bod.area
    n = free.shape[0]
    _damping_work(n, free, mem.K.shape[0] > 0, s.mu, s.B, v, 0.5, s.pw)
    for i in range(n):
        s.pw[i] /= n_sub * area[i]


@njit(cache=True, error_model="numpy")
def _bonded_steps_t(n_sub, dt, t0, frames_t, bod_t, pts_t, wav_t, stiff_t, mem_t, s_t, u, v):
    """:func:`_bonded_steps` with its records as plain tuples, named again here."""
    _bonded_steps(n_sub, dt, t0, Frames(*frames_t), FloatingBodies(*bod_t),
                  FloatingPoints(*pts_t), FloatingWave(*wav_t), BeamStiffness(*stiff_t),
                  RadiationMemory(*mem_t), BondedScratch(*s_t), u, v)


@njit(cache=True, error_model="numpy")
def _bonded_steps(n_sub, dt, t0, frames, bod, pts, wav, stiff, mem, s, u, v):
    bonded_start(dt, t0, frames, bod, pts, wav, stiff, mem, s, u, v)
    for k in range(n_sub):
        bonded_drift(dt, bod, mem, s, u, v)
        bonded_kick(k, dt, t0, frames, bod, pts, wav, stiff, mem, s, u, v)
    bonded_end(n_sub, bod, mem, s, v)


def advance_bonded(n_sub, dt, t0, frames, bod, pts, wav, stiff, mem, u, v, pw, exchange=None):
    """:func:`siku_plugins.floating.kernels.advance` with the beams' stiffness ``stiff``
    (:data:`BeamStiffness`, over the ``3 n`` degrees of freedom ``u``, velocities ``v``, both
    in place) and the constant vertical loads ``bod.load`` [N]: the same velocity Verlet,
    every element at once per sub-step, each at ``frames`` (``kernels.Frames``). With
    ``mem.K`` not empty (``radiation = "memory"``: ``siku_plugins.floating.memory
    .RadiationMemory``) the damping ``B v`` is the memory force of
    ``siku_plugins.floating.memory.advance_modes`` (same scheme). ``pw`` [W m-2] receives
    each element's damping (or memory force) power per area averaged over the sub-steps
    (trapezoid of ``B v²`` or ``mu v``). Element ``i`` feels the amplitudes
    ``wav.acell[wav.cell[i]]`` [m] (``kernels.advance``). Returns the ring buffers' head
    after the sub-steps.

    ``exchange`` (a function of ``u`` as ``(n, 3)``, in place; on MPI ranks: the owners'
    rows to the ghosts, ``siku_core.ranks.local.RankLink.to_ghosts``) runs after each
    drift, before the forces that read the partners' ``u``: the sub-steps run one by one,
    each element's arithmetic as in one call."""
    s = bonded_scratch(len(bod.free), len(wav.k), mem.head, pw)
    if exchange is None:
        # plain tuples across the boundary, named again inside (siku_core.records, "At the
        # boundary"): numba types seven records in Python otherwise, every step
        _bonded_steps_t(n_sub, dt, t0, tuple(frames), tuple(bod), tuple(pts), tuple(wav),
                        tuple(stiff), tuple(mem), tuple(s), u, v)
        return int(s.hp[0])
    bonded_start(dt, t0, frames, bod, pts, wav, stiff, mem, s, u, v)
    for k in range(n_sub):
        bonded_drift(dt, bod, mem, s, u, v)
        exchange(u.reshape(-1, 3))
        bonded_kick(k, dt, t0, frames, bod, pts, wav, stiff, mem, s, u, v)
    bonded_end(n_sub, bod, mem, s, v)
    return int(s.hp[0])


@njit(cache=True, inline="always")
def _damping_work(n, free, mem, mu, B, v, w, pw):
    """Add ``w`` times each free element's damping (``mem``: memory) force times its rates
    to ``pw``."""
    for r in range(3 * n):
        if free[r // 3]:
            pw[r // 3] += w * (mu[r] if mem else B[r] * v[r]) * v[r]


def equilibrium(bodies, beams, n: int) -> np.ndarray:
    """The static state ``(n, 3)`` (heave [m], principal slopes) of the floating elements
    ``bodies`` (``FloatingBodies``) joined by ``beams`` (:class:`Beams` or None) under their
    ``load`` in still water, linear: ``(K_beams + C) u = F`` (scipy's sparse solver)."""
    from scipy.sparse import csr_matrix, diags
    from scipy.sparse.linalg import spsolve

    C = np.column_stack([bodies.C3, bodies.C1, bodies.C2]).ravel()
    K = diags(C)
    if beams is not None:
        b = beams
        K = K + csr_matrix((b.data, b.indices, b.indptr), shape=(3 * n, 3 * n))
    F = np.column_stack([bodies.load, np.zeros(n), np.zeros(n)]).ravel()
    keep = np.repeat(bodies.free, 3)
    u = np.zeros(3 * n)
    u[keep] = spsolve(K.tocsr()[keep][:, keep].tocsc(), F[keep])
    return u.reshape(n, 3)


def advance_jointed(n_sub, dt, t0, q, field, bodies, points, wave, beams, memory, f,
                    exchange=None):
    """``n_sub`` sub-steps of ``dt`` [s] from ``t0`` of the floating elements ``bodies`` with
    beams between jointed elements (``beams``, or None) or loads: all elements together in
    each sub-step (:func:`advance_bonded`), at their centres on the plane of ``field`` (the
    wave field, or None) at orientations ``q``, in the wave ``wave`` (``kernels.FloatingWave``)
    with the radiation ``memory`` (``siku_plugins.floating.memory.Memory``, or None). The
    per-element fields ``f`` (heave, roll, pitch, their rates, ``wave_radiated_power``) are
    advanced in place; returns the state ``u`` (``3 n``: heave and principal slopes) at the
    end, from which :meth:`Beams.break_overstressed` finds the joints that break.
    ``exchange``: :func:`advance_bonded`'s (on MPI ranks, the ghosts' rows each sub-step)."""
    n = q.shape[0]
    if field is not None:
        lat, lon, e0, e1 = centres_and_frames(q)
        xc, yc = field.plane(lat, lon)
    else:
        xc = yc = e1 = np.zeros(n)
        e0 = np.ones(n)
    if beams is not None:
        stiff = beams.stiffness()
    else:
        stiff = BeamStiffness(np.zeros(3 * n + 1, dtype=np.int64), np.zeros(0, dtype=np.int64),
                              np.zeros(0))
    c, s = bodies.cphi, bodies.sphi
    sx, sy = -f["pitch"], f["roll"]
    wx, wy = -f["pitch_rate"], f["roll_rate"]
    u = np.column_stack([f["heave"], sx * c + sy * s, -sx * s + sy * c]).ravel()
    v = np.column_stack([f["heave_rate"], wx * c + wy * s, -wx * s + wy * c]).ravel()
    mem = memory.kernels() if memory is not None else RadiationMemory(
        np.zeros((0, 3, 1)), np.zeros(0, dtype=np.int64), np.zeros((0, 3, 1)), 0)
    advance_bonded(n_sub, dt, t0, Frames(xc, yc, e0, e1), bodies, points, wave, stiff, mem, u,
                   v, f["wave_radiated_power"], exchange)
    if memory is not None:
        memory.head = (memory.head + n_sub) % memory.K.shape[2]
    U, W = u.reshape(-1, 3), v.reshape(-1, 3)
    f["heave"][:] = U[:, 0]
    f["heave_rate"][:] = W[:, 0]
    f["pitch"][:] = -(U[:, 1] * c - U[:, 2] * s)
    f["roll"][:] = U[:, 1] * s + U[:, 2] * c
    f["pitch_rate"][:] = -(W[:, 1] * c - W[:, 2] * s)
    f["roll_rate"][:] = W[:, 1] * s + W[:, 2] * c
    return u


def shortest_period(bodies, beams=None) -> float:
    """Shortest natural period [s] of any free element's heave, roll and pitch modes of the
    floating elements ``bodies`` (``FloatingBodies``) and of their ``beams`` (``inf``
    without a free element)."""
    free = bodies.free
    out = math.inf
    if free.any():
        w2 = np.concatenate([(bodies.C3 / bodies.M3)[free], (bodies.C1 / bodies.M1)[free],
                             (bodies.C2 / bodies.M2)[free]])
        out = float(2 * math.pi / math.sqrt(w2.max()))
    if beams is not None:
        out = min(out, beams.period_min)
    return out


def joint_stresses(bodies, beams, f) -> np.ndarray:
    """Bending stress [Pa] at every joint line of ``beams`` between the floating elements
    ``bodies`` (``FloatingBodies``) from their per-element fields ``f`` (heave, roll,
    pitch)."""
    c, s = bodies.cphi, bodies.sphi
    sx, sy = -f["pitch"], f["roll"]
    u = np.column_stack([f["heave"], sx * c + sy * s, -sx * s + sy * c]).ravel()
    return beams.stress(u)
