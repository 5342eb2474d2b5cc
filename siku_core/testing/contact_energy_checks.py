"""Energy and history checks of the contact-law conformance suite
(:mod:`siku_core.testing.contact_conformance`): passivity over a push-release cycle, joint
forces derived from a declared stored energy, history changed only as declared.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..contact_law import (
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_DT,
    J_S1X,
    J_S1Y,
    J_S2X,
    J_S2Y,
    J_VAX,
    J_VAY,
    J_VBX,
    J_VBY,
    J_W,
)
from ..geometry.quat import centers, qmatrix
from .contact_cases import (
    CASE_LAT,
    CASE_SIZE,
    call_law,
    joint_kwargs,
    separated_kwargs,
    contact_forces,
    global_torques,
    law_simulation,
    random_collision_geometry,
    random_joint_geometry,
    rotate_about,
)
from .scenes import EARTH_RADIUS


def _cycle(steps: Sequence[np.ndarray]) -> list[np.ndarray]:
    """A closed path of rigid rotations: ``steps`` forward, then undone in reverse order."""
    return [*steps, *[-o for o in reversed(steps)]]


def _rotate(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
    """Unit quaternion ``q`` turned by the global rotation vector ``omega`` [rad]."""
    a = float(np.linalg.norm(omega))
    return q if a == 0.0 else rotate_about(q, omega / a, a)


def _driven_work(sim: Any, path: Sequence[np.ndarray], tau_s: float | None, what: str,
                 check: str, name: str, amplitude: float) -> None:
    """Drive element 1 of ``sim`` along ``path`` (global rotation vectors [rad] about the planet
    centre, one per step; element 0 held) and assert that the work the contact does on it,
    accumulated by the trapezoidal rule, never exceeds zero beyond round-off: positions on the
    sphere carry an absolute error of about ``eps R``, so the work of an exactly conservative
    force along a closed path of ``amplitude`` [m] comes back to zero only within about
    ``eps R / amplitude`` of the work exchanged (16 times that is allowed). ``tau_s``: the
    duration of a step [s] (the element moves with the matching velocity and spin); ``None``:
    quasi-static (at rest at every point). The work of step ``k`` is ``tau_mean · omega_k``
    with ``tau`` the torque about the planet centre (:func:`global_torques`)."""
    R = sim.radius
    q = sim.state.q.copy()
    n = sim.state.n
    work = [0.0]
    incs: list[float] = []

    def torque(q: np.ndarray, omega: np.ndarray) -> np.ndarray:
        V = np.zeros((n, 2))
        w = np.zeros(n)
        if tau_s is not None:  # velocity of the driven element: R omega x c / tau, local frame
            c = centers(q[1:2])[0]
            vg = R * np.cross(omega, c) / tau_s
            vl = qmatrix(q[1]).T @ vg
            V[1] = vl[:2]
            w[1] = float(omega @ c) / tau_s
        try:
            F, T = contact_forces(sim, q, V, w, commit=True)
        except Exception as exc:  # noqa: BLE001 - a finding
            raise AssertionError(f"{name}: {check}: {what}: the contact loop raised "
                                 f"{type(exc).__name__}: {exc}") from None
        assert np.isfinite(F).all() and np.isfinite(T).all(), (
            f"{name}: {check}: {what}: non-finite force F = {F.tolist()}, T = {T.tolist()}")
        return global_torques(q, F, T, R)[1]

    prev = torque(q, path[0])
    peak, at = 0.0, -1
    for k, omega in enumerate(path):
        q_next = q.copy()
        q_next[1] = _rotate(q[1], omega)
        # the velocity of a step belongs to its motion: evaluate both ends with it
        start = torque(q, omega) if tau_s is not None else prev
        end = torque(q_next, omega)
        inc = 0.5 * float((start + end) @ omega)
        incs.append(abs(inc))
        work.append(work[-1] + inc)
        if work[-1] > peak:
            peak, at = work[-1], k
        q, prev = q_next, end
    scale = sum(incs)
    assert scale > 0.0, f"{name}: {check}: {what}: no force along the path (test setup)"
    tol = 16.0 * np.finfo(float).eps * R / amplitude
    assert peak <= tol * scale, (
        f"{name}: {check}: {what}: the contact did {peak:.4e} J of net work on the driven "
        f"element after step {at + 1} of {len(path)} (work exchanged in all "
        f"{scale:.4e} J; round-off allows {tol * scale:.2e} J): it gave back more energy "
        "than was put into it (an attractive elastic force or a negative damping)"
    )


def _pair_axes(sim: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit rotation axes that move element 1 away from element 0 along the great circle
    through both, across it (shear), and turn it about its centre (twist)."""
    c = centers(sim.state.q)
    a = np.cross(c[0], c[1])
    a /= np.linalg.norm(a)
    b = np.cross(c[1], a)
    return a, b / np.linalg.norm(b), c[1]


def check_passivity(law_cls: type, params: Mapping[str, Any] | None = None,
                    steps: int = 24) -> None:
    """Push–release cycles of an isolated pair through the engine: the work the contact does
    on the driven element, from the start of the cycle, is never positive (beyond the round-off
    bound of :func:`_driven_work`). Collision: two 2 km squares 10 m apart, the second pushed
    160 m into the first with a shear of a third of that and a twist of 3e-3 rad, and back
    along the same path. Joints (joint laws): the jointed pair opened by 5 cm (strain 2.5e-5)
    with shear and twist, back through rest to 5 cm closed, and back. Each cycle
    quasi-statically (at rest at every point: elastic forces only) and moving (10 s per step:
    damping and friction act too).
    """
    check = "passivity"
    R = EARTH_RADIUS
    dlon = math.degrees(2010.0 / (R * math.cos(math.radians(CASE_LAT))))
    sim = law_simulation(law_cls, params, size=CASE_SIZE, joints="none", elements=[
        {"center": (10.0, CASE_LAT)}, {"center": (10.0 + dlon, CASE_LAT)}])
    a, b, c = _pair_axes(sim)
    d = 160.0 / R / steps
    path = _cycle([-a * d + b * (d / 3.0) + c * (3e-3 / steps)] * steps)
    for tau_s, how in ((None, "quasi-static"), (10.0, "moving")):
        sim = law_simulation(law_cls, params, size=CASE_SIZE, joints="none", elements=[
            {"center": (10.0, CASE_LAT)}, {"center": (10.0 + dlon, CASE_LAT)}])
        _driven_work(sim, path, tau_s, f"collision cycle, {how}", check, law_cls.name, 160.0)
    if not law_cls.uses_joints:
        return
    for tau_s, how in ((None, "quasi-static"), (10.0, "moving")):
        sim = law_simulation(law_cls, params, **joint_kwargs())
        assert sim.contacts.n_joints == 1, "jointed pair of the check has no joint (test setup)"
        a, b, c = _pair_axes(sim)
        d = 0.05 / R / steps
        out = [a * d + b * (0.6 * d) + c * (2e-5 / steps)] * steps
        path = _cycle(out) + _cycle([-o for o in out])
        _driven_work(sim, path, tau_s, f"joint cycle, {how}", check, law_cls.name, 0.05)
        assert sim.contacts.n_intact == 1, (
            f"{law_cls.name}: {check}: the joint broke at a strain of 2.5e-5")


def _turn_j(g: np.ndarray, dtheta: float) -> np.ndarray:
    """Joint geometry with ``j``'s copy of the joint turned by ``dtheta`` [rad] about ``i``'s
    joint midpoint (where the engine applies the joint's force)."""
    out = g.copy()
    mx, my = 0.5 * (g[J_AX] + g[J_BX]), 0.5 * (g[J_AY] + g[J_BY])
    sn = math.sin(dtheta)
    cm1 = -2.0 * math.sin(0.5 * dtheta) ** 2  # cos - 1 without cancellation
    for (ex, ey), (sx, sy) in (((J_AX, J_AY), (J_S1X, J_S1Y)), ((J_BX, J_BY), (J_S2X, J_S2Y))):
        px, py = g[ex] - mx + g[sx], g[ey] - my + g[sy]
        # s + (Rot - I) p, so that the small displacement keeps its digits
        out[sx] = g[sx] + (cm1 * px - sn * py)
        out[sy] = g[sy] + (sn * px + cm1 * py)
    return out


def check_energy(law_cls: type, params: Mapping[str, Any] | None = None, n: int = 50,
                 seed: int = 1) -> None:
    """For a law that declares ``joint_energy(g, pars, hist)`` [J]: on ``n`` random intact
    joints at rest, the force on ``j`` is minus the energy's derivative with respect to a
    translation of ``j``'s copy of the joint (to 1e-6 of the force, central differences), and
    the couple minus its derivative with respect to a turn of that copy about the point where
    the force acts, within ``|f| |d|`` (``d`` the midpoint's displacement: the couple of the
    force about the displaced midpoint, which a law may leave out) plus 1e-6 of ``|f| w``."""
    check = "energy"
    energy = law_cls.joint_energy
    if energy is None or not law_cls.uses_joints:
        return
    energy = getattr(energy, "__func__", energy)
    sim = law_simulation(law_cls, params, **separated_kwargs())
    law = sim.contacts.law
    joint = law_cls.joint_evaluator
    jpars = np.ascontiguousarray(law.joint_parameters(), dtype=float)
    nh = max(len(law.history_names), 1)
    rng = np.random.default_rng(seed)
    tested = 0
    for _ in range(n):
        g = random_joint_geometry(rng)
        g[[J_S1X, J_S1Y, J_S2X, J_S2Y]] *= 1e-2  # strains about 1e-7 to 1e-5: intact
        g[[J_VAX, J_VAY, J_VBX, J_VBY]] = 0.0
        hist, out = np.zeros(nh), np.zeros(4)
        call_law(law_cls, check, "joint", joint, g.copy(), jpars, hist, out)
        if out[3] != 0.0:
            continue
        tested += 1

        def e(gg: np.ndarray) -> float:
            try:
                return float(energy(gg, jpars, hist.copy()))
            except Exception as exc:  # noqa: BLE001 - a finding
                raise AssertionError(f"{law_cls.name}: {check}: joint_energy raised "
                                     f"{type(exc).__name__}: {exc} (g = {gg.tolist()})") from None

        smax = float(np.abs(g[[J_S1X, J_S1Y, J_S2X, J_S2Y]]).max())
        h = 0.1 * smax  # exact for energies quadratic in a translation; digits of E kept
        grad = []
        for ix, iy in ((J_S1X, J_S2X), (J_S1Y, J_S2Y)):
            gp, gm = g.copy(), g.copy()
            gp[[ix, iy]] += h
            gm[[ix, iy]] -= h
            grad.append((e(gp) - e(gm)) / (2 * h))
        f = math.hypot(out[0], out[1])
        ftol = 1e-6 * max(f, 1e-300)
        assert abs(out[0] + grad[0]) <= ftol and abs(out[1] + grad[1]) <= ftol, (
            f"{law_cls.name}: {check}: force on j {out[:2].tolist()} N is not minus the "
            f"energy's gradient {grad} N (g = {g.tolist()})"
        )
        w = g[J_W]
        dth = 1e-2 * smax / max(w, 1.0)  # truncation dth²/6 relative, negligible
        dE = (e(_turn_j(g, dth)) - e(_turn_j(g, -dth))) / (2 * dth)
        dmid = 0.5 * math.hypot(g[J_S1X] + g[J_S2X], g[J_S1Y] + g[J_S2Y])
        bound = f * dmid + 1e-6 * (f * w + abs(out[2]))
        assert abs(out[2] + dE) <= bound, (
            f"{law_cls.name}: {check}: couple on j {out[2]:.6e} N m is not minus the energy's "
            f"derivative by a turn {dE:.6e} N m (allowed {bound:.2e}; g = {g.tolist()})"
        )
    assert tested, f"{law_cls.name}: {check}: every test joint broke at strains below 1e-5"


def _check_contact_history(law_cls: type, law: Any, n: int, seed: int) -> None:
    """A law with ``contact_history_names``: its collision evaluator writes no column past
    them and leaves its row finite."""
    nch = len(law.contact_history_names)
    if not nch:
        return
    coll = law_cls.collision_evaluator
    cpars = np.ascontiguousarray(law.collision_parameters(), dtype=float)
    rng = np.random.default_rng(seed)
    guard = 1234.5678
    for _ in range(n):
        g = random_collision_geometry(rng)
        hist = np.full(nch + 2, guard)
        hist[:nch] = 0.0
        for _rep in range(2):
            call_law(law_cls, "history", "collision", coll, g.copy(), cpars, hist, np.zeros(4))
            assert np.all(hist[nch:] == guard) and np.isfinite(hist[:nch]).all(), (
                f"{law_cls.name}: history: the collision evaluator wrote contact history "
                f"{hist.tolist()}: columns past its {nch} contact_history_names "
                f"{tuple(law.contact_history_names)} or non-finite values (g = {g.tolist()})")


def check_history(law_cls: type, params: Mapping[str, Any] | None = None, n: int = 100,
                  seed: int = 2) -> None:
    """On ``n`` random joints: the joint evaluator writes no history column beyond its
    ``history_names`` (guard columns after them stay as they were), and evaluating the same
    geometry a second time (at ``dt = 0`` for ``history_update = "rate"``) leaves the history
    as the first evaluation left it."""
    check = "history"
    sim = law_simulation(law_cls, params, **separated_kwargs())
    law = sim.contacts.law
    _check_contact_history(law_cls, law, n, seed)
    if not law_cls.uses_joints:
        return
    joint = law_cls.joint_evaluator
    jpars = np.ascontiguousarray(law.joint_parameters(), dtype=float)
    nh = len(law.history_names)
    rate = law.history_update == "rate"
    rng = np.random.default_rng(seed)
    guard = 1234.5678
    for _ in range(n):
        g = random_joint_geometry(rng)
        if rate:
            g[J_DT] = 0.0
        hist = np.full(max(nh, 1) + 2, guard)
        hist[:nh] = 0.0
        out = np.zeros(4)
        call_law(law_cls, check, "joint", joint, g.copy(), jpars, hist, out)
        assert np.all(hist[nh:] == guard), (
            f"{law_cls.name}: {check}: the joint evaluator wrote history column(s) "
            f"{[k for k in range(nh, len(hist)) if hist[k] != guard]} beyond its "
            f"{nh} history_names {tuple(law.history_names)} (g = {g.tolist()})"
        )
        first = hist.copy()
        call_law(law_cls, check, "joint", joint, g.copy(), jpars, hist, np.zeros(4))
        assert np.array_equal(hist, first, equal_nan=True), (
            f"{law_cls.name}: {check}: evaluating the same joint again changed its history "
            f"from {first[:nh].tolist()} to {hist[:nh].tolist()}"
            + (" at dt = 0" if rate else "")
            + f" (history_update = {'rate' if rate else 'state'!r}: the history must depend "
            "on the geometry " + ("and the time step" if rate else "it has seen")
            + f", not on the number of calls; g = {g.tolist()})"
        )
