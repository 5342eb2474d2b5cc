"""Conformance suite for contact laws (rheologies), and helpers for contact tests.

Every contact law (a :class:`~siku_core.interfaces.ContactLaw`) must:

1. obey Newton's third law through the engine's apply path, for its collision evaluator and,
   for joint laws, its joint evaluator (:func:`check_newton_third_law`). On a sphere the exact
   statement is about torques: the contributions of a pair to the torque about the planet centre
   cancel (to round-off), so the pair conserves its angular momentum about the planet centre.
   The tangential forces of the two elements live in two tangent planes; mapped to the global
   frame they cancel up to a radial remainder of relative size ``O(d / R)`` (``d`` the distance
   between the centres), which is checked with that bound;
2. exert no force on a separated pair without a joint (:func:`check_zero_force_when_apart`);
3. have compiled evaluators equal to their pure-Python form (``evaluator.py_func``) on random
   geometry vectors, history updates and break flags included
   (:func:`check_compiled_matches_python`);
4. give finite output in degenerate geometry: zero overlap area, zero contact width, a joint
   whose two ends coincide (zero width), two coincident elements, two elements that only touch
   (:func:`check_degenerate_finite`);
5. be passive: over a push–release cycle of an isolated pair (one element driven along a
   closed path of rigid motions, the other held), the work the contact does on the driven
   element never exceeds zero: a contact cannot give back more energy than was put into it
   (:func:`check_passivity`; catches anti-springs and negative damping);
6. derive its joint force and couple from its stored energy, where the law declares one
   (``joint_energy(g, pars, hist) -> J``; :func:`check_energy`);
7. change its history only as it declares (:func:`check_history`): only its
   ``history_names`` columns, and with ``history_update = "state"`` (the default: maxima,
   failure flags, damage) evaluating the same geometry again changes nothing; with ``"rate"``
   (history integrated over the time step) nothing changes again at ``dt = 0``.

An evaluator that raises (a 0/0, a domain error) or returns non-finite numbers is reported as a
finding of the check that met it, with the geometry. Every message starts with the law's name
and the check's, e.g. ``anti_spring: passivity: ...``.

:func:`check_contact_law` runs them all on a law class, registered or not:

.. code-block:: python

    from siku_core.testing.contact_conformance import check_contact_law
    from my_package.laws import MyLaw

    def test_my_law_conforms():
        check_contact_law(MyLaw, params={"stiffness": 2.0})

The geometry vectors follow the layouts ``G_*`` / ``J_*`` of :mod:`siku_core.contacts`; the
scene helpers (:func:`contact_scene_text`, :func:`square_pack`, :func:`rotate_about`, ...) are
shared with siku's own contact tests. Importing this module loads numba and siku's engine
modules, but neither h5py, netCDF4, xarray nor any plugin.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..contacts import (
    G_AREA,
    G_AREA_I,
    G_AREA_J,
    G_CX,
    G_CY,
    G_K,
    G_MEFF,
    G_NX,
    G_NY,
    G_SIZE,
    G_VX,
    G_VY,
    G_WIDTH,
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_DT,
    J_EI,
    J_EJ,
    J_HI,
    J_HJ,
    J_K,
    J_L0,
    J_MEFF,
    J_NU,
    J_S1X,
    J_S1Y,
    J_S2X,
    J_S2Y,
    J_SIZE,
    J_VAX,
    J_VAY,
    J_VBX,
    J_VBY,
    J_W,
)
from ..geometry.quat import centers, qmatrix, qmul
from ..plugins import Registry, get_registry
from ..scene import Scene, scene_from_text
from .scenes import EARTH_RADIUS, _key, scene_text, square, toml_value

# ---------------------------------------------------------------------------------------------
# scene helpers


def square_pack(lon: float, lat: float, nx: int, ny: int, size: float = 2000.0,
                radius: float = EARTH_RADIUS, **keys: Any) -> dict[str, Any]:
    """An ``[[elements.pack]]`` table of ``nx × ny`` cells about ``size`` [m] square.

    ``(lon, lat)`` [deg] is the south-west corner; the cells are ``size`` tall and ``size``
    wide at the pack's middle latitude. ``keys`` adds pack keys (``gap``, ``jitter``,
    ``right = "steady"``, ...).
    """
    dlat = math.degrees(size / radius)
    dlon = dlat / math.cos(math.radians(lat + 0.5 * ny * dlat))
    return {"lon": [lon, lon + nx * dlon], "lat": [lat, lat + ny * dlat], "nx": nx, "ny": ny,
            **keys}


def contact_scene_text(
    law: str,
    params: Mapping[str, Any] | None = None,
    *,
    elements: Sequence[Any] = (),
    packs: Sequence[Mapping[str, Any]] = (),
    joints: str | None = None,
    pairs: Sequence[Sequence[int]] | None = None,
    tolerance: float | None = None,
    broad_phase: str | None = None,
    skin: float | None = None,
    touching: str | None = None,
    jointed: str | None = None,
    dt: float = 0.01,
    duration: float | None = None,
    steps: int = 100,
    size: float = 2000.0,
    thickness: float = 1.0,
    youngs_modulus: float = 1e9,
    poisson_ratio: float = 0.3,
    **kwargs: Any,
) -> str:
    """Scene TOML with a ``[contact]`` table: the arguments of
    :func:`~siku_core.testing.scene_text` (``elements``: square polygons of side ``size``;
    ``packs``: pack tables, e.g. from :func:`square_pack`; ``run``, ``output``, ...) plus the
    law, its parameters and the ``[contact]`` keys. Ice: ``thickness`` [m], one material
    ``ice`` with ``youngs_modulus`` [Pa] and ``poisson_ratio``. ``duration`` defaults to
    ``steps × dt``."""
    contact: dict[str, Any] = {"law": law}
    if params:
        contact["params"] = dict(params)
    for k, v in (("joints", joints), ("pairs", pairs), ("tolerance", tolerance),
                 ("broad_phase", broad_phase), ("skin", skin), ("touching", touching),
                 ("jointed", jointed)):
        if v is not None:
            contact[k] = [list(map(int, p)) for p in v] if k == "pairs" else v
    table = "[contact]\n" + "\n".join(f"{_key(k)} = {toml_value(v)}" for k, v in contact.items())
    extra = kwargs.pop("extra", "")
    return scene_text(
        elements, packs=packs, dt=dt, duration=steps * dt if duration is None else duration,
        size=size, thickness=thickness,
        materials={"ice": {"youngs_modulus": youngs_modulus, "poisson_ratio": poisson_ratio}},
        extra=table + ("\n\n" + extra if extra else ""), **kwargs,
    )


def contact_scene(*args: Any, label: str = "<contact test scene>", **kwargs: Any) -> Scene:
    """The validated :class:`~siku_core.scene.Scene` of :func:`contact_scene_text`."""
    return scene_from_text(contact_scene_text(*args, **kwargs), label)


def axis_angle(axis: Sequence[float], angle: float) -> np.ndarray:
    """Unit quaternion (scalar first) of a turn by ``angle`` [rad] about ``axis``."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    return np.array([math.cos(0.5 * angle), *(math.sin(0.5 * angle) * a)])


def rotate_about(q: np.ndarray, axis: Sequence[float], angle: float) -> np.ndarray:
    """Element quaternion ``q`` turned by ``angle`` [rad] about the global ``axis`` (through
    the planet centre): ``axis_angle(axis, angle) ∘ q``."""
    return qmul(axis_angle(axis, angle), np.asarray(q, dtype=float))


def pull_apart(q: np.ndarray, i: int, j: int, s: float, radius: float) -> np.ndarray:
    """Copy of ``q`` with element ``j`` moved by ``s`` [m] along the great circle away from
    ``i`` (``s < 0``: towards it); orientation carried along that great circle."""
    c = centers(q)
    out = q.copy()
    out[j] = rotate_about(q[j], np.cross(c[i], c[j]), s / radius)
    return out


def global_torques(q: np.ndarray, F: np.ndarray, T: np.ndarray, radius: float) -> np.ndarray:
    """Torque about the planet centre [N m] of each element, ``(N, 3)`` global, from the
    engine's generalised forces: ``tau_body = (-R Fy, R Fx, T)`` rotated by ``q``."""
    out = np.empty((q.shape[0], 3))
    for k in range(q.shape[0]):
        tb = np.array([-radius * F[k, 1], radius * F[k, 0], T[k]])
        out[k] = qmatrix(q[k]) @ tb
    return out


def global_forces(q: np.ndarray, F: np.ndarray) -> np.ndarray:
    """Each element's generalised force ``(Fx, Fy)`` [N] as a global 3-vector ``(N, 3)``."""
    out = np.empty((q.shape[0], 3))
    for k in range(q.shape[0]):
        out[k] = qmatrix(q[k]) @ np.array([F[k, 0], F[k, 1], 0.0])
    return out


def law_registry(law_cls: type, registry: Registry | None = None) -> Registry:
    """A registry holding ``law_cls`` (under its ``name``) next to the components of
    ``registry`` (default: the process-wide one): lets an unregistered law run in a scene."""
    base = registry or get_registry()
    table = base.entries.get("contact_law", {})
    if law_cls.name in table and table[law_cls.name].cls is law_cls:
        return base
    reg = Registry(entries={k: dict(v) for k, v in base.entries.items()},
                   broken=dict(base.broken), plugins=dict(base.plugins))
    reg.entries["contact_law"].pop(law_cls.name, None)
    reg.add("contact_law", law_cls, law_cls.__module__.split(".")[0], "unknown")
    return reg


def law_simulation(law_cls: type, params: Mapping[str, Any] | None = None, **scene_kwargs: Any):
    """A :class:`~siku_core.simulation.Simulation` (no output) of a
    :func:`contact_scene_text` scene with ``law_cls``."""
    from ..simulation import Simulation

    scene = contact_scene(law_cls.name, params, label=f"<conformance {law_cls.name}>",
                          **scene_kwargs)
    return Simulation(scene, out=False, progress=False, registry=law_registry(law_cls))


def contact_forces(sim: Any, q: np.ndarray | None = None, V: np.ndarray | None = None,
                   w: np.ndarray | None = None, commit: bool = False):
    """Contact forces ``F (N, 2)`` [N] and torques ``T (N,)`` [N m] of ``sim`` for a state
    (default: the current one) through the engine (:meth:`ContactModel.add`); joint history
    changes only with ``commit``."""
    st = sim.state
    q = st.q.copy() if q is None else q
    V = st.V.copy() if V is None else V
    w = st.w.copy() if w is None else w
    F = np.zeros((st.n, 2))
    T = np.zeros(st.n)
    sim.contacts.add(sim.time, q, V, w, F, T, commit)
    return F, T


def _call(law_cls: type, check: str, which: str, fn: Any, g: np.ndarray, *args: Any,
          case: str = "") -> None:
    """``fn(g, *args)``; an exception becomes the check's finding, naming the law, the
    evaluator, the geometry case and ``g``."""
    try:
        fn(g, *args)
    except Exception as exc:  # noqa: BLE001 - any exception of an evaluator is a finding
        where = f" on {case}" if case else ""
        raise AssertionError(
            f"{law_cls.name}: {check}: {which} evaluator raised {type(exc).__name__}: {exc}"
            f"{where} (g = {np.asarray(g).tolist()})"
        ) from None


def _evaluators(law_cls: type) -> tuple[Any, Any]:
    """The law's evaluators as stored on the class (numba dispatchers, not bound methods)."""
    coll = getattr(law_cls, "collision_evaluator", None)
    joint = getattr(law_cls, "joint_evaluator", None) if law_cls.uses_joints else None
    return coll, joint


# ---------------------------------------------------------------------------------------------
# scenes of the checks: 2 km squares of 1 m ice at 70°N

_LAT = 70.0
_SIZE = 2000.0


def _overlap_kwargs() -> dict[str, Any]:
    """Two squares overlapping by 150 m, offset 400 m north, moving and spinning."""
    R = EARTH_RADIUS
    dlon = math.degrees(1850.0 / (R * math.cos(math.radians(_LAT))))
    dlat = math.degrees(400.0 / R)
    return {"elements": [
        {"center": (10.0, _LAT), "velocity": (0.3, -0.1), "spin": 2e-4},
        {"center": (10.0 + dlon, _LAT + dlat), "velocity": (-0.2, 0.25), "spin": -3e-4},
    ], "size": _SIZE, "joints": "none"}


def _joint_kwargs() -> dict[str, Any]:
    """A jointed pair: a 2 × 1 pack of 2 km cells with 2 m of open water between them (the
    joint is detected within the 10 % tolerance), so no collision acts while displaced."""
    return {"packs": [square_pack(10.0, _LAT, 2, 1, _SIZE, gap=0.001)], "joints": "auto"}


def _separated_kwargs() -> dict[str, Any]:
    R = EARTH_RADIUS
    dlon = math.degrees(2500.0 / (R * math.cos(math.radians(_LAT))))
    return {"elements": [
        {"center": (10.0, _LAT), "velocity": (0.3, -0.1), "spin": 2e-4},
        {"center": (10.0 + dlon, _LAT), "velocity": (-0.2, 0.25), "spin": -3e-4},
    ], "size": _SIZE, "joints": "none"}


def _assert_pair_balanced(sim: Any, q: np.ndarray, F: np.ndarray, T: np.ndarray, what: str,
                          rtol: float = 1e-12) -> None:
    R = sim.radius
    tau = global_torques(q, F, T, R)
    scale = float(np.abs(tau).sum())
    assert scale > 0.0, f"{what}: no force at all, nothing to check"
    net = np.linalg.norm(tau.sum(axis=0))
    assert net <= rtol * scale, (
        f"{what}: torques about the planet centre do not cancel: |sum| = {net:.3e} N m for "
        f"sum |tau| = {scale:.3e} N m (relative {net / scale:.2e} > {rtol:g}); the pair would "
        "change its angular momentum"
    )
    # tangential forces in two tangent planes: they cancel up to O(d/R), d the span of the pair
    c = centers(q)
    d = R * float(np.arccos(np.clip(c[0] @ c[1], -1.0, 1.0))) + float(sim.state.radius.sum())
    fg = global_forces(q, F)
    fmax = float(np.linalg.norm(fg, axis=1).max())
    net_f = float(np.linalg.norm(fg.sum(axis=0)))
    bound = 4.0 * d / R * fmax + 1e-12 * fmax
    assert net_f <= bound, (
        f"{what}: forces on i and j do not cancel: |F_i + F_j| = {net_f:.3e} N for |F| = "
        f"{fmax:.3e} N (bound {bound:.3e} N from the curvature, 4 d/R)"
    )


# ---------------------------------------------------------------------------------------------
# checks


def check_newton_third_law(law_cls: type, params: Mapping[str, Any] | None = None) -> None:
    """Both evaluators, through the engine (``ContactModel.add``): the pair's torques about the
    planet centre cancel to 1e-12 relative, and the forces on ``i`` and ``j`` cancel up to the
    curvature term ``4 d/R``. The collision pair overlaps obliquely while moving and spinning
    (elastic, damping, friction and couples all act); the jointed pair is pulled, sheared and
    twisted while moving apart and spinning."""
    sim = law_simulation(law_cls, params, **_overlap_kwargs())
    F, T = contact_forces(sim, commit=True)
    assert sim.contacts.n_overlap == 1, f"{law_cls.name}: the overlapping pair does not overlap"
    _assert_pair_balanced(sim, sim.state.q, F, T, f"{law_cls.name} collision evaluator")
    if not law_cls.uses_joints:
        return
    sim = law_simulation(law_cls, params, **_joint_kwargs())
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
    _assert_pair_balanced(sim, q, F, T, f"{law_cls.name} joint evaluator")


def check_zero_force_when_apart(law_cls: type, params: Mapping[str, Any] | None = None) -> None:
    """Two moving, spinning elements 500 m apart, without a joint: exactly zero force and
    torque."""
    sim = law_simulation(law_cls, params, **_separated_kwargs())
    F, T = contact_forces(sim)
    assert not np.any(F) and not np.any(T), (
        f"{law_cls.name}: separated pair without joint got F = {F.tolist()}, T = {T.tolist()}"
    )


def random_collision_geometry(rng: np.random.Generator) -> np.ndarray:
    """A plausible random collision geometry vector (layout ``G_*``)."""
    g = np.empty(G_SIZE)
    g[G_AREA] = rng.choice([0.0, rng.uniform(0.0, 1e5), rng.uniform(0.0, 1e7)])
    g[G_CX], g[G_CY] = rng.uniform(-2e3, 2e3, 2)
    a = rng.uniform(0, 2 * math.pi)
    g[G_NX], g[G_NY] = math.cos(a), math.sin(a)
    g[G_WIDTH] = rng.uniform(0.0, 4e3)
    g[G_K] = rng.uniform(1e3, 1e7)
    g[G_MEFF] = rng.uniform(1e6, 1e11)
    g[G_VX], g[G_VY] = rng.normal(0.0, 0.5, 2)
    g[G_AREA_I], g[G_AREA_J] = rng.uniform(1e4, 1e7, 2)
    return g


def random_joint_geometry(rng: np.random.Generator) -> np.ndarray:
    """A plausible random joint geometry vector (layout ``J_*``): strains about 1e-5 to 1e-3,
    so that some joints hold, some segments fail and some joints break."""
    g = np.empty(J_SIZE)
    L0 = rng.uniform(200.0, 5e3)
    scale = L0 * 10 ** rng.uniform(-5, -3)
    g[J_S1X], g[J_S1Y], g[J_S2X], g[J_S2Y] = rng.normal(0.0, scale, 4)
    m = rng.uniform(-2e3, 2e3, 2)
    a = rng.uniform(0, 2 * math.pi)
    wdt = rng.uniform(1.0, 4e3)
    t = np.array([math.cos(a), math.sin(a)])
    g[J_AX], g[J_AY] = m - 0.5 * wdt * t
    g[J_BX], g[J_BY] = m + 0.5 * wdt * t
    g[J_L0] = L0
    g[J_W] = wdt
    g[J_K] = rng.uniform(1e3, 1e7)
    g[J_MEFF] = rng.uniform(1e6, 1e11)
    g[J_VAX], g[J_VAY], g[J_VBX], g[J_VBY] = rng.normal(0.0, 0.1, 4)
    g[J_HI], g[J_HJ] = rng.uniform(0.1, 5.0, 2)
    g[J_EI], g[J_EJ] = rng.uniform(0.25e9, 4e9, 2)
    g[J_NU] = rng.uniform(0.0, 0.45)
    g[J_DT] = rng.uniform(1e-3, 10.0)
    return g


def _close(a: np.ndarray, b: np.ndarray, rtol: float) -> bool:
    scale = max(float(np.abs(b).max()), 1e-300)
    return bool(np.allclose(a, b, rtol=rtol, atol=rtol * scale))


def check_compiled_matches_python(law_cls: type, params: Mapping[str, Any] | None = None,
                                  n: int = 200, seed: int = 0, rtol: float = 1e-12) -> None:
    """Each compiled evaluator equals ``evaluator.py_func`` on ``n`` random geometry vectors:
    outputs and history to ``rtol`` (relative to the largest component: compiled ``math``
    functions such as ``hypot`` may differ from CPython's in the last bit), break flags exactly
    (joint laws are evaluated twice, the second time on the history the first left)."""
    sim = law_simulation(law_cls, params, **_separated_kwargs())
    law = sim.contacts.law
    coll, joint = _evaluators(law_cls)
    rng = np.random.default_rng(seed)
    cpars = np.ascontiguousarray(law.collision_parameters(), dtype=float)
    for k in range(n):
        g = random_collision_geometry(rng)
        oc, op = np.zeros(4), np.zeros(4)
        _call(law_cls, "compiled == python", "collision", coll, g.copy(), cpars, oc)
        _call(law_cls, "compiled == python", "collision (py_func)", coll.py_func, g.copy(),
              cpars, op)
        assert _close(oc, op, rtol), (
            f"{law_cls.name}: compiled == python: compiled collision evaluator {oc.tolist()} "
            "!= py_func "
            f"{op.tolist()} for g = {g.tolist()}"
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
            _call(law_cls, "compiled == python", "joint", joint, g.copy(), jpars, hc, oc)
            _call(law_cls, "compiled == python", "joint (py_func)", joint.py_func, g.copy(),
                  jpars, hp, op)
            assert oc[3] == op[3] and _close(hc, hp, rtol) and _close(oc, op, rtol), (
                f"{law_cls.name}: compiled == python: compiled joint evaluator out "
                f"{oc.tolist()}, hist "
                f"{hc.tolist()} != py_func out {op.tolist()}, hist {hp.tolist()} "
                f"(evaluation {rep + 1}) for g = {g.tolist()}"
            )
            g[[J_S1X, J_S1Y, J_S2X, J_S2Y]] *= rng.uniform(0.3, 2.0)


def degenerate_collision_geometries() -> list[tuple[str, np.ndarray]]:
    """Collision geometry vectors of degenerate contacts, with names."""
    base = np.zeros(G_SIZE)
    base[G_NX] = 1.0
    base[G_K] = 5e5
    base[G_MEFF] = 1e9
    base[G_AREA_I] = base[G_AREA_J] = 4e6
    out = []
    g = base.copy()
    out.append(("zero area, zero width, at rest", g))
    g = base.copy()
    g[G_VX], g[G_VY] = -0.5, 0.3
    out.append(("zero area, zero width, moving", g))
    g = base.copy()
    g[G_AREA] = 50.0
    g[G_VX] = -0.5
    out.append(("positive area, zero width", g))
    g = base.copy()
    g[G_WIDTH] = 100.0
    g[G_VX] = 0.5
    out.append(("zero area, positive width", g))
    g = base.copy()
    g[G_AREA] = 10.0
    g[G_K] = 0.0
    g[G_AREA_I] = g[G_AREA_J] = 0.0
    g[G_VY] = 1.0
    out.append(("zero stiffness (coincident centres), zero element areas", g))
    return out


def degenerate_joint_geometries() -> list[tuple[str, np.ndarray]]:
    """Joint geometry vectors of degenerate joints, with names."""
    base = np.zeros(J_SIZE)
    base[J_AX] = base[J_BX] = 1000.0
    base[J_AY], base[J_BY] = -1000.0, 1000.0
    base[J_W] = 2000.0
    base[J_L0] = 2000.0
    base[J_K] = 5e5
    base[J_MEFF] = 1e9
    base[J_HI] = base[J_HJ] = 1.0
    base[J_EI] = base[J_EJ] = 1e9
    base[J_NU] = 0.3
    base[J_DT] = 0.1
    out = []
    out.append(("at rest (coincident copies of both ends)", base.copy()))
    for label, s in (("at rest", 0.0), ("pulled", 0.1)):
        g = base.copy()
        g[J_BY] = g[J_AY]  # coincident ends: zero width
        g[J_W] = 0.0
        g[J_S1X] = g[J_S2X] = s
        g[J_VAX] = g[J_VBX] = 0.1
        out.append((f"coincident joint ends (zero width), {label}", g))
    g = base.copy()
    g[J_S1X], g[J_S2X] = 0.1, -0.1
    g[J_VAY] = 0.2
    out.append(("opposite end displacements (pure couple)", g))
    return out


def check_degenerate_finite(law_cls: type, params: Mapping[str, Any] | None = None) -> None:
    """Finite forces, couples, flags and history for the degenerate geometry vectors above,
    and through the engine for two coincident elements and for two elements that only touch
    along an edge (zero overlap area)."""
    coll, joint = _evaluators(law_cls)
    sim = law_simulation(law_cls, params, **_separated_kwargs())
    law = sim.contacts.law
    cpars = np.ascontiguousarray(law.collision_parameters(), dtype=float)
    check = "degenerate geometry"
    for name, g in degenerate_collision_geometries():
        out = np.zeros(4)
        _call(law_cls, check, "collision", coll, g, cpars, out, case=name)
        assert np.isfinite(out).all(), (
            f"{law_cls.name}: {check}: collision evaluator, {name}: out = {out.tolist()}")
    if joint is not None:
        jpars = np.ascontiguousarray(law.joint_parameters(), dtype=float)
        nh = max(len(law.history_names), 1)
        for name, g in degenerate_joint_geometries():
            out, hist = np.zeros(4), np.zeros(nh)
            _call(law_cls, check, "joint", joint, g, jpars, hist, out, case=name)
            assert np.isfinite(out).all() and np.isfinite(hist).all(), (
                f"{law_cls.name}: {check}: joint evaluator, {name}: out = {out.tolist()}, "
                f"hist = {hist.tolist()}"
            )
    R = EARTH_RADIUS
    dlon = math.degrees(_SIZE / (R * math.cos(math.radians(_LAT))))
    cases = {
        "coincident elements": [{"center": (10.0, _LAT), "velocity": (0.2, 0.0)},
                                {"center": (10.0, _LAT), "velocity": (-0.2, 0.1), "spin": 1e-4}],
        "touching elements": [{"vertices": v} for v in _touching_squares(dlon)],
    }
    for name, elements in cases.items():
        sim = law_simulation(law_cls, params, elements=elements, size=_SIZE, joints="none")
        try:
            F, T = contact_forces(sim)
        except Exception as exc:  # noqa: BLE001 - a finding
            raise AssertionError(f"{law_cls.name}: {check}: {name}: the engine's contact "
                                 f"loop raised {type(exc).__name__}: {exc}") from None
        assert np.isfinite(F).all() and np.isfinite(T).all(), (
            f"{law_cls.name}: {check}: {name}: F = {F.tolist()}, T = {T.tolist()}"
        )


def _touching_squares(dlon: float) -> list[list[list[float]]]:
    """Two lon/lat boxes sharing their common meridian edge exactly."""
    dlat = math.degrees(_SIZE / EARTH_RADIUS)
    lat0, lat1 = _LAT, _LAT + dlat
    lons = (10.0, 10.0 + dlon, 10.0 + 2 * dlon)
    return [[[lons[k], lat0], [lons[k + 1], lat0], [lons[k + 1], lat1], [lons[k], lat1]]
            for k in range(2)]


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
    dlon = math.degrees(2010.0 / (R * math.cos(math.radians(_LAT))))
    sim = law_simulation(law_cls, params, size=_SIZE, joints="none", elements=[
        {"center": (10.0, _LAT)}, {"center": (10.0 + dlon, _LAT)}])
    a, b, c = _pair_axes(sim)
    d = 160.0 / R / steps
    path = _cycle([-a * d + b * (d / 3.0) + c * (3e-3 / steps)] * steps)
    for tau_s, how in ((None, "quasi-static"), (10.0, "moving")):
        sim = law_simulation(law_cls, params, size=_SIZE, joints="none", elements=[
            {"center": (10.0, _LAT)}, {"center": (10.0 + dlon, _LAT)}])
        _driven_work(sim, path, tau_s, f"collision cycle, {how}", check, law_cls.name, 160.0)
    if not law_cls.uses_joints:
        return
    for tau_s, how in ((None, "quasi-static"), (10.0, "moving")):
        sim = law_simulation(law_cls, params, **_joint_kwargs())
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
    energy = getattr(law_cls, "joint_energy", None)
    if energy is None or not law_cls.uses_joints:
        return
    energy = getattr(energy, "__func__", energy)
    sim = law_simulation(law_cls, params, **_separated_kwargs())
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
        _call(law_cls, check, "joint", joint, g.copy(), jpars, hist, out)
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


def check_history(law_cls: type, params: Mapping[str, Any] | None = None, n: int = 100,
                  seed: int = 2) -> None:
    """On ``n`` random joints: the joint evaluator writes no history column beyond its
    ``history_names`` (guard columns after them stay as they were), and evaluating the same
    geometry a second time (at ``dt = 0`` for ``history_update = "rate"``) leaves the history
    as the first evaluation left it."""
    check = "history"
    if not law_cls.uses_joints:
        return
    sim = law_simulation(law_cls, params, **_separated_kwargs())
    law = sim.contacts.law
    joint = law_cls.joint_evaluator
    jpars = np.ascontiguousarray(law.joint_parameters(), dtype=float)
    nh = len(law.history_names)
    rate = getattr(law, "history_update", "state") == "rate"
    rng = np.random.default_rng(seed)
    guard = 1234.5678
    for _ in range(n):
        g = random_joint_geometry(rng)
        if rate:
            g[J_DT] = 0.0
        hist = np.full(max(nh, 1) + 2, guard)
        hist[:nh] = 0.0
        out = np.zeros(4)
        _call(law_cls, check, "joint", joint, g.copy(), jpars, hist, out)
        assert np.all(hist[nh:] == guard), (
            f"{law_cls.name}: {check}: the joint evaluator wrote history column(s) "
            f"{[k for k in range(nh, len(hist)) if hist[k] != guard]} beyond its "
            f"{nh} history_names {tuple(law.history_names)} (g = {g.tolist()})"
        )
        first = hist.copy()
        _call(law_cls, check, "joint", joint, g.copy(), jpars, hist, np.zeros(4))
        assert np.array_equal(hist, first, equal_nan=True), (
            f"{law_cls.name}: {check}: evaluating the same joint again changed its history "
            f"from {first[:nh].tolist()} to {hist[:nh].tolist()}"
            + (" at dt = 0" if rate else "")
            + f" (history_update = {'rate' if rate else 'state'!r}: the history must depend "
            "on the geometry " + ("and the time step" if rate else "it has seen")
            + f", not on the number of calls; g = {g.tolist()})"
        )


def check_contact_law(law_cls: type, params: Mapping[str, Any] | None = None) -> None:
    """Run every contact-law conformance check on ``law_cls`` (registered or not) with the
    given parameters (defaults otherwise)."""
    check_newton_third_law(law_cls, params)
    check_zero_force_when_apart(law_cls, params)
    check_history(law_cls, params)
    check_compiled_matches_python(law_cls, params)
    check_degenerate_finite(law_cls, params)
    check_passivity(law_cls, params)
    check_energy(law_cls, params)


__all__ = [
    "axis_angle", "check_compiled_matches_python", "check_contact_law",
    "check_degenerate_finite", "check_energy", "check_history", "check_newton_third_law",
    "check_passivity", "check_zero_force_when_apart",
    "contact_forces", "contact_scene", "contact_scene_text", "degenerate_collision_geometries",
    "degenerate_joint_geometries", "global_forces", "global_torques", "law_registry",
    "law_simulation", "pull_apart", "random_collision_geometry", "random_joint_geometry",
    "rotate_about", "square", "square_pack",
]
