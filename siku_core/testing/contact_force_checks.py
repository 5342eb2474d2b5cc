"""Force checks of the contact-law conformance suite
(:mod:`siku_core.testing.contact_conformance`): Newton's third law through the engine's apply
path, no force on a separated pair, compiled evaluators equal to their Python form, finite
output in degenerate geometry.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..contact_law import (
    J_S1X,
    J_S1Y,
    J_S2X,
    J_S2Y,
)
from ..geometry.quat import centers
from .contact_cases import (
    CASE_LAT,
    CASE_SIZE,
    assert_pair_balanced,
    call_law,
    law_evaluators,
    joint_kwargs,
    overlap_kwargs,
    separated_kwargs,
    touching_squares,
    contact_forces,
    contact_history_row,
    degenerate_collision_geometries,
    degenerate_joint_geometries,
    law_simulation,
    pull_apart,
    random_collision_geometry,
    random_joint_geometry,
    rotate_about,
)
from .scenes import EARTH_RADIUS

# ---------------------------------------------------------------------------------------------
# checks


def check_newton_third_law(law_cls: type, params: Mapping[str, Any] | None = None) -> None:
    """Both evaluators, through the engine (``ContactModel.add``): the pair's torques about the
    planet centre cancel to 1e-12 relative, and the forces on ``i`` and ``j`` cancel up to the
    curvature term ``4 d/R``. The collision pair overlaps obliquely while moving and spinning
    (elastic, damping, friction and couples all act); the jointed pair is pulled, sheared and
    twisted while moving apart and spinning."""
    sim = law_simulation(law_cls, params, **overlap_kwargs())
    F, T = contact_forces(sim, commit=True)
    assert sim.contacts.n_overlap == 1, f"{law_cls.name}: the overlapping pair does not overlap"
    assert_pair_balanced(sim, sim.state.q, F, T, f"{law_cls.name} collision evaluator")
    if not law_cls.uses_joints:
        return
    sim = law_simulation(law_cls, params, **joint_kwargs())
    cm = sim.contacts
    assert cm.n_joints == 1, f"{law_cls.name}: expected one joint in the pair, got {cm.n_joints}"
    R = sim.radius
    q = pull_apart(sim.state.q, 0, 1, 0.05, R)
    c = centers(q)
    q[1] = rotate_about(q[1], c[1], 2e-5)  # twist j about its centre
    north = np.cross(np.cross(c[0], c[1]), c[1])
    q[1] = rotate_about(q[1], np.cross(c[1], north), 0.03 / R)  # shear j along the joint
    V = np.array([[0.01, -0.02], [0.03, 0.01]])
    w = np.array([1e-5, -2e-5])
    F, T = contact_forces(sim, q, V, w, commit=True)
    assert sim.contacts.n_overlap == 0, "jointed pair of the check overlaps (test setup)"
    assert cm.n_intact == 1, f"{law_cls.name}: the joint broke under a strain of 5e-5"
    assert_pair_balanced(sim, q, F, T, f"{law_cls.name} joint evaluator")


def check_zero_force_when_apart(law_cls: type, params: Mapping[str, Any] | None = None) -> None:
    """Two moving, spinning elements 500 m apart, without a joint: exactly zero force and
    torque."""
    sim = law_simulation(law_cls, params, **separated_kwargs())
    F, T = contact_forces(sim)
    assert not np.any(F) and not np.any(T), (
        f"{law_cls.name}: separated pair without joint got F = {F.tolist()}, T = {T.tolist()}"
    )



def _close(a: np.ndarray, b: np.ndarray, rtol: float) -> bool:
    scale = max(float(np.abs(b).max()), 1e-300)
    return bool(np.allclose(a, b, rtol=rtol, atol=rtol * scale))


def _rows(h: tuple) -> str:
    return f", contact history {h[0].tolist()}" if h else ""


def check_compiled_matches_python(law_cls: type, params: Mapping[str, Any] | None = None,
                                  n: int = 200, seed: int = 0, rtol: float = 1e-12) -> None:
    """Each compiled evaluator equals ``evaluator.py_func`` on ``n`` random geometry vectors:
    outputs and history to ``rtol`` (relative to the largest component: compiled ``math``
    functions such as ``hypot`` may differ from CPython's in the last bit), break flags exactly
    (joint laws are evaluated twice, the second time on the history the first left)."""
    sim = law_simulation(law_cls, params, **separated_kwargs())
    law = sim.contacts.law
    coll, joint = law_evaluators(law_cls)
    rng = np.random.default_rng(seed)
    cpars = np.ascontiguousarray(law.collision_parameters(), dtype=float)
    for k in range(n):
        g = random_collision_geometry(rng)
        hc, hp = contact_history_row(law), contact_history_row(law)  # () or (zero row,)
        for rep in range(2 if hc else 1):  # twice on the row the first evaluation left
            oc, op = np.zeros(4), np.zeros(4)
            call_law(law_cls, "compiled == python", "collision", coll, g.copy(), cpars, *hc, oc)
            call_law(law_cls, "compiled == python", "collision (py_func)", coll.py_func,
                  g.copy(), cpars, *hp, op)
            assert _close(oc, op, rtol) and all(_close(a, b, rtol) for a, b in zip(hc, hp)), (
                f"{law_cls.name}: compiled == python: compiled collision evaluator "
                f"{oc.tolist()}{_rows(hc)} != py_func {op.tolist()}{_rows(hp)} "
                f"(evaluation {rep + 1}) for g = {g.tolist()}"
            )
    if joint is None:
        return
    jpars = np.ascontiguousarray(law.joint_parameters(), dtype=float)
    nh = max(len(law.history_names), 1)
    for k in range(n):
        g = random_joint_geometry(rng)
        hc, hp = np.zeros(nh), np.zeros(nh)
        for rep in range(2):
            oc, op = np.zeros(4), np.zeros(4)
            call_law(law_cls, "compiled == python", "joint", joint, g.copy(), jpars, hc, oc)
            call_law(law_cls, "compiled == python", "joint (py_func)", joint.py_func, g.copy(),
                  jpars, hp, op)
            assert oc[3] == op[3] and _close(hc, hp, rtol) and _close(oc, op, rtol), (
                f"{law_cls.name}: compiled == python: compiled joint evaluator out "
                f"{oc.tolist()}, hist "
                f"{hc.tolist()} != py_func out {op.tolist()}, hist {hp.tolist()} "
                f"(evaluation {rep + 1}) for g = {g.tolist()}"
            )
            g[[J_S1X, J_S1Y, J_S2X, J_S2Y]] *= rng.uniform(0.3, 2.0)




def check_degenerate_finite(law_cls: type, params: Mapping[str, Any] | None = None) -> None:
    """Finite forces, couples, flags and history for the degenerate geometry vectors above,
    and through the engine for two coincident elements and for two elements that only touch
    along an edge (zero overlap area)."""
    coll, joint = law_evaluators(law_cls)
    sim = law_simulation(law_cls, params, **separated_kwargs())
    law = sim.contacts.law
    cpars = np.ascontiguousarray(law.collision_parameters(), dtype=float)
    check = "degenerate geometry"
    for name, g in degenerate_collision_geometries():
        out, hist = np.zeros(4), contact_history_row(law)
        call_law(law_cls, check, "collision", coll, g, cpars, *hist, out, case=name)
        assert np.isfinite(out).all() and all(np.isfinite(h).all() for h in hist), (
            f"{law_cls.name}: {check}: collision evaluator, {name}: out = {out.tolist()}"
            f"{_rows(hist)}")
    if joint is not None:
        jpars = np.ascontiguousarray(law.joint_parameters(), dtype=float)
        nh = max(len(law.history_names), 1)
        for name, g in degenerate_joint_geometries():
            out, hist = np.zeros(4), np.zeros(nh)
            call_law(law_cls, check, "joint", joint, g, jpars, hist, out, case=name)
            assert np.isfinite(out).all() and np.isfinite(hist).all(), (
                f"{law_cls.name}: {check}: joint evaluator, {name}: out = {out.tolist()}, "
                f"hist = {hist.tolist()}"
            )
    R = EARTH_RADIUS
    dlon = math.degrees(CASE_SIZE / (R * math.cos(math.radians(CASE_LAT))))
    cases = {
        "coincident elements": [{"center": (10.0, CASE_LAT), "velocity": (0.2, 0.0)},
                                {"center": (10.0, CASE_LAT), "velocity": (-0.2, 0.1),
                                 "spin": 1e-4}],
        "touching elements": [{"vertices": v} for v in touching_squares(dlon)],
    }
    for name, elements in cases.items():
        sim = law_simulation(law_cls, params, elements=elements, size=CASE_SIZE, joints="none")
        try:
            F, T = contact_forces(sim)
        except Exception as exc:  # noqa: BLE001 - a finding
            raise AssertionError(f"{law_cls.name}: {check}: {name}: the engine's contact "
                                 f"loop raised {type(exc).__name__}: {exc}") from None
        assert np.isfinite(F).all() and np.isfinite(T).all(), (
            f"{law_cls.name}: {check}: {name}: F = {F.tolist()}, T = {T.tolist()}"
        )
