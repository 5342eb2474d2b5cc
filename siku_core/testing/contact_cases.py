"""Cases of the contact-law conformance suite (:mod:`siku_core.testing.contact_conformance`):
the scenes and scene helpers shared with siku's own contact tests (:func:`contact_scene_text`,
:func:`square_pack`, :func:`rotate_about`, ...), the small scenes of the checks, and the random
and degenerate geometry vectors (layouts ``G_*`` / ``J_*`` of :mod:`siku_core.contact_law`).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from ..contact_law import (
    COLLISION_LAYOUT,
    JOINT_LAYOUT,
    G_AREA,
    G_AREA_I,
    G_AREA_J,
    G_HI,
    G_HJ,
    G_CX,
    G_CY,
    G_K,
    G_MEFF,
    G_NX,
    G_NY,
    G_DTM,
    G_SIZE,
    G_VX,
    G_VY,
    G_WIDTH,
    J_AX,
    J_AY,
    J_BX,
    J_BY,
    J_DT,
    J_DTM,
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
from ..scene.scene_file import Scene, scene_from_text
from .scenes import EARTH_RADIUS, toml_key, scene_text, toml_value

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
    table = "[contact]\n" + "\n".join(f"{toml_key(k)} = {toml_value(v)}"
                                        for k, v in contact.items())
    extra = kwargs.pop("extra", "")
    return scene_text(
        elements, packs=packs, dt=dt, duration=steps * dt if duration is None else duration,
        size=size, thickness=thickness,
        materials={"ice": {"youngs_modulus": youngs_modulus, "poisson_ratio": poisson_ratio}},
        extra=table + ("\n\n" + extra if extra else ""), **kwargs,
    )


def contact_scene(*args: Any, label: str = "<contact test scene>", **kwargs: Any) -> Scene:
    """The validated :class:`~siku_core.scene.scene_file.Scene` of :func:`contact_scene_text`."""
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


def registry_with(kind: str, cls: type, registry: Registry | None = None) -> Registry:
    """A registry holding component ``cls`` of ``kind`` (under its ``name``) next to the
    components of ``registry`` (default: the process-wide one): lets an unregistered component
    (a law, a process) run in a scene."""
    base = registry or get_registry()
    table = base.entries.get(kind, {})
    if cls.name in table and table[cls.name].cls is cls:
        return base
    reg = Registry(entries={k: dict(v) for k, v in base.entries.items()},
                   broken=dict(base.broken), plugins=dict(base.plugins))
    reg.entries[kind].pop(cls.name, None)
    reg.add(kind, cls, cls.__module__.split(".")[0], "unknown")
    return reg


def law_registry(law_cls: type, registry: Registry | None = None) -> Registry:
    """:func:`registry_with` for a contact law."""
    return registry_with("contact_law", law_cls, registry)


def law_simulation(law_cls: type, params: Mapping[str, Any] | None = None, **scene_kwargs: Any):
    """A :class:`~siku_core.run.simulation.Simulation` (no output) of a
    :func:`contact_scene_text` scene with ``law_cls``."""
    from ..run.simulation import Simulation

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


def call_law(law_cls: type, check: str, which: str, fn: Any, g: np.ndarray, *args: Any,
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


def law_evaluators(law_cls: type) -> tuple[Any, Any]:
    """The law's evaluators as stored on the class (numba dispatchers, not bound methods)."""
    coll = law_cls.collision_evaluator
    joint = law_cls.joint_evaluator if law_cls.uses_joints else None
    return coll, joint


# ---------------------------------------------------------------------------------------------
# scenes of the checks: 2 km squares of 1 m ice at 70°N

CASE_LAT = 70.0
CASE_SIZE = 2000.0


def overlap_kwargs() -> dict[str, Any]:
    """Two squares overlapping by 150 m, offset 400 m north, moving and spinning."""
    R = EARTH_RADIUS
    dlon = math.degrees(1850.0 / (R * math.cos(math.radians(CASE_LAT))))
    dlat = math.degrees(400.0 / R)
    return {"elements": [
        {"center": (10.0, CASE_LAT), "velocity": (0.3, -0.1), "spin": 2e-4},
        {"center": (10.0 + dlon, CASE_LAT + dlat), "velocity": (-0.2, 0.25), "spin": -3e-4},
    ], "size": CASE_SIZE, "joints": "none"}


def joint_kwargs() -> dict[str, Any]:
    """A jointed pair: a 2 × 1 pack of 2 km cells with 2 m of open water between them (the
    joint is detected within the 10 % tolerance), so no collision acts while displaced."""
    return {"packs": [square_pack(10.0, CASE_LAT, 2, 1, CASE_SIZE, gap=0.001)], "joints": "auto"}


def separated_kwargs() -> dict[str, Any]:
    R = EARTH_RADIUS
    dlon = math.degrees(2500.0 / (R * math.cos(math.radians(CASE_LAT))))
    return {"elements": [
        {"center": (10.0, CASE_LAT), "velocity": (0.3, -0.1), "spin": 2e-4},
        {"center": (10.0 + dlon, CASE_LAT), "velocity": (-0.2, 0.25), "spin": -3e-4},
    ], "size": CASE_SIZE, "joints": "none"}


def assert_pair_balanced(sim: Any, q: np.ndarray, F: np.ndarray, T: np.ndarray, what: str,
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




def _named_vector(layout: tuple, prefix: str, what: str, values: Mapping[str, float]
                  ) -> np.ndarray:
    names = [name[len(prefix):].lower() for name, _, _ in layout]
    unknown = sorted(set(values) - set(names))
    if unknown:
        raise TypeError(f"{what}: unknown entr{'ies' if len(unknown) > 1 else 'y'} "
                        f"{', '.join(unknown)}; the entries are {', '.join(names)}")
    g = np.zeros(len(layout))
    for k, name in enumerate(names):
        if name in values:
            g[k] = float(values[name])
    return g


def collision_geometry(**values: float) -> np.ndarray:
    """A collision geometry vector (layout ``G_*`` of :mod:`siku_core.contact_law`) from named
    entries, the others 0, for a pure-Python test of a collision evaluator. The names are the
    layout's constants without ``G_``, in lower case, in the layout's units: ``area`` [m²],
    ``cx``, ``cy`` [m], ``nx``, ``ny`` [1], ``width`` [m], ``k`` [Pa], ``meff`` [kg], ``vx``,
    ``vy`` [m/s], ``area_i``, ``area_j`` [m²], ``hi``, ``hj`` [m], ``dtm`` [s/kg]; an unknown
    name raises ``TypeError`` listing them. E.g. 1 ha of overlap along +x, 100 m wide::

        g = collision_geometry(area=1e4, nx=1.0, width=100.0, k=5e8, meff=1e6)
    """
    return _named_vector(COLLISION_LAYOUT, "G_", "collision_geometry", values)


def joint_geometry(**values: float) -> np.ndarray:
    """A joint geometry vector (layout ``J_*``) from named entries, the others 0: the names
    are the layout's constants without ``J_`` in lower case (``s1x``, ``s1y``, ``s2x``,
    ``s2y``, ``ax``, ``ay``, ``bx``, ``by``, ``l0``, ``w`` [m], ``k`` [Pa], ``meff`` [kg],
    ``vax``, ``vay``, ``vbx``, ``vby`` [m/s], ``hi``, ``hj`` [m], ``ei``, ``ej`` [Pa], ``nu``
    [1], ``dt`` [s], ``dtm`` [s/kg]); see :func:`collision_geometry`."""
    return _named_vector(JOINT_LAYOUT, "J_", "joint_geometry", values)


def contact_history_row(law: Any) -> tuple[np.ndarray, ...]:
    """``(hist,)``, a zero row of the law's ``contact_history_names`` columns, to pass to its
    collision evaluator ``(g, pars, hist, out)``; ``()`` for a law without them
    (``(g, pars, out)``)."""
    n = len(law.contact_history_names)
    return (np.zeros(n),) if n else ()


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
    g[G_HI], g[G_HJ] = rng.uniform(0.1, 5.0, 2)
    # the step over the damping mass (siku_core.contact.damping): none, or dt / (phi m_d) of a step
    # of
    # 1 ms to 10 s with m_d a share 1/100 to 1 of the reduced mass
    g[G_DTM] = rng.choice([0.0, rng.uniform(1e-3, 10.0) * rng.uniform(1.0, 100.0) / g[G_MEFF]])
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
    g[J_DTM] = rng.choice([0.0, g[J_DT] * rng.uniform(1.0, 100.0) / g[J_MEFF]])
    return g




def degenerate_collision_geometries() -> list[tuple[str, np.ndarray]]:
    """Collision geometry vectors of degenerate contacts, with names."""
    base = np.zeros(G_SIZE)
    base[G_NX] = 1.0
    base[G_K] = 5e5
    base[G_MEFF] = 1e9
    base[G_AREA_I] = base[G_AREA_J] = 4e6
    base[G_HI] = base[G_HJ] = 1.0
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


def touching_squares(dlon: float) -> list[list[list[float]]]:
    """Two lon/lat boxes sharing their common meridian edge exactly."""
    dlat = math.degrees(CASE_SIZE / EARTH_RADIUS)
    lat0, lat1 = CASE_LAT, CASE_LAT + dlat
    lons = (10.0, 10.0 + dlon, 10.0 + 2 * dlon)
    return [[[lons[k], lat0], [lons[k + 1], lat0], [lons[k + 1], lat1], [lons[k], lat1]]
            for k in range(2)]
