"""Speed/accuracy study: error against a reference versus cost, for every integrator.

``python -m bench.accuracy`` (from the repository root) runs, for each verification case, a grid
of (integrator × dt) — and for V6 (resolution × integrator × dt) — and measures

* the **error** against a reference:

  - V2 great circle (docs/explanation/physics.md §8): distance [m] of the element's centre after 6
    days from the exact solution (the torque-free symmetric top, as in
    ``tests/test_great_circles.py``); oblique case (20°N 40°E, 45° to east, 60°/day), with one turn
    per day of spin and without;
  - V1 free drift: spin-up from rest under a 10 m/s wind in still water without Coriolis,
    largest ``|U - U∞ tanh(κ t)|`` [m/s] over ``t = 300, 600, … 3600 s`` (as in
    ``tests/test_free_drift.py``; analytic);
  - V6 clamped pack pulled by a handle at 3 m/s (``tests/contacts/test_v6_resolution.py``):
    *time-step error* = largest ``|F(t) - F_ref(t)|`` of the handle force over the last wave
    period ``P``, over ``F_cont(T)``, where ``F_ref`` is the same resolution run with ``rk4`` at
    ``dt0/16`` (``dt0 ≤ 0.45 dt_c``, the test's step); *vs continuum* = ``|⟨F⟩/⟨F_cont⟩ - 1|``,
    the force averaged over the last period against ``E h W δ/(L + b)`` plus the joint damping's
    share (the test's measure); *vs finest* = the same ratio's distance from that of the
    reference run at the finest resolution;

* the **cost**: wall seconds of the ``Simulation.step`` calls only (scene building excluded;
  each integrator and case is run once first, so no compilation is timed; runs under 0.5 s
  are repeated up to three times and the fastest kept), the number of steps, force
  evaluations (``steps × Integrator.force_evaluations``) and element-steps.

It prints markdown tables and writes ``speed_accuracy_table.md`` and ``speed_accuracy.png``
(log-log error against cost, one line per integrator and resolution, the error–cost frontier in
grey) to ``--out`` (default ``docs/explanation``). ``--quick`` runs a small subset (under a
minute) and writes ``*_quick.*`` files, so that it never overwrites the full study's output.
Everything runs on one thread. See ``docs/explanation/speed_accuracy.md``.
"""
from __future__ import annotations

import argparse
import math
import platform
import sys
import time
import warnings
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from siku_core.errors import NonFiniteError
from siku_core.geometry.quat import centers, east_north_local, qrotate
from siku_core.plugins import get_registry
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.state import FREE, STEADY
from siku_core.testing import make_scene
from siku_core.testing.contact_conformance import contact_scene_text

ROOT = Path(__file__).resolve().parents[1]
R_EARTH = 6_371_000.0  # m
DAY = 86_400.0  # s
INTEGRATORS = ("siku2", "rk4")
#: NaN guard every this many steps (the scene default, 1, would time a state copy per step)
NAN_EVERY = 100

# V2: oblique great circle, 60°/day, 1 turn/day spin, 6 days (tests/test_great_circles.py)
GC_CENTER = (40.0, 20.0)  # lon, lat [deg]
GC_SPEED = math.radians(60.0) * R_EARTH / DAY  # 77.2 m/s
GC_SPIN = 2 * math.pi / DAY  # rad/s
GC_T = 6 * DAY  # s

# V1: spin-up without Coriolis on the equator (tests/test_free_drift.py)
WIND = 10.0  # m/s
SPINUP_T = 3600.0  # s: 3.9 / κ
SPINUP_EVERY = 300.0  # s between error samples (a multiple of every dt of the grid)
MAX_REL_SPEED = 0.25  # m/s, water_drag's stability estimate (see tests/test_free_drift.py)

# V6: clamped pack (tests/contacts/test_v6_resolution.py)
V6_E, V6_H, V6_PULL = 1.0e9, 1.0, 3.0  # Pa, m, m/s
LON_SPAN, LAT_SPAN, CLAMP = 10.0, 4.0, 0.5  # deg
DEG = math.pi / 180.0 * R_EARTH  # m per degree on the equator
V6_T = 20_000.0  # s, as the test: about 9 wave round trips
V6_SAFETY = 0.45  # dt0 ≤ this × dt_c (the test's step)
V6_PARAMS = {"tensile_strain": 1.0}  # unbreakable: a stiffness question
RESOLUTIONS = ((5, 2), (10, 4), (20, 8), (40, 16))


@dataclass
class Point:
    """One run: its step, cost and error (``None``: the run diverged)."""

    case: str
    integrator: str
    dt: float  # s
    steps: int
    elements: int
    force_evaluations: int
    seconds: float  # wall time of the steps [s]
    error: float | None
    unit: str
    resolution: str = ""
    dt_critical: float = math.inf  # s
    extra: dict = field(default_factory=dict)

    @property
    def element_steps(self) -> int:
        return self.elements * self.steps

    @property
    def line(self) -> str:
        """Label of the line this point belongs to in the plot and the order fits."""
        return f"{self.integrator} {self.resolution}".strip()


# --------------------------------------------------------------------------------- timing
def timed(build: Callable[[], Simulation], steps: int,
          after: Callable[[Simulation], Callable[[int], None] | None] | None = None,
          repeat_below: float = 0.5, max_repeat: int = 5) -> tuple[Simulation, float, int, bool]:
    """Run ``steps`` steps of ``build()``; ``(sim, seconds, steps run, finished)``.

    Only the ``sim.step()`` calls are timed. ``after(sim)`` may return ``f(k)``, called after
    step ``k`` (0-based; not timed). A run shorter than ``repeat_below`` [s] is repeated (fresh
    simulation) up to ``max_repeat`` times and the fastest kept. A diverging run stops at the
    NaN guard (``finished`` false; ``steps run`` counts the steps up to the guard).
    """
    best, sim = math.inf, None
    for _ in range(max_repeat):
        sim = build()
        each = after(sim) if after is not None else None
        spent, clock = 0.0, time.perf_counter
        try:
            for k in range(steps):
                t0 = clock()
                sim.step()
                spent += clock() - t0
                if each is not None:
                    each(k)
        except NonFiniteError:
            return sim, spent, k + 1, False
        best = min(best, spent)
        if spent >= repeat_below:
            break
    assert sim is not None
    return sim, best, steps, True


def _evals(integrator: str) -> int:
    return int(get_registry().get("integrator", integrator).force_evaluations)


def order_of(dt: Iterable[float], err: Iterable[float]) -> float:
    """Least-squares slope of log(error) against log(dt)."""
    d, e = np.asarray(list(dt), float), np.asarray(list(err), float)
    return float(np.polyfit(np.log(d), np.log(e), 1)[0])


# --------------------------------------------------------------------------------- V2
def _rodrigues(p: np.ndarray, axis: np.ndarray, ang: float) -> np.ndarray:
    return (p * math.cos(ang) + np.cross(axis, p) * math.sin(ang)
            + axis * float(np.dot(p, axis)) * (1 - math.cos(ang)))


def great_circle(integrator: str, dt: float, spin: bool = True) -> Point:
    """V2: end-point error [m] after 6 days against the exact torque-free motion.

    The element turns about the fixed axis ``L̂ = R(q0) Omega_L / |Omega_L|`` at the rate
    ``a = |Omega_L|``, ``Omega_L = (-Vy/R, Vx/R, k w)``, ``k = I/(m R²)`` (derivation in
    ``tests/test_great_circles.py``).
    """
    n = round(GC_T / dt)
    u = GC_SPEED / math.sqrt(2.0)

    def build() -> Simulation:
        scene = make_scene(
            elements=[{"center": GC_CENTER, "velocity": (u, u), "spin": GC_SPIN if spin else 0.0}],
            integrator=integrator, dt=dt, duration=n * dt, thickness=1.0, size=10e3,
            run={"nan_check_every": NAN_EVERY},
        )
        return Simulation(scene, out=False, progress=False)

    ref = build().state
    R = R_EARTH
    k = float(ref.I[0] / (ref.m[0] * R * R))
    V0, w0 = ref.V[0], float(ref.w[0])
    omega_l = np.array([-V0[1] / R, V0[0] / R, k * w0])
    a = float(np.linalg.norm(omega_l))
    axis = qrotate(ref.q[0].copy(), omega_l / a)
    exact = _rodrigues(centers(ref.q)[0], axis, a * n * dt)
    sim, sec, done, ok = timed(build, n)
    err = R * float(np.linalg.norm(centers(sim.state.q)[0] - exact)) if ok else None
    case = "V2 great circle, spin 1/day" if spin else "V2 great circle, no spin"
    return Point(case, integrator, dt, done, 1, done * _evals(integrator), sec, err, "m")


# --------------------------------------------------------------------------------- V1
def spinup(integrator: str, dt: float) -> Point:
    """V1: largest ``|U - U∞ tanh(κ t)|`` [m/s] at ``t = 300, 600, … 3600 s``.

    ``dU/dt = a - b U²``, ``a = rho_a C_a |U_a|² / (rho_i h)``, ``b = rho_w C_w / (rho_i h)``,
    ``U∞ = sqrt(a/b)``, ``κ = sqrt(a b)`` (1/929 s); wind due east on the equator, so the ice
    stays on the equator moving due east.
    """
    n = round(SPINUP_T / dt)
    every = round(SPINUP_EVERY / dt)
    assert abs(every * dt - SPINUP_EVERY) < 1e-9 and n % every == 0, dt

    def build() -> Simulation:
        scene = make_scene(
            elements=[(0.0, 0.0)], integrator=integrator, dt=dt, duration=n * dt,
            thickness=1.0, size=10e3, run={"nan_check_every": NAN_EVERY},
            forcing=[{"source": "air_drag",
                      "field": {"type": "uniform", "params": {"u": WIND, "v": 0.0}}},
                     {"source": "water_drag", "params": {"max_relative_speed": MAX_REL_SPEED}}],
        )
        return Simulation(scene, out=False, progress=False)

    sim0 = build()
    air, water = (f.p for f in sim0.forcing)
    st = sim0.state
    rho_i = float(st.m[0] / (st.area[0] * st.thickness[0]))
    a = air["rho"] * air["C"] * WIND**2 / (rho_i * st.thickness[0])
    b = water["rho"] * water["C"] / (rho_i * st.thickness[0])
    u_inf, kappa = math.sqrt(a / b), math.sqrt(a * b)
    worst = [0.0]

    def after(sim: Simulation) -> Callable[[int], None]:
        worst[0] = 0.0

        def each(k: int) -> None:
            if (k + 1) % every == 0:
                ex, ey, _, _ = east_north_local(sim.state.q[0])
                u = sim.state.V[0, 0] * ex + sim.state.V[0, 1] * ey
                exact = u_inf * math.tanh(kappa * (k + 1) * dt)
                worst[0] = max(worst[0], abs(u - exact))
        return each

    _, sec, done, ok = timed(build, n, after)
    err = worst[0] if ok else None
    return Point("V1 free-drift spin-up", integrator, dt, done, 1, done * _evals(integrator),
                 sec, err, "m/s", extra={"u_inf": u_inf, "kappa": kappa})


# --------------------------------------------------------------------------------- V6
def pack_scene(nx: int, ny: int, integrator: str, dt: float, duration: float,
               params: dict | None = None, touching: str = "contact") -> str:
    """The V6 pack between a static strip (west) and a handle strip pulled east, as TOML
    (``touching``: the ``contact.touching`` option)."""
    lat = [-LAT_SPAN / 2, LAT_SPAN / 2]
    packs = [
        {"lon": [-CLAMP, 0.0], "lat": lat, "nx": 1, "ny": ny, "flag": "static"},
        {"lon": [0.0, LON_SPAN], "lat": lat, "nx": nx, "ny": ny},
        {"lon": [LON_SPAN, LON_SPAN + CLAMP], "lat": lat, "nx": 1, "ny": ny, "flag": "steady",
         "velocity": [V6_PULL, 0.0]},
    ]
    return contact_scene_text(
        "distributed_spring", V6_PARAMS if params is None else params, packs=packs, dt=dt,
        duration=duration, thickness=V6_H, youngs_modulus=V6_E, integrator=integrator,
        title=f"V6 {nx}x{ny} {integrator}", touching=touching,
        run={"nan_check_every": NAN_EVERY, "allow_unstable_dt": True},
    )


def critical_dt(nx: int, ny: int, params: dict | None = None) -> float:
    """The engine's critical step ``dt_c`` [s] of the V6 pack."""
    sim = Simulation(scene_from_text(pack_scene(nx, ny, "siku2", 1e-3, 1.0, params)),
                     out=False, progress=False)
    return float(sim.critical_dt)


@dataclass
class Pull:
    """Handle force history of one V6 run and its continuum answer."""

    point: Point
    t: np.ndarray  # s, time of the state each force belongs to
    force: np.ndarray  # N, eastward pull of the handle on the pack
    stiffness: float  # N/m, E h W / (L + b)
    f_visc: float  # N, steady share of the joint damping
    period: float  # s, wave round trip 2 (L + b) / c

    @property
    def ratio(self) -> float:
        """``⟨F⟩ / ⟨F_cont⟩ - 1`` over the last period (the test's quasi-static measure)."""
        win = self.t > self.t[-1] - self.period
        theory = self.stiffness * V6_PULL * self.t[win].mean() + self.f_visc
        return float(self.force[win].mean() / theory - 1.0)


def pull(nx: int, ny: int, integrator: str, factor: float, dt_c: float,
         params: dict | None = None, duration: float = V6_T, touching: str = "contact") -> Pull:
    """Pull the V6 pack with ``dt = dt0 × factor``; ``dt0 = T/steps0 ≤ 0.45 dt_c``, ``steps0`` a
    multiple of 4 (so that every ``dt0 × 2^k`` divides ``T`` and their times coincide)."""
    steps0 = 4 * math.ceil(duration / (V6_SAFETY * dt_c) / 4)
    steps = round(steps0 / factor)
    dt = duration / steps
    text = pack_scene(nx, ny, integrator, dt, duration, params, touching)

    def build() -> Simulation:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # dt above the engine's guard, on purpose
            return Simulation(scene_from_text(text), out=False, progress=False)

    force = np.full(steps, np.nan)

    def after(sim: Simulation) -> Callable[[int], None]:
        st = sim.state
        handle = np.flatnonzero(st.flags == STEADY)

        def each(k: int) -> None:  # local +x is east for every handle element
            force[k] = -st.F[handle, 0].sum()
        return each

    sim, sec, done, ok = timed(build, steps, after)
    st = sim.state
    d = LON_SPAN / nx * DEG
    gauge = (LON_SPAN + CLAMP) * DEG
    width = LAT_SPAN * DEG
    # joint columns in series (each: spring constant, damping constant) [N/m, N s/m]; see
    # tests/contacts/test_v6_resolution.py: F = k_eff v t + k_eff² v Σ c_i / k_i²
    zeta = float(sim.contacts.law.p["joint_damping_ratio"])
    m = float(st.m[st.flags == FREE].mean())
    wy = width / ny
    end_gap = 0.5 * (CLAMP * DEG + d)
    cols = [(V6_H * V6_E * wy / d, 2 * zeta * math.sqrt(V6_H * V6_E * wy / d * m / 2))] * (nx - 1)
    cols += [(V6_H * V6_E * wy / end_gap,
              2 * zeta * math.sqrt(V6_H * V6_E * wy / end_gap * m))] * 2
    k_eff = 1.0 / sum(1.0 / (ny * k) for k, _ in cols)
    f_visc = k_eff**2 * V6_PULL * sum(ny * c / (ny * k) ** 2 for k, c in cols)
    rho = float(sim.scene.cfg.materials["ice"].density)
    period = 2.0 * gauge / math.sqrt(V6_E / rho)
    res = f"{nx}×{ny}" + ("" if params is None else " " + _params_label(params))
    pt = Point("V6 pack pull", integrator, dt, done, st.n, done * _evals(integrator), sec,
               math.nan if ok else None, "1", res, dt_c, {"factor": factor})
    return Pull(pt, np.arange(steps) * dt, force, V6_E * V6_H * width / gauge, f_visc, period)


def _params_label(params: dict) -> str:
    return ", ".join(f"{k} = {v:g}" for k, v in params.items() if k not in V6_PARAMS)


def v6_grid(resolutions: Iterable[tuple[int, int]], factors: dict[str, tuple[float, ...]],
            params: dict | None = None, log: Callable[[str], None] | None = None,
            duration: float = V6_T) -> tuple[list[Point], dict[str, float]]:
    """V6 runs per resolution and integrator, each against its ``rk4`` run at ``dt0/16``.

    Returns the points (``error`` = time-step error; ``extra``: ``vs_continuum``, ``ratio``)
    and the reference ``ratio`` per resolution label.
    """
    log = log or _progress
    points: list[Point] = []
    refs: dict[str, float] = {}
    for nx, ny in resolutions:
        dt_c = critical_dt(nx, ny, params)
        ref = pull(nx, ny, "rk4", 1 / 16, dt_c, params, duration)
        scale = ref.stiffness * V6_PULL * duration + ref.f_visc
        last = ref.t >= duration - ref.period
        refs[ref.point.resolution] = ref.ratio
        log(f"  V6 {ref.point.resolution}: reference rk4 dt = {ref.point.dt:.4g} s "
            f"({ref.point.steps} steps, {ref.point.seconds:.1f} s)")
        for integ in INTEGRATORS:
            for fac in factors[integ]:
                r = pull(nx, ny, integ, fac, dt_c, params, duration)
                p = r.point
                if p.error is not None:
                    m = round(p.dt / ref.point.dt)
                    diff = r.force - ref.force[::m][: len(r.force)]
                    p.error = float(np.abs(diff[last[::m][: len(r.force)]]).max() / scale)
                    p.extra.update(ratio=r.ratio, vs_continuum=abs(r.ratio))
                log(f"  V6 {p.resolution} {integ} dt = {p.dt:.4g} s: "
                    f"{'diverged' if p.error is None else f'{p.error:.3e}'} ({p.seconds:.2f} s)")
                points.append(p)
    return points, refs


# --------------------------------------------------------------------------------- study
GRIDS = {
    "full": {
        "v2": {"siku2": [4800 / 2**k for k in range(7)], "rk4": [4800 / 2**k for k in range(6)]},
        # rk4 without spin reaches round-off (a few 1e-8 m after 6 days) below 300 s
        "v2_nospin": {"siku2": [4800 / 2**k for k in range(7)],
                      "rk4": [4800 / 2**k for k in range(5)]},
        "v1": {"siku2": [300 / 2**k for k in range(7)], "rk4": [300 / 2**k for k in range(5)]},
        "v6": {"resolutions": RESOLUTIONS,
               "factors": {"siku2": (4.0, 2.0, 1.0, 0.5, 0.25),
                           "rk4": (4.0, 2.0, 1.0, 0.5, 0.25)}},
        "v6_smooth": {"resolutions": ((10, 4),),
                      "factors": {"siku2": (2.0, 1.0, 0.5, 0.25),
                                  "rk4": (2.0, 1.0, 0.5, 0.25)}},
    },
    "quick": {
        "v2": {"siku2": [1200.0, 600.0, 300.0], "rk4": [2400.0, 1200.0, 600.0]},
        "v2_nospin": {"siku2": [1200.0, 600.0, 300.0], "rk4": [2400.0, 1200.0, 600.0]},
        "v1": {"siku2": [75.0, 37.5, 18.75], "rk4": [150.0, 75.0, 37.5]},
        "v6": {"resolutions": ((5, 2), (10, 4)),
               "factors": {"siku2": (2.0, 1.0, 0.5), "rk4": (2.0, 1.0, 0.5)}},
        "v6_smooth": None,
    },
}
#: the collision law's damping off: a contact force without jumps (see the doc)
SMOOTH = {"tensile_strain": 1.0, "damping_ratio": 0.0}


def warm_up() -> None:
    """Run every case once briefly so that no compilation is timed."""
    for integ in INTEGRATORS:
        great_circle(integ, GC_T / 4)
        spinup(integ, SPINUP_EVERY)
        pull(5, 2, integ, 1.0, critical_dt(5, 2), duration=2000.0)


def _progress(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def run_study(grid: dict, log: Callable[[str], None] = _progress) -> tuple[list[Point], dict]:
    """Every run of ``grid`` (see :data:`GRIDS`); ``(points, V6 reference ratios)``."""
    pts: list[Point] = []
    t0 = time.perf_counter()
    warm_up()
    log(f"warm-up {time.perf_counter() - t0:.1f} s")
    for spin, key in ((True, "v2"), (False, "v2_nospin")):
        for integ, dts in grid[key].items():
            pts += [great_circle(integ, dt, spin) for dt in dts]
    log(f"V2 done at {time.perf_counter() - t0:.1f} s")
    for integ, dts in grid["v1"].items():
        pts += [spinup(integ, dt) for dt in dts]
    log(f"V1 done at {time.perf_counter() - t0:.1f} s")
    v6, refs = v6_grid(grid["v6"]["resolutions"], grid["v6"]["factors"], log=log)
    finest = list(refs)[-1]
    for p in v6:
        if p.error is not None:
            p.extra["vs_finest"] = abs(p.extra["ratio"] - refs[finest])
    pts += v6
    if grid.get("v6_smooth"):
        sm, _ = v6_grid(grid["v6_smooth"]["resolutions"], grid["v6_smooth"]["factors"],
                        params=SMOOTH, log=log)
        for p in sm:
            p.case = "V6 pack pull, no collision damping"
        pts += sm
    log(f"V6 done at {time.perf_counter() - t0:.1f} s")
    return pts, {"finest": finest, "refs": refs}


# --------------------------------------------------------------------------------- output
def _lines(points: list[Point]) -> dict[tuple[str, str], list[Point]]:
    out: dict[tuple[str, str], list[Point]] = {}
    for p in points:
        out.setdefault((p.case, p.line), []).append(p)
    return out


def fitted_orders(points: list[Point]) -> dict[tuple[str, str], float]:
    """Order per (case, line): slope of log error against log dt over the three finest steps
    of the line that did not diverge (the asymptotic range)."""
    out = {}
    for key, ps in _lines(points).items():
        ok = sorted((p for p in ps if p.error), key=lambda p: p.dt)[:3]
        if len(ok) >= 2:
            out[key] = order_of([p.dt for p in ok], [p.error for p in ok])
    return out


def _value(p: Point, key: str) -> float | None:
    return p.error if key == "error" or p.error is None else p.extra.get(key)


def frontier(points: list[Point], key: str = "error") -> list[Point]:
    """Pareto set by ``key`` (``error`` or an ``extra`` key): the points that no cheaper point
    beats, by increasing cost."""
    best, out = math.inf, []
    for p in sorted((p for p in points if _value(p, key)), key=lambda p: p.seconds):
        v = _value(p, key)
        if v < best:
            best = v
            out.append(p)
    return out


def _fmt(x: float | None, digits: int = 3) -> str:
    return "diverged" if x is None else f"{x:.{digits}e}"


def table(points: list[Point]) -> str:
    """Markdown: one table per case, then the fitted orders."""
    parts = []
    orders = fitted_orders(points)
    cases = list(dict.fromkeys(p.case for p in points))
    for case in cases:
        ps = [p for p in points if p.case == case]
        unit = ps[0].unit
        v6 = case.startswith("V6")
        # V6: the time-step error compares runs of one resolution; the continuum all of them
        groups = [[p for p in ps if p.resolution == r] for r in dict.fromkeys(p.resolution
                                                                              for p in ps)]
        front = {id(p) for g in groups for p in frontier(g)}
        front_c = {id(p) for p in frontier(ps, "vs_continuum")} if v6 else set()
        head = "| integrator | " + ("elements | dt [s] | dt/dt_c | " if v6 else "dt [s] | ")
        head += ("steps | force evaluations | element-steps | wall [s] | µs per element-step | "
                 + ("time-step error [1] | ⟨F⟩ vs continuum [1] | vs finest [1] |" if v6 else
                    f"error [{unit}] | order (pairwise) |"))
        rows = [f"### {case}", "", head, "|" + "---|" * (head.count("|") - 1)]
        prev: dict[str, Point] = {}
        for p in ps:
            star = " ★" if id(p) in front else ""
            cells = [p.integrator]
            if v6:
                cells += [p.resolution, f"{p.dt:.4g}", f"{p.dt / p.dt_critical:.3f}"]
            else:
                cells += [f"{p.dt:g}"]
            cells += [f"{p.steps}" + (" (diverged)" if p.error is None else ""),
                      f"{p.force_evaluations}", f"{p.element_steps}",
                      f"{p.seconds:.3g}", f"{1e6 * p.seconds / max(p.element_steps, 1):.3g}"]
            if v6:
                cells += [_fmt(p.error) + star,
                          (_fmt(p.extra.get("vs_continuum")) + (" ★" if id(p) in front_c else ""))
                          if p.error is not None else "—",
                          _fmt(p.extra.get("vs_finest")) if "vs_finest" in p.extra else "—"]
            else:
                q = prev.get(p.line)
                pair = (f"{math.log(q.error / p.error) / math.log(q.dt / p.dt):.2f}"
                        if q is not None and q.error and p.error else "")
                cells += [_fmt(p.error) + star, pair]
            prev[p.line] = p
            rows.append("| " + " | ".join(cells) + " |")
        parts.append("\n".join(rows))
    rows = ["### Fitted orders (slope of log error against log dt)", "",
            "| case | integrator | order |", "|---|---|---|"]
    rows += [f"| {case} | {line} | {o:.2f} |" for (case, line), o in orders.items()]
    parts.append("\n".join(rows))
    return "\n\n".join(parts) + "\n"


def plot(points: list[Point], path: Path) -> Path:
    """Log-log error against wall seconds, one panel per case, the frontier in grey."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import NullFormatter

    panels: list[tuple[str, str, str]] = []  # (case, error key, title)
    for case in dict.fromkeys(p.case for p in points):
        if case == "V6 pack pull":
            panels += [(case, "error", "V6 pack pull: time-step error of F(t)"),
                       (case, "vs_continuum", "V6 pack pull: ⟨F⟩ against the continuum")]
        elif case.startswith("V6"):
            panels.append((case, "error", "V6 10×4, collision damping 0: time-step error"))
        else:
            panels.append((case, "error", case))
    ncol = 3 if len(panels) > 4 else 2
    nrow = math.ceil(len(panels) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(5.2 * ncol, 4.2 * nrow), squeeze=False)
    orders = fitted_orders(points)
    shades = {"siku2": plt.cm.Blues, "rk4": plt.cm.Reds}
    for ax, (case, key, title) in zip(axes.flat, panels):
        ps = [p for p in points if p.case == case and p.error is not None]
        # the time-step error compares runs of one resolution: one frontier per resolution
        groups = ([[p for p in ps if p.resolution == r] for r in dict.fromkeys(
            p.resolution for p in ps)] if key == "error" else [ps])
        for k, g in enumerate(groups):
            front = frontier(g, key)
            ax.step([p.seconds for p in front], [_value(p, key) for p in front], where="post",
                    color="0.75", lw=5, alpha=0.7, zorder=0, label="frontier" if k == 0 else None)
        lines = _lines(ps)
        for i, ((_, line), lp) in enumerate(lines.items()):
            integ = lp[0].integrator
            same = [ln for (_, ln) in lines if ln.split()[0] == integ]
            color = shades[integ](0.45 + 0.5 * (same.index(line) + 1) / len(same))
            o = orders.get((case, line)) if key == "error" else None
            ax.loglog([p.seconds for p in lp], [_value(p, key) for p in lp],
                      "o-" if integ == "siku2" else "s--", color=color, ms=4,
                      label=line + (f" (order {o:.2f})" if o is not None else ""))
        lo, hi = ax.get_ylim()
        if hi / lo < 100:  # at least two decades, so that a flat line looks flat
            lo, hi = math.sqrt(lo * hi) / 10, math.sqrt(lo * hi) * 10
        ax.set_ylim(lo, hi * 30)  # room for the legend above the lines
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("cost: wall time of the steps [s]")
        ax.set_ylabel(f"error [{ps[0].unit if ps else ''}]")
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=6.5, loc="upper right", ncol=2 if len(lines) > 4 else 1)
    for ax in list(axes.flat)[len(panels):]:
        ax.axis("off")
    fig.tight_layout()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write(points: list[Point], out: Path, suffix: str = "", header: str = "") -> tuple[Path, Path]:
    """Write ``speed_accuracy_table{suffix}.md`` and ``speed_accuracy{suffix}.png`` in ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    md = out / f"speed_accuracy_table{suffix}.md"
    md.write_text(header + table(points), encoding="utf-8")
    png = plot(points, out / f"speed_accuracy{suffix}.png")
    return md, png


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m bench.accuracy",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="a small subset (under a minute)")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "explanation",
                    help="folder of the table and the plot (default docs/explanation)")
    args = ap.parse_args(argv)
    import numba

    numba.set_num_threads(1)
    t0 = time.perf_counter()
    kind = "quick" if args.quick else "full"
    points, refs = run_study(GRIDS[kind])
    total = time.perf_counter() - t0
    cmd = "python -m bench.accuracy" + (" --quick" if args.quick else "")
    header = (
        f"<!-- generated by `{cmd}`: do not edit by hand -->\n\n"
        f"Measured with `{cmd}` (one thread; Python {platform.python_version()}, "
        f"{platform.machine()}); the whole study took {total:.0f} s. ★ marks the error–cost "
        f"frontier of each case. V6: time-step error against the same resolution run with rk4 "
        f"at dt0/16; \"vs finest\" against the {refs['finest']} reference.\n\n")
    md, png = write(points, args.out, "_quick" if args.quick else "", header)
    print(header + table(points))
    print(f"wrote {md} and {png}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
