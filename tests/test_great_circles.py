"""V2 great circles (docs/explanation/physics.md §8): free motion of one element on the sphere,
no forcing.

Exact solution. The element is a rigid body turning about the planet centre with body-frame
angular velocity ``Omega = (-Vy/R, Vx/R, w)`` and inertia ``diag(mR², mR², I)``; with no forces
Euler's equations give ``dV/dt = -g w k × V`` (``g = 1 - k``, ``k = I/(mR²)``), ``dw/dt = 0``:
the torque-free symmetric top. Its solution is::

    q(t) = q0 ∘ exp(t Omega_L / 2) ∘ rz(g w t),     Omega_L = (-Vy0/R, Vx0/R, k w)

so the centre ``p = R(q) e_z`` turns about the *fixed* global axis ``L̂ = R(q0) Omega_L/|Omega_L|``
(the direction of the angular momentum about the planet centre) at the rate
``a = |Omega_L| = sqrt(u² + (k w)²)``, ``u = |V|/R``.

* Without spin ``L̂`` is the normal of the great circle through ``p0`` along ``V0``: the path is
  that great circle.
* With spin the angular momentum ``I w`` about the local vertical tilts ``L̂`` towards ``p0``
  by ``delta``, ``sin(delta) = k w / a``: the centre runs on a small circle whose distance from
  the initial great-circle plane is ``d(t) = R sin(delta) cos(delta) (1 - cos(a t))`` — at most
  ``2 R k w / u ≈ 31 m`` here (10 km square: ``k = 4.1e-7``; ``w/u = 6``), i.e. 8e-7 of the
  40 000 km path. This is the physics of Euler's equations, not an error; the test checks it.
  Without the gyroscopic term the velocity would stay fixed in the spinning body frame and the
  element would run round a circle of radius ``|V|/w ≈ 1060 km`` instead.

Numerical solutions (derivations in docs/explanation/kinematics.md):

* ``siku2`` (free motion: kick = 0, drift = ``q ∘ p(Omega_L dt) ∘ rz(g w dt)``) turns the centre
  about the exact axis ``L̂`` by ``4 atan(a dt / 4)`` per step (eq. 6 with ``dt²``) — the only
  error is that angle: per step ``-(a dt)³/48``, after time ``t`` an along-track lag
  ``R a t (a dt)²/48`` (second order). Trajectories match this to round-off.
* ``rk4`` (per-stage renormalised quaternion): from a symbolic series of one step,
  per-step angle error ``c5 dt⁵`` (``c5`` in :func:`rk4_c5`; ``-u⁵/5120`` without spin), the
  axis tilted by ``tau4 dt⁴`` towards ``p0`` and ``|V|`` shrinking by ``(g w dt)⁶/144`` per step
  (RK4's amplification factor on a rotation), which slows the orbit: after ``t`` a further lag
  ``R u t² (g w)⁶ dt⁵ / 288``.

Round-off: each step rounds ``q`` at ~``eps`` per operation; we bound the accumulated position
error by :func:`roundoff` = ``10 eps R`` per step (linear growth, ~10 rounded operations per
component per step).
"""
from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest

from siku_core.geometry.quat import centers, latlon_of, qrotate
from siku_core.plugins import get_registry
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene

R = 6_371_000.0
DAY = 86400.0
U = math.radians(60.0) * R / DAY  # 60°/day: 77.2 m/s
SPIN = 2 * math.pi / DAY  # one turn per day
T_END = 6 * DAY
EPS = np.finfo(float).eps
DT = {"siku2": 300.0, "rk4": 600.0}

#: (centre lon, lat) [deg], velocity (east, north) [m/s]
CASES = {
    "equator_east": ((0.0, 0.0), (U, 0.0)),
    "meridian_south": ((0.0, 30.0), (0.0, -U)),  # over the South Pole after 2 days
    "oblique_45": ((40.0, 20.0), (U / math.sqrt(2), U / math.sqrt(2))),
    "antimeridian_east": ((179.9, 0.0), (U, 0.0)),
    "antimeridian_oblique": ((179.9, -10.0), (U / math.sqrt(2), -U / math.sqrt(2))),
    "near_pole_east": ((0.0, 89.9), (U, 0.0)),
    "over_pole_north": ((30.0, 89.9), (0.0, U)),  # crosses the North Pole 11 km on
}


def roundoff(n_steps: int) -> float:
    """Bound on the accumulated round-off of the centre position after ``n_steps`` [m]."""
    return 10.0 * EPS * R * max(n_steps, 1)


def rodrigues(p, axis, ang):
    """Rotate unit vector(s) ``p`` about unit ``axis`` by ``ang`` (array or scalar)."""
    ang = np.asarray(ang, dtype=float)[..., None]
    return (p * np.cos(ang) + np.cross(axis, p) * np.sin(ang)
            + axis * np.dot(p, axis) * (1 - np.cos(ang)))


def rk4_c5(u: float, w: float, g: float) -> float:
    """Leading coefficient of RK4's per-step orbit-angle error, ``dtheta = c5 dt⁵``.

    From a symbolic Taylor expansion (sympy) of one step of siku_plugins.integrators.RK4 (with
    its per-stage renormalisation of q) for the free symmetric top, compared with
    ``exp(Omega_L dt)``; ``a = sqrt(u² + (1-g)² w²)``. Without spin: ``-u⁵/5120`` (plain RK4 on
    the same linear ODE would give ``-u⁵/1920``; the stage renormalisation changes the constant,
    not the order).
    """
    a = math.sqrt(u * u + (1 - g) ** 2 * w * w)
    poly = (128 * g**6 * w**6 - 128 * g**5 * w**6 + 224 * g**4 * u**2 * w**4
            + 104 * g**3 * u**2 * w**4 - 16 * g**2 * u**4 * w**2 - 16 * g**2 * u**2 * w**4
            - 3 * g * u**4 * w**2 - 6 * g * u**2 * w**4 - 3 * g * w**6 + 3 * u**6
            + 9 * u**4 * w**2 + 9 * u**2 * w**4 + 3 * w**6)
    return -poly / (15360 * a)


def rk4_tau4(u: float, w: float, g: float) -> float:
    """Leading coefficient of the tilt of RK4's orbit axis towards ``p0``: ``tau4 dt⁴`` [rad]."""
    return g * w * (32 * g**2 * u**2 * w**2 + 24 * g**2 * w**4 - 8 * g * u**2 * w**2
                    - 8 * g * w**4 + 9 * u**4 + 18 * u**2 * w**2 + 9 * w**4) / (3072 * u)


def qmul_np(a, b):
    """Hamilton product of quaternion arrays ``(..., 4)`` (scalar first)."""
    a0, a1, a2, a3 = np.moveaxis(a, -1, 0)
    b0, b1, b2, b3 = np.moveaxis(b, -1, 0)
    return np.stack([a0 * b0 - a1 * b1 - a2 * b2 - a3 * b3,
                     a0 * b1 + a1 * b0 + a2 * b3 - a3 * b2,
                     a0 * b2 - a1 * b3 + a2 * b0 + a3 * b1,
                     a0 * b3 + a1 * b2 - a2 * b1 + a3 * b0], axis=-1)


def rotation_angle_between(qa, qb):
    """Angle [rad] of the rotation taking orientation(s) ``qb`` to ``qa`` (robust form)."""
    qa, qb = np.atleast_2d(qa), np.atleast_2d(qb)
    conj = qb * np.array([1.0, -1.0, -1.0, -1.0])
    d = qmul_np(conj, qa)
    return 2 * np.arctan2(np.linalg.norm(d[:, 1:], axis=1), np.abs(d[:, 0]))


# --------------------------------------------------------------------------- runs
class Run:
    """One free-motion run with the centre, |q|, |V| and w recorded at every step."""

    def __init__(self, case: str, spin: float, integrator: str, dt: float, record: bool = True):
        (lon, lat), vel = CASES[case]
        scene = make_scene(
            elements=[{"center": (lon, lat), "velocity": vel, "spin": spin}],
            integrator=integrator, dt=dt, duration=T_END, thickness=1.0, size=10e3,
            run={"nan_check_every": 100000},
        )
        sim = Simulation(scene, out=False, progress=False)
        st = sim.state
        self.dt, self.n = dt, round(T_END / dt)
        self.k = float(st.I[0] / (st.m[0] * R * R))
        self.g = 1.0 - self.k
        self.w0 = float(st.w[0])
        self.V0 = st.V[0].copy()
        self.u = float(np.linalg.norm(self.V0)) / R
        q0 = st.q[0].copy()
        omega_L = np.array([-self.V0[1] / R, self.V0[0] / R, self.k * self.w0])
        self.a = float(np.linalg.norm(omega_L))
        self.axis = qrotate(q0, omega_L / self.a)  # L̂, fixed in space
        self.p0 = centers(st.q)[0].copy()
        v_glob = qrotate(q0, np.array([self.V0[0], self.V0[1], 0.0]))
        self.n0 = np.cross(self.p0, v_glob / np.linalg.norm(v_glob))  # great-circle normal
        self.sin_d = float(np.dot(self.p0, self.axis))  # sin(delta) = k w / a
        self.cos_d = math.sqrt(1.0 - self.sin_d**2)
        if record:
            P = np.empty((self.n + 1, 3))
            Q = np.empty((self.n + 1, 4))
            qn = np.empty(self.n + 1)
            vn = np.empty(self.n + 1)
            ws = np.empty(self.n + 1)
            lats = np.empty(self.n + 1)
            lons = np.empty(self.n + 1)
            for i in range(self.n + 1):
                if i:
                    sim.step()
                P[i] = centers(st.q)[0]
                Q[i] = st.q[0]
                qn[i] = np.linalg.norm(st.q[0])
                vn[i] = np.linalg.norm(st.V[0])
                ws[i] = st.w[0]
                la, lo = latlon_of(st.q)
                lats[i], lons[i] = la[0], lo[0]
            self.P, self.Q, self.qnorm, self.vnorm, self.w = P, Q, qn, vn, ws
            self.lat, self.lon = lats, lons
        else:
            sim.run(self.n)
            self.P = centers(st.q)[None, 0]
        self.p_end = centers(st.q)[0].copy()
        self.q0, self.omega_L = q0, omega_L
        self.q_end = st.q[0].copy()
        self.t = np.arange(self.n + 1) * dt

    def exact_q(self, t):
        """Exact orientation(s) ``q0 ∘ exp(t Omega_L / 2) ∘ rz(g w t)`` at time(s) ``t``."""
        t = np.atleast_1d(np.asarray(t, dtype=float))
        half = 0.5 * self.a * t
        e = np.zeros((t.size, 4))
        e[:, 0] = np.cos(half)
        e[:, 1:] = np.sin(half)[:, None] * (self.omega_L / self.a)
        rz = np.zeros((t.size, 4))
        rz[:, 0] = np.cos(0.5 * self.g * self.w0 * t)
        rz[:, 3] = np.sin(0.5 * self.g * self.w0 * t)
        return qmul_np(qmul_np(np.broadcast_to(self.q0, e.shape), e), rz)

    def exact(self, t):
        """Exact centre(s) at time(s) ``t``."""
        return rodrigues(self.p0, self.axis, self.a * np.asarray(t))

    def end_error(self) -> float:
        """Distance [m] of the final centre from the exact one."""
        return R * float(np.linalg.norm(self.p_end - self.exact(T_END)))

    def predicted_end_error(self, integrator: str) -> float:
        """Leading-order end-point error [m] from the integrator's error constants."""
        h, t = self.dt, T_END
        if integrator == "siku2":  # exact for this scheme: only the Cayley angle is off
            dphi = self.n * 4 * math.atan(self.a * h / 4) - self.a * t
            return 2 * R * self.cos_d * abs(math.sin(dphi / 2))
        lag = (t * abs(rk4_c5(self.u, self.w0, self.g)) * h**4
               + self.u * t * t * (self.g * self.w0) ** 6 * h**5 / 288)
        return R * self.cos_d * lag

    def plane_distance(self) -> np.ndarray:
        """Signed distance [m] of the centre from the initial great-circle plane, per step."""
        return R * (self.P @ self.n0)


@cache
def run(case: str, spin: bool, integrator: str) -> Run:
    return Run(case, SPIN if spin else 0.0, integrator, DT[integrator])


# --------------------------------------------------------------------------- tests
PARAMS = [(c, s, i) for c in CASES for s in (False, True) for i in ("siku2", "rk4")]


def _id(p):
    return f"{p[0]}-{'spin' if p[1] else 'nospin'}-{p[2]}"


@pytest.mark.parametrize("case,spin,integrator", PARAMS, ids=[_id(p) for p in PARAMS])
def test_returns_to_start_after_six_days(case, spin, integrator):
    """After 6 days (one full turn at 60°/day) the element is back where it started.

    The end-point error against the exact solution must equal the leading-order prediction
    from the integrator's error constants (module docstring): siku2 exactly (the prediction is
    its whole error; tolerance 1e-6 relative + round-off), rk4 to 1 % (the next terms are
    smaller by O((a dt)², (w dt)²) ≤ 2e-3 at dt = 600 s) + round-off. The distance to the
    starting point adds the exact orbit's own miss, ``2 R cos(delta) sin(|a T - 2 pi|/2)``
    (a > u by (k w)²/(2u): 1e-4 m with spin, 0 without).
    """
    r = run(case, spin, integrator)
    err = r.end_error()
    pred = r.predicted_end_error(integrator)
    ro = roundoff(r.n)
    rel = 1e-6 if integrator == "siku2" else 1e-2
    assert abs(err - pred) <= rel * pred + ro, (err, pred)
    exact_miss = 2 * R * r.cos_d * abs(math.sin((r.a * T_END - 2 * math.pi) / 2))
    back = R * float(np.linalg.norm(r.p_end - r.p0))
    assert back <= pred * (1 + rel) + exact_miss + ro
    # for the record: siku2 at 300 s misses by 11 m after 40 000 km, rk4 at 600 s by 4 m (spin)
    # or 2e-5 m (no spin)
    assert back < (12.0 if integrator == "siku2" else 4.0)


@pytest.mark.parametrize("case,spin,integrator", PARAMS, ids=[_id(p) for p in PARAMS])
def test_path_follows_exact_solution(case, spin, integrator):
    """Distance from the initial great-circle plane at every step, against the exact one.

    Without spin: zero (both schemes turn ``q`` about a fixed body axis that is the great-circle
    normal), to round-off. With spin: ``d(t) = R sin(delta) cos(delta) (1 - cos(a t))`` (module
    docstring): siku2 runs on exactly that circle with phase ``n 4 atan(a dt/4)``; rk4's axis
    is tilted by ``tau4 dt⁴`` (d scales by ``1 + tau4 dt⁴ / delta``), phase error negligible
    here; allowance 1 % of that tilt term (next order O((w dt)²)) + round-off.
    """
    r = run(case, spin, integrator)
    d = r.plane_distance()
    ro = np.array([roundoff(i) for i in range(r.n + 1)]) + roundoff(1)
    if not spin:
        assert np.all(np.abs(d) <= ro)
        return
    if integrator == "siku2":
        phi = np.arange(r.n + 1) * 4 * math.atan(r.a * r.dt / 4)
        expect = R * r.sin_d * r.cos_d * (1 - np.cos(phi))
        assert np.all(np.abs(d - expect) <= 1e-9 * R * r.sin_d + ro)
    else:
        tilt = rk4_tau4(r.u, r.w0, r.g) * r.dt**4
        delta = math.asin(r.sin_d) + tilt
        phi = r.a * r.t
        expect = R * math.sin(delta) * math.cos(delta) * (1 - np.cos(phi))
        assert np.all(np.abs(d - expect) <= 0.01 * 2 * R * tilt + ro)
        # (at dt = 600 s the tilt is 7.5 % of delta: rk4's offset peaks at 33.8 m, not 31.4 m)
    # the physical offset is really there: max d = 2 R sin(delta) cos(delta) ≈ 31 m
    assert 25.0 < d.max() < 40.0


@pytest.mark.parametrize("case,spin,integrator", PARAMS, ids=[_id(p) for p in PARAMS])
def test_orientation_follows_exact_solution(case, spin, integrator):
    """The whole orientation ``q`` (centre *and* azimuth: the element spins) at every step.

    Error angle = angle of the rotation from the exact ``q(t)`` to the model's.

    * siku2: ``q_n = q0 ∘ p(Omega_L dt)^n ∘ rz(n g w dt)`` exactly (the gyroscopic turn of V and
      the extra ``rz`` commute through the next step's ``p``), so the error is a rotation about
      ``Omega_L`` by ``|n 4 atan(a dt/4) - a t|``: checked to 1e-9 relative + round-off.
    * rk4: two leading errors about (nearly) perpendicular axes — the orbit lag about ``L̂``,
      ``e2 = |c5| t dt⁴ + u t² (g w)⁶ dt⁵/288``, and the spin-angle lag about the local vertical
      from RK4's phase error on the rotation of V, ``e1 = t (g w)⁵ dt⁴/120``: at the end
      ``hypot(e1, e2)`` to 1 %; at every step at most ``e1 + e2 + 2 tau4 dt⁴`` (axis tilt).
    """
    r = run(case, spin, integrator)
    ang = rotation_angle_between(r.Q, r.exact_q(r.t))
    ro = np.array([roundoff(i) for i in range(r.n + 1)]) / R + 1e-15
    if integrator == "siku2":
        pred = np.abs(np.arange(r.n + 1) * 4 * np.arctan(r.a * r.dt / 4) - r.a * r.t)
        assert np.all(np.abs(ang - pred) <= 1e-9 * pred.max() + ro)
    else:
        h, t, nu = r.dt, r.t, r.g * r.w0
        e1 = t * abs(nu) ** 5 * h**4 / 120
        e2 = t * abs(rk4_c5(r.u, r.w0, r.g)) * h**4 + r.u * t * t * nu**6 * h**5 / 288
        tilt = rk4_tau4(r.u, r.w0, r.g) * h**4
        assert np.all(ang <= 1.01 * (e1 + e2) + 2 * tilt + ro)
        end = math.hypot(e1[-1], e2[-1])
        assert abs(ang[-1] - end) <= 0.01 * end + ro[-1]


@pytest.mark.parametrize("case", list(CASES))
@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_spinning_element_keeps_its_great_circle(case, integrator):
    """Spinning and non-spinning runs follow the same great circle (gyroscopic term).

    They differ only by the tilt ``delta`` of the orbit axis: at most ``2 R sin(delta)`` ≈ 31 m
    (reached half-way round), plus the phase difference ``(a - u) t`` (1e-4 m) and the two
    runs' integration errors: rk4's axis-tilt term ``2 R tau4 dt⁴`` (2.4 m at 600 s) and the
    difference of the two runs' along-track lags (≤ the sum of their end-point errors, which
    grow monotonically; for siku2 the lags are equal up to O((k w)²)). Without the gyroscopic
    term the spinning element would leave the great circle by ~2000 km.
    """
    r1, r0 = run(case, True, integrator), run(case, False, integrator)
    diff = R * np.linalg.norm(r1.P - r0.P, axis=1)
    bound = 2 * R * r1.sin_d
    extra = 1e-3 + roundoff(r1.n)
    if integrator == "rk4":
        extra += 2 * R * rk4_tau4(r1.u, r1.w0, r1.g) * r1.dt**4
        extra += r1.predicted_end_error("rk4") + r0.predicted_end_error("rk4")
    assert diff.max() <= bound + extra
    assert diff.max() >= bound - extra  # and the offset is really there, as Euler says


@pytest.mark.parametrize("spin", [False, True])
@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_equator_stays_on_equator(spin, integrator):
    """Eastward along the equator: max |lat| ≤ the exact offset ``asin(2 sin d cos d)``.

    Without spin this is 0 (round-off bound ``roundoff(n)/R``); with spin it is the tilt of the
    orbit (2.8e-4° ≈ 31 m), plus rk4's axis-tilt error ``2 tau4 dt⁴``.
    """
    r = run("equator_east", spin, integrator)
    bound = 2 * r.sin_d * r.cos_d + roundoff(r.n) / R
    if integrator == "rk4":
        bound += 2 * rk4_tau4(r.u, r.w0, r.g) * r.dt**4
    assert np.abs(r.lat).max() <= math.asin(min(bound, 1.0))
    if not spin:
        assert np.abs(r.lat).max() * R < 1e-4  # metres


@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_antimeridian_longitudes(integrator):
    """Longitudes wrap cleanly across ±180°: every step's lon is the exact one, wrapped.

    lon error ≤ (along-track error so far + orbit offset) / R, both from the bounds above.
    """
    for spin in (False, True):
        r = run("antimeridian_east", spin, integrator)
        ex = r.exact(r.t)
        lon_ex = np.arctan2(ex[:, 1], ex[:, 0])
        dl = np.angle(np.exp(1j * (r.lon - lon_ex)))
        tol = (r.predicted_end_error(integrator) * 1.01 + 2 * R * r.sin_d + roundoff(r.n)) / R
        assert np.abs(dl).max() <= tol
        # one step east of 179.9° is already west of the antimeridian
        assert r.lon[0] > math.radians(179.8) and r.lon[1] < math.radians(-179.5)


@pytest.mark.parametrize("case,spin,integrator", PARAMS, ids=[_id(p) for p in PARAMS])
def test_invariants_in_free_motion(case, spin, integrator):
    """|q| = 1 to 1e-12; spin w conserved exactly; |V| conserved (siku2) or as RK4 predicts.

    * ``|q|``: both schemes renormalise each step: ``||q| - 1| ≤ few eps``; brief: 1e-12.
    * ``w``: no torque, so both schemes add exact zeros: ``w`` is bit-for-bit constant.
    * ``|V|``: siku2 turns ``V`` by an exact rotation (cos/sin, round-off ``2 eps`` per step),
      none without spin; rk4 multiplies it per step by ``|T4(i g w dt)| = 1 - (g w dt)⁶/144``
      (``T4`` the degree-4 Taylor polynomial of exp), so after ``n`` steps
      ``|V|/|V0| - 1 = -n (g w dt)⁶/144`` (1e-7 at dt = 600 s), checked to 1 % + round-off.
    """
    r = run(case, spin, integrator)
    assert np.abs(r.qnorm - 1).max() <= 1e-12
    assert np.all(r.w == r.w0)
    rel = r.vnorm / r.vnorm[0] - 1.0
    if integrator == "siku2" or not spin:
        assert np.abs(rel).max() <= 4 * EPS * r.n
        if not spin:
            assert np.all(r.vnorm == r.vnorm[0])
    else:
        pred = -np.arange(r.n + 1) * (r.g * r.w0 * r.dt) ** 6 / 144
        assert np.all(np.abs(rel - pred) <= 0.01 * np.abs(pred) + 4 * EPS * (r.n + 1))


# --------------------------------------------------------------------------- convergence
#: dt series per (integrator, spin): 6 days divisible by each; chosen in the asymptotic range
#: (error constants above) and above the round-off floor (~1e-8 m for rk4)
CONV_DT = {
    ("siku2", False): (1200.0, 600.0, 300.0, 150.0),
    ("siku2", True): (1200.0, 600.0, 300.0, 150.0),
    ("rk4", False): (4800.0, 2400.0, 1200.0, 600.0),
    ("rk4", True): (600.0, 300.0, 150.0, 75.0),
}


@pytest.mark.parametrize("spin", [False, True])
@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_convergence_order(integrator, spin):
    """End-point error (vs the exact solution) falls at the integrator's nominal ``order``.

    Least-squares slope of log(error) vs log(dt) over four dt, within 0.2 of ``order``.
    siku2: error ∝ dt² exactly at leading order (next term relative (a dt)² < 1e-4).
    rk4: leading term ∝ dt⁴; the |V|-decay lag ∝ t² dt⁵ adds a slope excess of O(w dt) at the
    coarse end (measured 4.1 with spin at 600…75 s), and ~0 without spin.
    """
    order = get_registry().get("integrator", integrator).order
    case = "oblique_45"
    dts = CONV_DT[(integrator, spin)]
    errs = []
    for dt in dts:
        r = Run(case, SPIN if spin else 0.0, integrator, dt, record=False)
        errs.append(r.end_error())
        # in the asymptotic range, far from the round-off floor: the error is the leading-order
        # prediction (1e-6 for siku2; 1 % for rk4, next terms O((w dt)²) ≤ 2e-3 relative)
        pred = r.predicted_end_error(integrator)
        rel = 1e-6 if integrator == "siku2" else 1e-2
        assert abs(errs[-1] - pred) <= rel * pred + roundoff(r.n)
        assert pred > 100 * roundoff(r.n) or integrator == "rk4"  # siku2: far above round-off
    p = float(np.polyfit(np.log(dts), np.log(errs), 1)[0])
    print(f"\ngreat circle {integrator} spin={spin}: dt = {dts} s, end error = "
          f"{np.array(errs)} m, order = {p:.4f}")
    assert abs(p - order) < 0.2
