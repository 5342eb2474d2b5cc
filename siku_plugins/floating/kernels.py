"""Kernels of the ``floating`` process: where each element is on the wave field's plane, the
Froude–Krylov load of the incident wave on its bottom, and the time stepping of heave and the
two tilts (``siku_plugins.floating.process`` gives the equations).

The kernels take their bulk data as named records (:mod:`siku_core.records`), declared here
and built by the process (``siku_plugins.floating.process``), which the plugin's modules share:
:data:`FloatingBodies` (each element's waterplane, masses, damping and stiffness),
:data:`FloatingPoints` (the quadrature points of each bottom and their lattice),
:data:`FloatingWave` (the incident wave and the loads added to it) and :data:`FloatingMotion`
(the process's per-element fields, which the kernels advance in place)."""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from siku_core.geometry.quat import east_north_row
from siku_core.parallel import chunk_bounds
from siku_core.records import record_type

#: the floating elements: built once by the process's set-up (its arrays change in place only:
#: ``radiation = "memory"`` sets the masses, ``loads`` the loads)
FloatingBodies = record_type("FloatingBodies", __name__, [
    ("free", "b", 1, "the element floats (free elements only)"),
    ("phi", "f", 1, "angle of the waterplane's first principal axis from the element's "
     "local x axis [rad]"),
    ("cphi", "f", 1, "cos(phi) [1]"),
    ("sphi", "f", 1, "sin(phi) [1]"),
    ("h", "f", 1, "thickness h [m]"),
    ("draft", "f", 1, "draft d = h rho_i / rho_w [m]"),
    ("area", "f", 1, "waterplane area A [m²]"),
    ("J1", "f", 1, "second moment of the waterplane about its first principal axis [m⁴]"),
    ("J2", "f", 1, "second moment about the second principal axis [m⁴]"),
    ("M3", "f", 1, "heave inertia with added mass, m + A33 (or A_inf) [kg]"),
    ("B3", "f", 1, "heave radiation damping B33 [kg/s]"),
    ("C3", "f", 1, "heave hydrostatic stiffness rho_w g A [N/m]"),
    ("M1", "f", 1, "inertia of slope 1 with added inertia [kg m²]"),
    ("B1", "f", 1, "radiation damping of slope 1 [kg m²/s]"),
    ("C1", "f", 1, "hydrostatic stiffness of slope 1 [N m]"),
    ("M2", "f", 1, "inertia of slope 2 with added inertia [kg m²]"),
    ("B2", "f", 1, "radiation damping of slope 2 [kg m²/s]"),
    ("C2", "f", 1, "hydrostatic stiffness of slope 2 [N m]"),
    ("load", "f", 1, "constant vertical force on the element, upward positive [N]"),
    ("rho_g", "n", 0, "rho_w g [N/m³]"),
], doc="The floating elements (``siku_plugins.floating.process``), one entry per element.")

#: the quadrature of each free element's bottom (``siku_plugins.floating.geometry``)
FloatingPoints = record_type("FloatingPoints", __name__, [
    ("qoff", "i", 1, "(n + 1,) element i's points are qoff[i] .. qoff[i + 1] - 1"),
    ("qa", "f", 1, "point's coordinate along the element's local x axis [m]"),
    ("qb", "f", 1, "point's coordinate along the element's local y axis [m]"),
    ("qu", "f", 1, "point's coordinate along the first principal axis [m]"),
    ("qv", "f", 1, "point's coordinate along the second principal axis [m]"),
    ("qw", "f", 1, "point's weight (the area it stands for) [m²]"),
    ("voff", "i", 1, "(n + 1,) element i's polygon vertices voff[i] .. voff[i + 1] - 1"),
    ("m6", "i", 1, "(n,) the lattice's denominator of each element"),
    ("vx", "f", 1, "vertex x in the element's local frame [m]"),
    ("vy", "f", 1, "vertex y [m]"),
    ("ia", "i", 1, "point's index of its first vertex power in the table Z"),
    ("ib", "i", 1, "point's index of its second vertex power"),
    ("zsize", "n", 0, "size of the table Z of vertex powers"),
], doc="The quadrature points and their lattice (``siku_plugins.floating.geometry"
       ".lattice_arrays``).")

#: the incident wave as the kernels take it (``Floating.wave``)
FloatingWave = record_type("FloatingWave", __name__, [
    ("lat0", "n", 0, "latitude of the wave field's origin [rad]"),
    ("lon0", "n", 0, "longitude of the origin [rad]"),
    ("R", "n", 0, "radius of the model sphere [m]"),
    ("depth", "n", 0, "water depth [m] (inf: deep water)"),
    ("ramp", "n", 0, "the loads grow as (1 - cos(pi t / ramp)) / 2 until t = ramp [s] (0: no "
     "ramp)"),
    ("amp", "f", 1, "(M,) incident amplitude of each component [m]"),
    ("kx", "f", 1, "(M,) wavenumber east [rad/m]"),
    ("ky", "f", 1, "(M,) wavenumber north [rad/m]"),
    ("omega", "f", 1, "(M,) angular frequency [rad/s]"),
    ("phase", "f", 1, "(M,) phase at the origin at t = 0 [rad]"),
    ("k", "f", 1, "(M,) wavenumber's magnitude [rad/m]"),
    ("acell", "f", 2, "(C, M) amplitudes [m] element i feels: the row acell[cell[i]]"),
    ("cell", "i", 1, "(n,) each element's row of acell"),
    ("kap", "f", 4, "(n, M, 3, 2) diffraction factors (real, imaginary) per element, component "
     "and mode, or empty"),
    ("ext", "f", 2, "(n, 3) loads added unramped: (∫ eta dA [m³], ∫ u eta dA, ∫ v eta dA "
     "[m⁴]), or empty"),
], doc="The incident wave of the ``floating`` process (``siku_plugins.floating.process``).")

#: the process's per-element fields, advanced in place
FloatingMotion = record_type("FloatingMotion", __name__, [
    ("heave", "f", 1, "heave z [m]"),
    ("heave_rate", "f", 1, "heave rate [m/s]"),
    ("roll", "f", 1, "roll [rad]"),
    ("roll_rate", "f", 1, "roll rate [rad/s]"),
    ("pitch", "f", 1, "pitch [rad]"),
    ("pitch_rate", "f", 1, "pitch rate [rad/s]"),
    ("power", "f", 1, "radiation damping's power per area over the step [W m-2]"),
], doc="Heave, roll, pitch, their rates and the radiated power of every element.")

#: the elements' centres on the wave field's plane and their local frames
Frames = record_type("Frames", __name__, [
    ("xc", "f", 1, "centre east of the wave field's origin [m]"),
    ("yc", "f", 1, "centre north of the origin [m]"),
    ("e0", "f", 1, "east unit vector's x in the element's local frame [1]"),
    ("e1", "f", 1, "east unit vector's y [1]"),
], doc="Where each element is on the wave field's plane (:func:`centres_and_frames`).")


def motion(fields) -> tuple:
    """The :data:`FloatingMotion` record of the per-element fields ``fields`` (by name)."""
    return FloatingMotion(fields["heave"], fields["heave_rate"], fields["roll"],
                          fields["roll_rate"], fields["pitch"], fields["pitch_rate"],
                          fields["wave_radiated_power"])


@njit(cache=True)
def centres_and_frames(q):
    """``lat, lon`` [rad] of each element's centre and ``e0, e1``: the east unit vector in the
    element's local frame (north is ``(-e1, e0)``)."""
    n = q.shape[0]
    lat = np.empty(n)
    lon = np.empty(n)
    e0 = np.empty(n)
    e1 = np.empty(n)
    for i in range(n):
        z = 1.0 - 2.0 * (q[i, 1] * q[i, 1] + q[i, 2] * q[i, 2])
        x3 = 2.0 * (q[i, 1] * q[i, 3] + q[i, 0] * q[i, 2])
        y3 = 2.0 * (q[i, 2] * q[i, 3] - q[i, 0] * q[i, 1])
        lat[i] = math.asin(max(-1.0, min(1.0, z)))
        lon[i] = math.atan2(y3, x3)
        ex, ey, _, _ = east_north_row(q, i)
        e0[i] = ex
        e1[i] = ey
    return lat, lon, e0, e1


@njit(cache=True, inline="always")
def wave_frame(q, i, wave, R, c0, lat0, lon0):
    """Element ``i``'s centre on the wave field's plane ``(x, y)`` [m] (east and north of the
    field's origin ``lat0, lon0`` [rad], ``c0 = cos(lat0)``) and its local east axis ``(e0,
    e1)``; ``(0, 0, 1, 0)`` without a wave field."""
    if not wave:
        return 0.0, 0.0, 1.0, 0.0
    zq = 1.0 - 2.0 * (q[i, 1] * q[i, 1] + q[i, 2] * q[i, 2])
    x3 = 2.0 * (q[i, 1] * q[i, 3] + q[i, 0] * q[i, 2])
    y3 = 2.0 * (q[i, 2] * q[i, 3] - q[i, 0] * q[i, 1])
    lat = math.asin(max(-1.0, min(1.0, zq)))
    lon = math.atan2(y3, x3)
    dl = lon - lon0
    if dl > math.pi:
        dl -= 2.0 * math.pi
    elif dl < -math.pi:
        dl += 2.0 * math.pi
    e0, e1, _, _ = east_north_row(q, i)
    return R * c0 * dl, R * (lat - lat0), e0, e1


@njit(cache=True, inline="always")
def attenuation(k, d, depth):
    """Pressure of a linear wave at depth ``d`` over that at the surface: ``e^{-k d}`` in deep
    water (``depth`` = inf), ``cosh(k (H - d)) / cosh(k H)`` otherwise (written without
    overflow)."""
    if not math.isfinite(depth):
        return math.exp(-k * d)
    if d >= depth:
        d = depth
    return math.exp(-k * d) * (1.0 + math.exp(-2.0 * k * (depth - d))) / (
        1.0 + math.exp(-2.0 * k * depth))


@njit(cache=True, inline="always")
def excite(t, i, xc, yc, e0, e1, pts, amp, att, wav):
    """``(∫ eta' dA [m³], ∫ u eta' dA, ∫ v eta' dA [m⁴])`` over element ``i``'s bottom (its
    points of ``pts``, :data:`FloatingPoints`; centre ``xc, yc`` [m] and frame ``e0, e1`` on
    the plane of the wave ``wav``, :data:`FloatingWave`),
    ``eta'`` the incident elevation attenuated to the draft (``att`` per component), ``u, v``
    the principal coordinates of the quadrature points. With ``kap`` (``(n, M, 3, 2)``, not
    empty) each component's three complex loads are multiplied by ``kap[i, j, mode]`` (real,
    imaginary): the ratio of capytaine's Froude–Krylov plus diffraction excitation to this
    Froude–Krylov integral (``siku_plugins.floating.hydro.diffraction_factors``). ``ramp`` [s]
    > 0: the loads grow as ``(1 - cos(pi t / ramp)) / 2`` until ``t = ramp``. ``ext`` (``(n,
    3)``, not empty): loads added as they are, not ramped (a coupled model's, through the
    exchange grid: ``siku_plugins.floating.process``). ``amp`` [m]: the amplitudes element
    ``i`` feels (a row of ``wav.acell``)."""
    qa, qb, qu, qv, qw = pts.qa, pts.qb, pts.qu, pts.qv, pts.qw
    lo, hi = pts.qoff[i], pts.qoff[i + 1]
    kx, ky, om, ph = wav.kx, wav.ky, wav.omega, wav.phase
    kap, ramp, ext = wav.kap, wav.ramp, wav.ext
    f = 0.0
    g1 = 0.0
    g2 = 0.0
    use = kap.shape[0] > 0
    for j in range(amp.shape[0]):
        c0 = 0.0
        c1 = 0.0
        c2 = 0.0
        s0 = 0.0
        s1 = 0.0
        s2 = 0.0
        for p in range(lo, hi):
            xe = xc + qa[p] * e0 + qb[p] * e1
            yn = yc - qa[p] * e1 + qb[p] * e0
            psi = kx[j] * xe + ky[j] * yn - om[j] * t + ph[j]
            w = qw[p]
            cs = math.cos(psi)
            c0 += w * cs
            c1 += qu[p] * w * cs
            c2 += qv[p] * w * cs
            if use:
                sn = math.sin(psi)
                s0 += w * sn
                s1 += qu[p] * w * sn
                s2 += qv[p] * w * sn
        aa = amp[j] * att[j]
        if use:
            f += aa * (kap[i, j, 0, 0] * c0 - kap[i, j, 0, 1] * s0)
            g1 += aa * (kap[i, j, 1, 0] * c1 - kap[i, j, 1, 1] * s1)
            g2 += aa * (kap[i, j, 2, 0] * c2 - kap[i, j, 2, 1] * s2)
        else:
            f += aa * c0
            g1 += aa * c1
            g2 += aa * c2
    if ramp > 0.0 and t < ramp:
        r = 0.5 * (1.0 - math.cos(math.pi * max(t, 0.0) / ramp))
        f *= r
        g1 *= r
        g2 *= r
    if ext.shape[0] > 0:
        f += ext[i, 0]
        g1 += ext[i, 1]
        g2 += ext[i, 2]
    return f, g1, g2


@njit(cache=True, inline="always")
def _cis(x):
    """``(cos x, sin x)``; for ``|x| <= 0.2`` (the vertices' phase steps of
    :func:`_sums_lattice`, at most ``0.7 / 6`` with the default quadrature) by their Taylor
    series to ``x^14``, whose remainder, below ``0.2^15 / 15! = 2.5e-23``, is far below
    round-off: a few multiplications instead of two library calls."""
    if abs(x) > 0.2:
        return math.cos(x), math.sin(x)
    x2 = x * x
    sn = x * (1.0 + x2 * (-1.0 / 6.0 + x2 * (1.0 / 120.0 + x2 * (-1.0 / 5040.0 + x2 * (
        1.0 / 362880.0 + x2 * (-1.0 / 39916800.0 + x2 * (1.0 / 6227020800.0)))))))
    cs = 1.0 + x2 * (-0.5 + x2 * (1.0 / 24.0 + x2 * (-1.0 / 720.0 + x2 * (1.0 / 40320.0 + x2 * (
        -1.0 / 3628800.0 + x2 * (1.0 / 479001600.0 + x2 * (-1.0 / 87178291200.0)))))))
    return cs, sn


@njit(cache=True, inline="always")
def _sums_lattice(e0, e1, i, pts, amp, att, wav, S, Z):
    """The part of :func:`excite`'s sums that is fixed within an engine step: ``S[j]`` (row
    of ``(natt, 6)``) ``= a_j att_j Σ_p w_p (1, u_p, v_p) e^{i delta_p}`` as (real, imaginary)
    pairs, ``delta_p = k_j·(x_p - x_c)`` the phase of point ``p`` relative to the element's
    centre (local frame ``e0, e1``); :func:`_turn` and :func:`_load` give the loads, since
    ``cos(psi_c + delta_p) = Re(e^{i psi_c} e^{i delta_p})``. ``pts``
    (:data:`FloatingPoints`) holds the lattice of
    ``siku_plugins.floating.geometry.lattice_arrays``: point ``p`` lies at ``(beta_p v_e +
    gamma_p v_{e+1}) / m6``, so ``e^{i delta_p} = z_e^beta z_{e+1}^gamma`` with ``z_v = e^{i
    k'·v / m6}``: one sine and cosine per vertex (:func:`_cis`), the powers by products (table
    ``Z``, ``(zsize,)``, at ``ia, ib``), one product per point. ``amp`` [m]: the amplitudes
    element ``i`` feels; ``wav``: :data:`FloatingWave`. The same sums as :func:`excite`'s up to
    round-off (a power ``z^m`` carries ``m`` roundings, ``m < m6``)."""
    voff, vx, vy, m6a, ia, ib = pts.voff, pts.vx, pts.vy, pts.m6, pts.ia, pts.ib
    qu, qv, qw = pts.qu, pts.qv, pts.qw
    kx, ky = wav.kx, wav.ky
    lo, hi = pts.qoff[i], pts.qoff[i + 1]
    vlo = voff[i]
    nv = voff[i + 1] - vlo
    m6 = m6a[i]
    w2 = 2 * (m6 - 1)
    # the tables are indexed through unsigned integers: no test for a negative index (the
    # points' loop takes half the time; the same arithmetic)
    for j in range(amp.shape[0]):
        ka = kx[j] * e0 - ky[j] * e1     # d psi / d qa
        kb = kx[j] * e1 + ky[j] * e0     # d psi / d qb
        for v in range(nv):
            u = np.uint64(vlo + v)
            cr, ci = _cis((ka * vx[u] + kb * vy[u]) / m6)
            pr = 1.0
            pim = 0.0
            base = v * w2
            Z[np.uint64(base)] = 1.0
            Z[np.uint64(base + 1)] = 0.0
            for m in range(2, w2, 2):
                pr, pim = pr * cr - pim * ci, pr * ci + pim * cr
                Z[np.uint64(base + m)] = pr
                Z[np.uint64(base + m + 1)] = pim
        r0 = 0.0
        i0 = 0.0
        r1 = 0.0
        i1 = 0.0
        r2 = 0.0
        i2 = 0.0
        for p in range(np.uint64(lo), np.uint64(hi)):
            a = np.uint64(ia[p])
            b = np.uint64(ib[p])
            a1 = np.uint64(ia[p] + 1)
            b1 = np.uint64(ib[p] + 1)
            za = Z[a]
            za1 = Z[a1]
            zb = Z[b]
            zb1 = Z[b1]
            xr = za * zb - za1 * zb1
            xi = za * zb1 + za1 * zb
            wc = qw[p] * xr
            ws = qw[p] * xi
            r0 += wc
            i0 += ws
            r1 += qu[p] * wc
            i1 += qu[p] * ws
            r2 += qv[p] * wc
            i2 += qv[p] * ws
        aa = amp[j] * att[j]
        S[j, 0] = aa * r0
        S[j, 1] = aa * i0
        S[j, 2] = aa * r1
        S[j, 3] = aa * i1
        S[j, 4] = aa * r2
        S[j, 5] = aa * i2


@njit(cache=True)
def clock(t0, dt, n_sub, om, ramp):
    """What the sub-steps' times ``t_k = t0 + k dt`` (``k = 0..n_sub``) share between
    elements: ``E[k, j] = e^{-i omega_j t_k}`` (cosine, sine) and the ramp's factor ``r[k]``
    (:func:`excite`)."""
    natt = om.shape[0]
    E = np.empty((n_sub + 1, natt, 2))
    r = np.ones(n_sub + 1)
    for k in range(n_sub + 1):
        t = t0 + k * dt
        for j in range(natt):
            E[k, j, 0] = math.cos(om[j] * t)
            E[k, j, 1] = -math.sin(om[j] * t)
        if ramp > 0.0 and t < ramp:
            r[k] = 0.5 * (1.0 - math.cos(math.pi * max(t, 0.0) / ramp))
    return E, r


@njit(cache=True, inline="always")
def _turn(xc, yc, kx, ky, ph, S):
    """Multiply each component's sums ``S[j]`` (:func:`_sums_lattice`) by ``e^{i (k·x_c +
    phase)}``, the phase at the element's centre without the time."""
    for j in range(S.shape[0]):
        psi = kx[j] * xc + ky[j] * yc + ph[j]
        cs = math.cos(psi)
        sn = math.sin(psi)
        for m in range(3):
            re = S[j, 2 * m]
            im = S[j, 2 * m + 1]
            S[j, 2 * m] = cs * re - sn * im
            S[j, 2 * m + 1] = sn * re + cs * im


@njit(cache=True, inline="always")
def _load(k, i, S, E, r, kap, ext):
    """:func:`excite` at the sub-step time ``t_k`` of :func:`clock` from the turned sums ``S``
    (:func:`_turn`): ``Σ w cos(psi) = Re(e^{-i omega t_k} S)``, ``Σ w sin(psi) = Im(...)``."""
    f = 0.0
    g1 = 0.0
    g2 = 0.0
    use = kap.shape[0] > 0
    for j in range(S.shape[0]):
        cs = E[k, j, 0]
        sn = E[k, j, 1]
        c0 = cs * S[j, 0] - sn * S[j, 1]
        c1 = cs * S[j, 2] - sn * S[j, 3]
        c2 = cs * S[j, 4] - sn * S[j, 5]
        if use:
            s0 = sn * S[j, 0] + cs * S[j, 1]
            s1 = sn * S[j, 2] + cs * S[j, 3]
            s2 = sn * S[j, 4] + cs * S[j, 5]
            f += kap[i, j, 0, 0] * c0 - kap[i, j, 0, 1] * s0
            g1 += kap[i, j, 1, 0] * c1 - kap[i, j, 1, 1] * s1
            g2 += kap[i, j, 2, 0] * c2 - kap[i, j, 2, 1] * s2
        else:
            f += c0
            g1 += c1
            g2 += c2
    f *= r[k]
    g1 *= r[k]
    g2 *= r[k]
    if ext.shape[0] > 0:
        f += ext[i, 0]
        g1 += ext[i, 1]
        g2 += ext[i, 2]
    return f, g1, g2


@njit(cache=True, error_model="numpy")
def _advance_range(lo_e, hi_e, n_sub, dt, t0, q, bod, pts, wav, mot):
    """Elements ``lo_e`` to ``hi_e`` of :func:`advance`."""
    lat0, lon0, R, depth, ramp, rho_g = wav.lat0, wav.lon0, wav.R, wav.depth, wav.ramp, bod.rho_g
    free = bod.free
    cphi, sphi, draft, h, area = bod.cphi, bod.sphi, bod.draft, bod.h, bod.area
    M3, B3, M1, C1, B1, M2, C2, B2 = (bod.M3, bod.B3, bod.M1, bod.C1, bod.B1, bod.M2, bod.C2,
                                      bod.B2)
    kx, ky, om, ph, kk = wav.kx, wav.ky, wav.omega, wav.phase, wav.k
    acell, cell, kap, ext = wav.acell, wav.cell, wav.kap, wav.ext
    z, vz, roll, roll_rate = mot.heave, mot.heave_rate, mot.roll, mot.roll_rate
    pitch, pitch_rate, pw = mot.pitch, mot.pitch_rate, mot.power
    natt = kx.shape[0]
    wave = natt > 0
    c0 = math.cos(lat0)
    att = np.empty(natt)
    S = np.empty((natt, 6))
    Z = np.empty(pts.zsize)
    E, rk = clock(t0, dt, n_sub if wave else 0, om, ramp)
    d_att = math.nan
    for i in range(lo_e, hi_e):
        if not free[i]:
            continue
        xc, yc, e0, e1 = wave_frame(q, i, wave, R, c0, lat0, lon0)
        d = draft[i]
        if d != d_att:     # the last element's draft: the same factors
            for j in range(natt):
                att[j] = attenuation(kk[j], d, depth)
            d_att = d
        ka = rho_g * area[i]
        _sums_lattice(e0, e1, i, pts, acell[cell[i]], att, wav, S, Z)
        _turn(xc, yc, kx, ky, ph, S)
        f, g1, g2 = _load(0, i, S, E, rk, kap, ext)
        c = cphi[i]
        s = sphi[i]
        # tilts as slopes along the principal axes: (sx, sy) = (-pitch, roll) locally
        sx = -pitch[i]
        sy = roll[i]
        wx = -pitch_rate[i]
        wy = roll_rate[i]
        zi, vzi = z[i], vz[i]
        s1i, s2i = sx * c + sy * s, -sx * s + sy * c
        v1i, v2i = wx * c + wy * s, -wx * s + wy * c
        m3, b3, m1, c1, b1, m2, c2, b2 = (M3[i], B3[i], M1[i], C1[i], B1[i], M2[i], C2[i],
                                          B2[i])
        hd = 0.5 * dt
        den3 = 1.0 + hd * b3 / m3
        den1 = 1.0 + hd * b1 / m1
        den2 = 1.0 + hd * b2 / m2
        e = -0.5 * (b3 * vzi * vzi + b1 * v1i * v1i + b2 * v2i * v2i)  # damping work: pw
        for k in range(n_sub):
            e += b3 * vzi * vzi + b1 * v1i * v1i + b2 * v2i * v2i
            # buoyancy and wave load together saturate once the element is out of the
            # water (0) or under it (rho_w g A h): submergence d - ζ + (wave load)/(rho_w g A)
            fh = ka * (min(max(d - zi + f / area[i], 0.0), h[i]) - d)
            vzh = vzi + hd * (fh - b3 * vzi) / m3
            v1h = v1i + hd * (-c1 * s1i + rho_g * g1 - b1 * v1i) / m1
            v2h = v2i + hd * (-c2 * s2i + rho_g * g2 - b2 * v2i) / m2
            zi += dt * vzh
            s1i += dt * v1h
            s2i += dt * v2h
            if wave:
                f, g1, g2 = _load(k + 1, i, S, E, rk, kap, ext)
            fh = ka * (min(max(d - zi + f / area[i], 0.0), h[i]) - d)
            vzi = (vzh + hd * fh / m3) / den3
            v1i = (v1h + hd * (-c1 * s1i + rho_g * g1) / m1) / den1
            v2i = (v2h + hd * (-c2 * s2i + rho_g * g2) / m2) / den2
        e += 0.5 * (b3 * vzi * vzi + b1 * v1i * v1i + b2 * v2i * v2i)
        pw[i] = e / (n_sub * area[i])
        z[i] = zi
        vz[i] = vzi
        pitch[i] = -(s1i * c - s2i * s)
        roll[i] = s1i * s + s2i * c
        pitch_rate[i] = -(v1i * c - v2i * s)
        roll_rate[i] = v1i * s + v2i * c


@njit(cache=True, parallel=True, error_model="numpy")
def _advance_parallel(nch, n_sub, dt, t0, q, bod_t, pts_t, wav_t, mot_t):
    """:func:`advance` on ``nch`` chunks; the records come as plain tuples (:func:`advance`)."""
    bod, pts = FloatingBodies(*bod_t), FloatingPoints(*pts_t)
    wav, mot = FloatingWave(*wav_t), FloatingMotion(*mot_t)
    n = mot.heave.shape[0]
    for ch in prange(nch):
        lo_e, hi_e = chunk_bounds(ch, nch, n)
        _advance_range(lo_e, hi_e, n_sub, dt, t0, q, bod, pts, wav, mot)


@njit(cache=True, error_model="numpy")
def _advance_serial(n_sub, dt, t0, q, bod_t, pts_t, wav_t, mot_t):
    """:func:`advance` in one chunk; the records come as plain tuples (:func:`advance`)."""
    mot = FloatingMotion(*mot_t)
    _advance_range(0, mot.heave.shape[0], n_sub, dt, t0, q, FloatingBodies(*bod_t),
                   FloatingPoints(*pts_t), FloatingWave(*wav_t), mot)


def advance(nch, n_sub, dt, t0, q, bod, pts, wav, mot):
    """``n_sub`` steps of ``dt`` [s] from ``t0`` [s] for every free element: velocity Verlet,
    the damping taken half explicitly (first half step) and half implicitly (second), so that
    the scheme is second order and, for the linear oscillator, stable for ``omega dt < 2``.
    The element's centre on the wave field's plane (``x = R cos(lat0) (lon - lon0)``, ``y = R
    (lat - lat0)``, as ``siku_forcing.waves.wave_field``) and its local frame come from ``q``; the
    tilts
    are stepped as slopes along the principal axes (angle ``phi``: ``cphi, sphi``) and written
    back as roll and pitch; ``mot.power`` [W m-2] receives the damping's power per area
    averaged over the ``n_sub`` steps (trapezoid of ``B v²`` at the sub-steps). The fields of
    ``mot`` (:data:`FloatingMotion`: heave [m], its rate [m/s], roll, pitch [rad] and their
    rates [rad/s]) change in place; elements are independent, in ``nch`` chunks
    (``siku_core.parallel``), so the result does not depend on the threads.

    ``bod``: :data:`FloatingBodies`; ``pts``: :data:`FloatingPoints`; ``wav``:
    :data:`FloatingWave`. The amplitudes an element feels are the row ``wav.acell[wav.cell[i]]``
    [m]: the local sea of a ``spectral`` field, ``sqrt(2 E_j)`` of the element's grid cell
    (``siku_forcing.waves.spectral``); for a uniform sea one row, the incident ``amp``, and every
    ``cell`` 0. Looked up once per element and step (the sums of :func:`_sums_lattice` carry
    it), so the local sea costs no more per sub-step than a uniform one.

    The records cross into the compiled code as plain tuples and are named again there: numba's
    dispatcher types a plain tuple's fields in C and a namedtuple's in Python, and on the
    184-element floe of ``bench.floating`` (one call a step) the 55 fields cost 8 µs a call as
    namedtuples, 2 µs as tuples (as the positional arguments of old)."""
    if nch > 1:
        _advance_parallel(nch, n_sub, dt, t0, q, tuple(bod), tuple(pts), tuple(wav), tuple(mot))
    else:
        _advance_serial(n_sub, dt, t0, q, tuple(bod), tuple(pts), tuple(wav), tuple(mot))
