"""V1 free drift (docs/explanation/physics.md §8): one element under uniform wind and still water.

Momentum balance of an element of area ``S``, thickness ``h``, mass ``m = rho_i h S``
(docs/explanation/physics.md §3, eqs. 18–20, ``relative = false`` so the wind stress does not
depend on ``U``)::

    m dU/dt = S tau_a + S tau_w - m f k × U,
    tau_a = rho_a C_a |U_a| U_a                              (th_a = 0),
    tau_w = -rho_w C_w |U| e^{i th_w} U                      (still water).

In complex notation (``U = u_east + i u_north``, ``k ×`` is multiplication by ``i``) the steady
state is ``A = U (c |U| e^{i th_w} + i M)`` with ``A = tau_a``, ``c = rho_w C_w`` and
``M = rho_i h f``. Its modulus gives a quartic in ``s = |U|``::

    c² s⁴ + 2 c M sin(th_w) s³ + M² s² - |A|² = 0,

(one positive root), and the turning angle relative to the wind is
``arg(U / U_a) = -arg(c s e^{i th_w} + i M)``.

On the sphere (the model's planet) an element that keeps constant east/north velocity
components is *not* force-free in the spherical sense: its east/north frame turns relative to a
parallel-transported frame at the rate ``u_east tan(lat) / R``. This is the metric term of the
momentum equations in spherical coordinates, ``f -> f + u_east tan(lat)/R``. For ice drifting
due east (a latitude circle: its latitude, hence ``f``, stays fixed) the steady state is
therefore exactly the one above with ``M = rho_i h (f + s tan(lat)/R)``; since ``M`` is linear in
``s`` the equation stays a quartic::

    (c² + 2 c m1 sin th + m1²) s⁴ + 2 M0 (c sin th + m1) s³ + M0² s² - |A|² = 0,
    M0 = rho_i h f,   m1 = rho_i h tan(lat) / R.

The Earth cases below steer the wind so that the ice drifts due east and compare with this
solution; the f-plane case uses a planet ``10⁴`` times larger than the Earth, where the metric
term is below ``1e-8`` relative and the plain quartic of the brief applies. At ``75°N`` on the
Earth the metric term shifts the steady velocity by about ``1e-4`` relative (asserted below), so
a ``1e-6`` comparison is only meaningful with it.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from siku_core.geometry.quat import east_north_local, latlon_of
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene

R_EARTH = 6_371_000.0
OMEGA = 7.2921e-5  # [planet] rotation_rate default, rad/s
RHO_I, RHO_W, C_W, RHO_A, C_A = 910.0, 1026.0, 0.0045, 1.3, 0.0016  # eq. 21 defaults
H = 1.0  # thickness [m]
U_WIND = 10.0  # m/s
A_ABS = RHO_A * C_A * U_WIND**2  # |tau_a| = 0.208 Pa

#: largest ice–water speed in any of these runs, for water_drag's stability estimate. From
#: d|U|²/dt = 2 Re(conj(U) A)/(rho_i h) - 2 b cos(th_w) |U|³ (Coriolis does no work),
#: |U| <= sqrt(|A| / (c cos th_w)) = 0.223 m/s for |th_w| <= 25°; 0.25 m/s bounds it. The
#: declared limit is then m/(S c 0.25) = 788 s and dt must stay below dt_safety × that = 394 s.
MAX_REL_SPEED = 0.25

#: the tolerance of the brief: relative error of the steady velocity
REL_TOL = 1e-6
#: e-folding times of the slowest linear mode to run before comparing. Linearised about the
#: steady state, the drag relaxes the velocity component across U* at b|U*| = 1/T_relax,
#: T_relax = rho_i h / (rho_w C_w |U*|) ≈ 930 s, and along U* twice as fast; Coriolis and the
#: turning angle mix the two (slowest rate from the Jacobian, :func:`slowest_rate`: 1/916 s at
#: 75°N, 1/705 s with th_w = 25°). After N_EFOLD of them the remaining transient is about
#: |U*| exp(-N_EFOLD) ≈ 1e-10 |U*| (for the tanh spin-up exactly 1 - tanh(x) <= 2e^{-2x}, with
#: 2x = N_EFOLD at the end), four orders of magnitude inside REL_TOL. Runs: 4–6 h of model time.
N_EFOLD = 23.0


# --------------------------------------------------------------------------- analytic solution
def steady_state(lat: float, theta_w_deg: float, radius: float, coriolis: bool = True,
                 metric: bool = True) -> tuple[float, complex]:
    """Steady ``(s, D)`` with ``U = A / D``, ``s = |U|`` (see the module docstring).

    ``lat`` in radians; ``metric`` adds ``u_east tan(lat) / R`` to ``f`` (ice drifting due east).
    """
    c = RHO_W * C_W
    th = math.radians(theta_w_deg)
    f = 2.0 * OMEGA * math.sin(lat) if coriolis else 0.0
    M0 = RHO_I * H * f
    m1 = RHO_I * H * math.tan(lat) / radius if (metric and coriolis) else 0.0
    coef = [c * c + 2 * c * m1 * math.sin(th) + m1 * m1,
            2 * M0 * (c * math.sin(th) + m1), M0 * M0, 0.0, -A_ABS**2]
    roots = np.roots(coef)
    pos = [r.real for r in roots if abs(r.imag) <= 1e-9 * abs(r) and r.real > 0]
    assert len(pos) == 1, f"expected one positive root, got {roots}"
    s = pos[0]
    D = c * s * np.exp(1j * th) + 1j * (M0 + m1 * s)
    # the root solves the modulus equation: |A| = s |D|
    assert abs(s * abs(D) - A_ABS) <= 1e-12 * A_ABS
    return s, D


def slowest_rate(lat: float, theta_w_deg: float, radius: float, coriolis: bool) -> float:
    """Slowest decay rate [1/s] of the linearised drift equation at the steady state.

    ``dU/dt = (A - (c |U| e^{i th} + i M(U)) U) / (rho_i h)``, Jacobian by central differences
    in (east, north); the rate is ``min(-Re eig)``.
    """
    c = RHO_W * C_W
    th = math.radians(theta_w_deg)
    f = 2.0 * OMEGA * math.sin(lat) if coriolis else 0.0
    m1 = RHO_I * H * math.tan(lat) / radius if coriolis else 0.0
    _, D = steady_state(lat, theta_w_deg, radius, coriolis)
    A = A_ABS * np.exp(1j * np.angle(D))  # wind steered so that U* is due east
    Ustar = A / D

    def rhs(U: complex) -> complex:
        M = RHO_I * H * f + m1 * U.real
        return (A - (c * abs(U) * np.exp(1j * th) + 1j * M) * U) / (RHO_I * H)

    eps = 1e-7 * abs(Ustar)
    J = np.empty((2, 2))
    for k, d in enumerate((eps, 1j * eps)):
        g = (rhs(Ustar + d) - rhs(Ustar - d)) / (2 * eps)
        J[0, k], J[1, k] = g.real, g.imag
    return float(min(-np.linalg.eigvals(J).real))


# --------------------------------------------------------------------------- model runs
def drift_sim(lat_deg: float, theta_w_deg: float, wind: complex, integrator: str, dt: float,
              duration: float, coriolis: bool = True, radius: float = R_EARTH) -> Simulation:
    forcing = [
        {"source": "air_drag",
         "field": {"type": "uniform", "params": {"u": wind.real, "v": wind.imag}}},
        {"source": "water_drag",
         "params": {"turning_angle": theta_w_deg, "max_relative_speed": MAX_REL_SPEED}},
    ]
    if coriolis:
        forcing.append({"source": "coriolis"})
    scene = make_scene(
        elements=[(0.0, lat_deg)], forcing=forcing, integrator=integrator, dt=dt,
        duration=duration, thickness=H, size=10e3, planet={"radius": radius},
        run={"nan_check_every": 1000},
    )
    return Simulation(scene, out=False, progress=False)


def east_north_velocity(sim: Simulation) -> complex:
    q = sim.state.q[0]
    ex, ey, nx, ny = east_north_local(q)
    vx, vy = sim.state.V[0]
    return complex(vx * ex + vy * ey, vx * nx + vy * ny)


def run_to_steady(lat_deg, theta_w_deg, integrator, coriolis=True, radius=R_EARTH, steer=True,
                  dt=60.0):
    """Run from rest for N_EFOLD slowest e-folding times; return (U_model, wind, lat_end)."""
    lat = math.radians(lat_deg)
    _, D = steady_state(lat, theta_w_deg, radius, coriolis)
    # steer: wind direction arg(D) makes U* = A/D due east (see module docstring)
    wind = U_WIND * np.exp(1j * np.angle(D)) if steer else complex(U_WIND, 0.0)
    lam = slowest_rate(lat, theta_w_deg, radius, coriolis)
    n = math.ceil(N_EFOLD / (lam * dt))
    sim = drift_sim(lat_deg, theta_w_deg, wind, integrator, dt, n * dt, coriolis, radius)
    sim.run(n)
    assert sim.state.w[0] == 0.0  # no torque on a non-spinning element: no spin appears
    return east_north_velocity(sim), wind, float(latlon_of(sim.state.q)[0][0])


def check_against(U: complex, wind: complex, Uex: complex) -> tuple[float, float, float]:
    """Speed relative error, turning-angle error [rad] and turning angle of the model."""
    speed_err = abs(abs(U) / abs(Uex) - 1.0)
    ang = float(np.angle(U / wind))
    ang_ex = float(np.angle(Uex / wind))
    return speed_err, abs(ang - ang_ex), ang_ex


# --------------------------------------------------------------------------- tests
EARTH_CASES = [
    # (lat, th_w): northern hemisphere, non-zero water turning angle, southern hemisphere
    (75.0, 0.0),
    (75.0, 25.0),
    (-75.0, 0.0),
    (-75.0, -25.0),
]


@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
@pytest.mark.parametrize("lat_deg,theta_w", EARTH_CASES)
def test_steady_drift_with_coriolis_on_earth(integrator, lat_deg, theta_w):
    """Steady speed and turning angle with Coriolis on the Earth, to 1e-6 relative.

    Tolerance budget (all well inside REL_TOL = 1e-6):

    * transient after N_EFOLD = 23 e-folds of the slowest linear mode: ~1e-10 relative;
    * latitude: the comparison uses ``f`` at the final latitude; the transient moves the element
      by ~0.2 m/s × 1 relaxation time (< 1 km), after which it drifts due east and its latitude
      is constant, so ``f`` is exact;
    * discretisation: both integrators have the exact steady state as a fixed point of the
      force balance (forward-Euler kick / RK4); what remains is the O(dt) error of the
      frame-rotation (metric) term ``u tan(lat) dt / R ≈ 1e-5`` times its 1e-4 share of the
      balance, ~1e-9.
    """
    U, wind, lat_end = run_to_steady(lat_deg, theta_w, integrator)
    _, D = steady_state(lat_end, theta_w, R_EARTH)
    Uex = A_ABS * np.exp(1j * np.angle(wind)) / D
    speed_err, ang_err, ang_ex = check_against(U, wind, Uex)
    assert abs(U - Uex) / abs(Uex) < REL_TOL
    assert speed_err < REL_TOL
    assert ang_err < REL_TOL * abs(ang_ex)  # relative error of the turning angle
    # the ice turns to the right of the wind in the north (f > 0), to the left in the south
    assert math.copysign(1.0, ang_ex) == -math.copysign(1.0, lat_deg)
    # the metric term matters at this tolerance: the f-plane formula is off by
    # ~ rho_i h s tan(lat) / (R |D|) ≈ 1.0e-4 here, far outside REL_TOL
    _, D_fplane = steady_state(lat_end, theta_w, R_EARTH, metric=False)
    assert abs(D_fplane / D - 1.0) > 10 * REL_TOL


def test_southern_hemisphere_mirrors_northern():
    """f < 0 turns the ice the other way: the turning angle at 75°S is minus that at 75°N.

    Mirror symmetry about the equator maps (lat, th_w, angle) to (-lat, -th_w, -angle); both
    runs use the same integrator and step, so the model must reproduce it to round-off (the
    runs differ only in signs); we allow 1e-12 rad.
    """
    Un, wn, _ = run_to_steady(75.0, 25.0, "siku2")
    Us, ws, _ = run_to_steady(-75.0, -25.0, "siku2")
    an, as_ = float(np.angle(Un / wn)), float(np.angle(Us / ws))
    assert an < -0.1 and as_ > 0.1
    assert abs(an + as_) < 1e-12
    assert abs(abs(Un) - abs(Us)) < 1e-12 * abs(Un)


@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_steady_drift_f_plane_limit(integrator):
    """The plain quartic of the brief (no metric term) on a planet 10⁴ × the Earth's radius.

    Wind due east, th_w = 25°, 75°N. What separates the model from the f-plane solution here:

    * the metric term: ``rho_i h s tan(lat) / (R |D|) ≈ 1e-8`` relative;
    * the change of ``f`` while the ice moves off its starting latitude at ~0.2 m/s: ``f`` is
      taken at the final latitude, and over one relaxation time (~1000 s) ``f`` changes by
      ``cot(lat) U T / R ≈ 1e-9`` relative;
    * transient and discretisation as in the Earth cases (≤ 1e-9).
    """
    big = 1e4 * R_EARTH
    U, wind, lat_end = run_to_steady(75.0, 25.0, integrator, radius=big, steer=False)
    s, D = steady_state(lat_end, 25.0, big, metric=False)
    metric_share = RHO_I * H * s * math.tan(lat_end) / big / abs(D)
    assert metric_share < 1e-7
    Uex = A_ABS * np.exp(1j * np.angle(wind)) / D
    speed_err, ang_err, ang_ex = check_against(U, wind, Uex)
    assert speed_err < REL_TOL
    assert ang_err < REL_TOL * abs(ang_ex)
    assert ang_ex < -0.5  # 25° water turning angle plus Coriolis: ~ -31.6° to the right


@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
@pytest.mark.parametrize("theta_w", [0.0, 25.0])
def test_steady_drift_without_coriolis(integrator, theta_w):
    """No Coriolis, at the equator, wind due east: ``|U| = sqrt(|A|/c)``, angle ``-th_w``.

    With th_w = 0 the ice drifts along the equator (a great circle: no metric term); with
    th_w = 25° it drifts 25° south of east and leaves the equator by ~2 km (3e-4 rad), where the
    metric term ``u tan(lat) / R ≈ 1e-11 /s`` is ~1e-8 of the drag rate ``b |U| ≈ 1e-3 /s``
    (measured error 5e-9). Transient: ≤ 1e-10 (N_EFOLD). Tolerance 1e-6.
    """
    U, wind, _ = run_to_steady(0.0, theta_w, integrator, coriolis=False, steer=False)
    s_ex = math.sqrt(A_ABS / (RHO_W * C_W))
    Uex = s_ex * np.exp(-1j * math.radians(theta_w))
    assert abs(abs(U) / s_ex - 1) < REL_TOL
    ang = float(np.angle(U / wind))
    if theta_w == 0.0:
        assert abs(ang) < REL_TOL
    else:
        assert abs(ang / -math.radians(theta_w) - 1) < REL_TOL
    assert abs(U - Uex) / s_ex < REL_TOL


# --------------------------------------------------------------------------- spin-up
#: spin-up without Coriolis: dU/dt = a - b U², U(0) = 0 -> U = U_inf tanh(kappa t)
A_ACC = A_ABS / (RHO_I * H)  # a [m/s²]
B_DRAG = RHO_W * C_W / (RHO_I * H)  # b [1/m]
U_INF = math.sqrt(A_ACC / B_DRAG)  # 0.2122 m/s
KAPPA = math.sqrt(A_ACC * B_DRAG)  # 1/(929 s)
T_EVAL = 1800.0  # ≈ 1.9 / kappa: mid-way through the spin-up, where U'' is large


def spinup_error(integrator: str, dt: float) -> float:
    n = round(T_EVAL / dt)
    assert abs(n * dt - T_EVAL) < 1e-9
    sim = drift_sim(0.0, 0.0, complex(U_WIND, 0.0), integrator, dt, T_EVAL, coriolis=False)
    sim.run(n)
    U = east_north_velocity(sim)
    # wind due east at the equator: the ice stays on the equator, moving due east
    assert abs(U.imag) <= 1e-12 * abs(U)
    return U.real - U_INF * math.tanh(KAPPA * T_EVAL)


def measured_order(dts, errs) -> float:
    """Least-squares slope of log|err| against log dt."""
    return float(np.polyfit(np.log(dts), np.log(np.abs(errs)), 1)[0])


#: spin-up orders. siku2 kicks V with the force at the start of the step (V += dt F(V)/m, then
#: moves q): for a velocity-dependent force that is forward Euler in V, first order — its
#: nominal order 2 holds for free motion only (tests/test_great_circles.py). RK4 is fourth order.
SPINUP = {
    "siku2": (1, [T_EVAL / n for n in (24, 48, 96, 192)]),
    "rk4": (4, [T_EVAL / n for n in (12, 24, 48, 96)]),
}


@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_spinup_convergence_order(integrator):
    """Error of U(T_EVAL) against U_inf tanh(kappa t) falls at the scheme's order (± 0.2).

    siku2: forward Euler in V (see SPINUP). The next term of the error expansion is O(dt²), so
    the measured slope differs from 1 by O(kappa dt) ≤ 0.08 here: inside the ± 0.2 band.
    rk4: the next term is O(dt⁵), so the slope exceeds 4 by O(kappa dt) ≤ 0.16 at the coarsest
    pair (kappa dt = 0.16 at dt = 150 s) and less at the finer ones.
    Every dt is below the water-drag limit (394 s, see MAX_REL_SPEED).
    """
    expected, dts = SPINUP[integrator]
    errs = np.array([spinup_error(integrator, dt) for dt in dts])
    p = measured_order(dts, errs)
    print(f"\nspin-up {integrator}: dt = {dts} s, error = {errs} m/s, order = {p:.3f}")
    assert abs(p - expected) < 0.2
    # errors are far above round-off (|U| eps ~ 1e-17 m/s)
    assert np.all(np.abs(errs) > 1e-13)


def test_spinup_siku2_error_constant():
    """siku2's spin-up error matches forward Euler's leading error term.

    Global error of forward Euler: e' = G'(U) e - (dt/2) U'', e(0) = 0 with G = a - bU². For
    U = U_inf tanh(kappa t), G'(U) = -2 kappa tanh(kappa t) and the solution is::

        e(t) = dt U_inf kappa ln(cosh kappa t) / cosh²(kappa t)    (numerical ahead)

    The next term is O(dt²), i.e. relative O(kappa dt) = 0.01 at dt = 9.375 s: tolerance 5 %
    (a factor ~5 on kappa dt for its unknown coefficient).
    """
    dt = T_EVAL / 192
    e = spinup_error("siku2", dt)
    x = KAPPA * T_EVAL
    e_pred = dt * U_INF * KAPPA * math.log(math.cosh(x)) / math.cosh(x) ** 2
    assert e > 0
    assert abs(e / e_pred - 1) < 5 * KAPPA * dt


@pytest.mark.parametrize("integrator", ["siku2", "rk4"])
def test_spinup_reaches_terminal_speed(integrator):
    """After 23 / (2 kappa) the tanh spin-up is within 2 e^{-23} ≈ 2e-10 of U_inf (< 1e-6)."""
    dt = 60.0
    n = math.ceil(N_EFOLD / (2 * KAPPA * dt))
    sim = drift_sim(0.0, 0.0, complex(U_WIND, 0.0), integrator, dt, n * dt, coriolis=False)
    sim.run(n)
    U = east_north_velocity(sim)
    assert abs(U.real / U_INF - 1) < REL_TOL
    assert abs(U.imag) <= 1e-12 * U_INF
