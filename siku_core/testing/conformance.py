"""Conformance suite for forcing sources and velocity fields.

Every registered forcing source (each drag paired with every registered field) must:

1. give finite force and torque for a handful of elements, one at the North Pole, one on the
   antimeridian, at several times (:func:`check_forcing_finite`);
2. for drags (sources that take a ``field``): exert zero stress on ice at rest in a zero field
   (:func:`check_forcing_zero_field`);
3. only add: ``F`` and ``T`` are accumulators, so calling ``add`` twice doubles its contribution
   and ``q, V, w`` are left untouched (:func:`check_forcing_only_adds`);
4. where the source provides a pure-Python reference ``py_add`` (same signature as ``add``),
   agree with it (:func:`check_forcing_matches_python`);
5. unless it declares ``runs_on_ranks = False``, give a subset of the elements, set up on
   that subset as an MPI rank sets it up (two ranks, as threads), their forces bit for bit
   (:func:`check_forcing_on_ranks`).

Every registered field must return finite ``(u, v)`` of the right shape, poles and antimeridian
included (:func:`check_field_finite`).

Use the functions directly, or subclass the test class in your own test suite:

.. code-block:: python

    from siku_core.testing import conformance

    class TestMyForcing(conformance.TestForcingSourceConformance):
        sources = ("tidal_current",)          # default: every registered source
        source_params = {"tidal_current": {"amplitude": 0.3}}

(import the module rather than the class, or pytest also collects the unrestricted base class
under its own name). Components whose parameters have no default are skipped unless they are
given in ``source_params`` / ``field_params`` (keyed by component name).
"""
from __future__ import annotations

import math
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from dataclasses import field as _dc_field
from typing import Any

import numpy as np

from ..interfaces import Field, ForcingSource
from ..params import validate_params
from ..plugins import Registry, get_registry
from .scenes import make_scene

#: elements every check runs on: ``(lon, lat)`` centres [deg] with velocities [m/s] and spins
#: [rad/s]; the first sits on the North Pole, the second on the antimeridian at the equator
CONFORMANCE_ELEMENTS: tuple[dict[str, Any], ...] = (
    {"center": (0.0, 90.0), "velocity": (0.3, -0.2), "spin": 2e-5},
    {"center": (180.0, 0.0), "velocity": (-0.1, 0.25), "spin": -1e-5},
    {"center": (-180.0, 70.0), "velocity": (0.05, 0.05)},
    {"center": (-150.0, 75.0), "velocity": (0.2, 0.0), "spin": 5e-6},
    {"center": (30.0, -60.0), "velocity": (-0.2, -0.1)},
    {"center": (0.0, -89.5), "velocity": (0.0, 0.1), "spin": -3e-5},
)

#: times at which forces are evaluated [s from the start]
CONFORMANCE_TIMES: tuple[float, ...] = (0.0, 1800.0, 6.5 * 3600.0, 3 * 86400.0)


@dataclass(frozen=True)
class ForcingCase:
    """One forcing source (with one field, for drags) and the parameters to build it with."""

    source: str
    field: str | None = None
    params: Mapping[str, Any] = _dc_field(default_factory=dict)
    field_params: Mapping[str, Any] = _dc_field(default_factory=dict)
    uses_field: bool = False
    has_py_add: bool = False
    #: required parameters (no default) that were not given: the case cannot be built
    missing: tuple[str, ...] = ()

    @property
    def id(self) -> str:
        return self.source if self.field is None else f"{self.source}[{self.field}]"

    def table(self) -> dict[str, Any]:
        """The ``[[forcing]]`` table of this case."""
        t: dict[str, Any] = {"source": self.source}
        if self.params:
            t["params"] = dict(self.params)
        if self.field is not None:
            t["field"] = {"type": self.field, "params": dict(self.field_params)}
        return t


def _missing(cls: type, given: Mapping[str, Any], prefix: str = "") -> tuple[str, ...]:
    out = tuple(
        f"{prefix}{k}" for k, p in cls.params.items() if p.default is None and k not in given
    )
    # scene tables the component reads besides its parameters (the exchange grid of a coupling)
    out += tuple(f"{prefix}[{t}] table" for t in cls.scene_tables)
    # a component may need one of several parameter groups (a gridded field: its data files)
    groups = cls.required_one_of
    if groups and not any(all(k in given for k in g) for g in groups):
        out += (prefix + " or ".join(" and ".join(g) for g in groups),)
    return out


def forcing_cases(
    registry: Registry | None = None,
    sources: Iterable[str] | None = None,
    fields: Iterable[str] | None = None,
    source_params: Mapping[str, Mapping[str, Any]] | None = None,
    field_params: Mapping[str, Mapping[str, Any]] | None = None,
) -> list[ForcingCase]:
    """Cases for every registered source (or those named), drags paired with every field.

    A drag whose field is optional (``field_required = False``) also gets a case without one.
    """
    reg = registry or get_registry()
    source_params = source_params or {}
    field_params = field_params or {}
    names = reg.names("forcing") if sources is None else list(sources)
    field_names = reg.names("field") if fields is None else list(fields)
    cases = []
    for name in names:
        cls = reg.get("forcing", name)
        sp = dict(source_params.get(name, {}))
        common = {"source": name, "params": sp, "uses_field": bool(cls.uses_field),
                  "has_py_add": callable(cls.py_add)}
        if not cls.uses_field:
            cases.append(ForcingCase(**common, missing=_missing(cls, sp)))
            continue
        if not cls.field_required:
            cases.append(ForcingCase(**common, missing=_missing(cls, sp)))
        for fname in field_names:
            fcls = reg.get("field", fname)
            if not cls.accepts_field(fcls):
                continue
            fp = dict(field_params.get(fname, {}))
            miss = _missing(cls, sp) + _missing(fcls, fp, f"{fname}.")
            cases.append(ForcingCase(**common, field=fname, field_params=fp, missing=miss))
    return cases


def conformance_scene_kwargs() -> dict[str, Any]:
    """Keyword arguments of :func:`~siku_core.testing.make_scene` for the conformance elements."""
    return {"elements": CONFORMANCE_ELEMENTS, "dt": 1.0, "duration": 10.0, "size": 20e3,
            "title": "siku conformance"}


def build_forcing(
    case: ForcingCase, registry: Registry | None = None
) -> tuple[Any, ForcingSource]:
    """A :class:`~siku_core.run.simulation.Simulation` (no output) on the conformance elements with
    the case's source as its only forcing, and that source (set up)."""
    from ..run.simulation import Simulation

    if case.missing:
        raise ValueError(f"{case.id}: give values for the required parameters {case.missing}")
    scene = make_scene(forcing=[case.table()], label=f"<conformance {case.id}>",
                       run={"allow_unstable_dt": True}, **conformance_scene_kwargs())
    with warnings.catch_warnings():  # no steps are taken: the time step does not matter
        warnings.filterwarnings("ignore", message=".*allow_unstable_dt = true")
        sim = Simulation(scene, out=False, progress=False, registry=registry)
    return sim, sim.forcing[0]


def _where(sim: Any, i: int) -> str:
    from ..geometry.quat import latlon_of

    lat, lon = latlon_of(sim.state.q)
    return f"element {i} at lat {math.degrees(lat[i]):.4g}, lon {math.degrees(lon[i]):.4g}"


def _add(src: ForcingSource, sim: Any, t: float, F=None, T=None, state=None):
    st = sim.state
    q, V, w = state if state is not None else (st.q.copy(), st.V.copy(), st.w.copy())
    F = np.zeros((st.n, 2)) if F is None else F
    T = np.zeros(st.n) if T is None else T
    src.add(t, q, V, w, F, T)
    return F, T


def check_forcing_finite(
    case: ForcingCase, registry: Registry | None = None,
    times: Iterable[float] = CONFORMANCE_TIMES,
) -> None:
    """Force and torque are finite for every conformance element (poles, antimeridian)."""
    sim, src = build_forcing(case, registry)
    for t in times:
        F, T = _add(src, sim, float(t))
        for name, arr in (("force", F), ("torque", T)):
            bad = np.flatnonzero(~np.isfinite(arr.reshape(sim.state.n, -1)).all(axis=1))
            assert bad.size == 0, (
                f"{case.id}: non-finite {name} {arr[bad[0]]} on {_where(sim, int(bad[0]))} "
                f"at t = {t:g} s"
            )


class ZeroField(Field):
    """A field that is zero everywhere (used by the zero-stress check; not registered)."""

    name = "zero"

    def sample(self, t, lat, lon):
        n = np.shape(lat)[0]
        return np.zeros(n), np.zeros(n)


def check_forcing_zero_field(
    case: ForcingCase, registry: Registry | None = None, atol: float = 1e-12
) -> None:
    """A drag exerts no force or torque [N, N m] on ice at rest in a zero field."""
    sim, src = build_forcing(case, registry)
    if not src.uses_field:
        raise ValueError(f"{case.id}: not a drag (takes no field)")
    zero = src.zero_field() or ZeroField({})
    zero.setup(sim.context)
    src.field = zero  # type: ignore[attr-defined]
    st = sim.state
    rest = (st.q.copy(), np.zeros_like(st.V), np.zeros_like(st.w))
    for t in CONFORMANCE_TIMES:
        F, T = _add(src, sim, t, state=rest)
        for name, arr in (("force", F), ("torque", T)):
            i = int(np.argmax(np.abs(arr.reshape(st.n, -1)).max(axis=1)))
            assert np.allclose(arr, 0.0, rtol=0.0, atol=atol), (
                f"{case.id}: zero field and ice at rest, yet {name} {arr[i]} on {_where(sim, i)} "
                f"at t = {t:g} s"
            )


def check_forcing_only_adds(
    case: ForcingCase, registry: Registry | None = None, rtol: float = 1e-10, seed: int = 1
) -> None:
    """``add`` adds to ``F, T`` (twice doubles it) and never writes ``q, V, w``."""
    sim, src = build_forcing(case, registry)
    st = sim.state
    t = CONFORMANCE_TIMES[2]
    dF, dT = _add(src, sim, t)
    scale_F = max(float(np.abs(dF).max()), 1e-300)
    scale_T = max(float(np.abs(dT).max()), 1e-300)
    rng = np.random.default_rng(seed)
    F0 = rng.normal(size=(st.n, 2)) * scale_F
    T0 = rng.normal(size=st.n) * scale_T
    F, T = F0.copy(), T0.copy()
    q, V, w = st.q.copy(), st.V.copy(), st.w.copy()
    before = (q.copy(), V.copy(), w.copy())
    for k in (1, 2):
        src.add(t, q, V, w, F, T)
        for name, got, want, scale in (("F", F - F0, k * dF, scale_F),
                                       ("T", T - T0, k * dT, scale_T)):
            assert np.allclose(got, want, rtol=rtol, atol=rtol * scale), (
                f"{case.id}: after {k} call(s) of add(), {name} changed by {got.tolist()} instead "
                f"of {k} × {(want / k).tolist()}: add() must add to {name}, not overwrite it"
            )
    for name, a, b in zip(("q", "V", "w"), (q, V, w), before, strict=True):
        assert np.array_equal(a, b), f"{case.id}: add() changed the state array {name}"


def check_forcing_matches_python(
    case: ForcingCase, registry: Registry | None = None, rtol: float = 1e-10
) -> None:
    """The compiled ``add`` agrees with the source's pure-Python reference ``py_add``."""
    sim, src = build_forcing(case, registry)
    ref = src.py_add
    if ref is None:
        raise ValueError(f"{case.id}: the source has no py_add reference")
    st = sim.state
    for t in CONFORMANCE_TIMES:
        F, T = _add(src, sim, t)
        Fr, Tr = np.zeros_like(F), np.zeros_like(T)
        ref(t, st.q.copy(), st.V.copy(), st.w.copy(), Fr, Tr)
        for name, a, b in (("F", F, Fr), ("T", T, Tr)):
            scale = max(float(np.abs(b).max()), 1e-300)
            bad = ~np.isclose(a, b, rtol=rtol, atol=rtol * scale).reshape(st.n, -1).all(axis=1)
            i = int(np.argmax(bad))
            assert not bad.any(), (
                f"{case.id}: compiled {name} {a[i]} != pure-Python {b[i]} on {_where(sim, i)} "
                f"at t = {t:g} s"
            )


def check_forcing_on_ranks(case: ForcingCase, registry: Registry | None = None) -> None:
    """A source that runs on ranks (``runs_on_ranks``) gives every element, on two ranks
    that each hold every other element and set the source up over them
    (``siku_core.ranks.local``), the force and torque it gives it among all, bit for bit. The
    ranks are threads of this process taking turns
    (:mod:`siku_core.testing.rank_threads`): a source whose field evolves from every
    element gathers them through the rank's link, as on the ranks of a run."""
    from ..ranks.driver import refusals
    from ..ranks.local import RankLink, local_engine
    from .rank_threads import run_ranks

    sim, src = build_forcing(case, registry)
    if refusals(sim, 2):  # refused on ranks before the first step: nothing to compare
        return
    n = sim.state.n
    want = [_add(src, sim, t) for t in CONFORMANCE_TIMES]
    none = np.zeros(0, dtype=np.int64)

    def rank(ids: np.ndarray) -> Any:
        run = build_forcing(case, registry)[0]  # every rank builds the run

        def steps(comm: Any) -> list[tuple[np.ndarray, np.ndarray]]:
            link = RankLink(run, ids, np.arange(len(ids)), comm, [none, none], [none, none])
            loc, _ = local_engine(run, ids, none, link)
            part, ls = loc.forcing[0], loc.state
            return [_add(part, loc, t, state=(ls.q.copy(), ls.V.copy(), ls.w.copy()))
                    for t in CONFORMANCE_TIMES]
        return steps

    parts = [np.arange(r, n, 2) for r in range(2)]
    got = run_ranks([rank(ids) for ids in parts])
    for ids, forces in zip(parts, got):
        for t, (F, T), (Fs, Ts) in zip(CONFORMANCE_TIMES, want, forces):
            for name, a, b in (("F", F[ids], Fs), ("T", T[ids], Ts)):
                bad = ~(a == b).reshape(len(ids), -1).all(axis=1)
                i = int(np.argmax(bad))
                assert not bad.any(), (
                    f"{case.id}: {name} {b[i]} on {_where(sim, int(ids[i]))} when set up over "
                    f"a subset of the elements, {a[i]} among all, at t = {t:g} s: a source "
                    "that runs on ranks must act on each element by itself (or set "
                    "runs_on_ranks = False)")


def field_cases(
    registry: Registry | None = None, fields: Iterable[str] | None = None,
    field_params: Mapping[str, Mapping[str, Any]] | None = None,
) -> list[tuple[str, dict[str, Any], tuple[str, ...]]]:
    """``(name, params, missing required parameters)`` for every registered field."""
    reg = registry or get_registry()
    field_params = field_params or {}
    out = []
    for name in reg.names("field") if fields is None else list(fields):
        fp = dict(field_params.get(name, {}))
        out.append((name, fp, _missing(reg.get("field", name), fp)))
    return out


def check_field_finite(
    name: str, params: Mapping[str, Any] | None = None, registry: Registry | None = None
) -> None:
    """A field's ``sample`` gives finite ``(u, v)`` [m/s], one value per point, at the poles,
    on the antimeridian and elsewhere, at several times."""
    from ..run.simulation import Simulation

    reg = registry or get_registry()
    cls = reg.get("field", name)
    fld = cls(validate_params(name, cls.params, params or {}, f"<conformance field {name}>"))
    sim = Simulation(make_scene(**conformance_scene_kwargs()), out=False, progress=False,
                     registry=registry)
    fld.setup(sim.context)
    lat = np.radians([90.0, -90.0, 0.0, 0.0, 70.0, -60.0, 75.0, 89.999])
    lon = np.radians([0.0, 0.0, 180.0, -180.0, 179.999, 30.0, -150.0, 45.0])
    try:
        for t in CONFORMANCE_TIMES:
            u, v = fld.sample(t, lat, lon)
            u, v = np.asarray(u), np.asarray(v)
            assert u.shape == lat.shape and v.shape == lat.shape, (
                f"field {name}: sample() returned shapes {u.shape}, {v.shape} for {lat.shape} "
                "points"
            )
            ok = np.isfinite(u) & np.isfinite(v)
            i = int(np.argmin(ok))
            assert ok.all(), (
                f"field {name}: non-finite velocity ({u[i]}, {v[i]}) at lat "
                f"{np.degrees(lat[i]):g}, lon {np.degrees(lon[i]):g}, t = {t:g} s"
            )
    finally:
        fld.close()


class TestForcingSourceConformance:
    """The conformance suite as tests, parametrised over registered sources and fields.

    Subclass and set ``sources`` / ``fields`` (names; ``None``: every registered one), and
    ``source_params`` / ``field_params`` (``{name: {param: value}}``) for components whose
    parameters have no default.
    """

    sources: tuple[str, ...] | None = None
    fields: tuple[str, ...] | None = None
    source_params: Mapping[str, Mapping[str, Any]] = {}
    field_params: Mapping[str, Mapping[str, Any]] = {}

    def pytest_generate_tests(self, metafunc: Any) -> None:
        import pytest

        fn = metafunc.function.__name__
        if "forcing_case" in metafunc.fixturenames:
            values = []
            for c in forcing_cases(None, self.sources, self.fields, self.source_params,
                                   self.field_params):
                if fn == "test_zero_field_gives_zero_stress" and not c.uses_field:
                    continue
                marks = []
                if c.missing:
                    marks.append(pytest.mark.skip(
                        reason=f"{c.id}: no value for required parameter(s) "
                        f"{', '.join(c.missing)}; set source_params / field_params"))
                elif fn == "test_compiled_matches_python_reference" and not c.has_py_add:
                    marks.append(pytest.mark.skip(reason=f"{c.source} has no py_add reference"))
                values.append(pytest.param(c, id=c.id, marks=marks))
            metafunc.parametrize("forcing_case", values)
        if "field_case" in metafunc.fixturenames:
            values = []
            for name, fp, missing in field_cases(None, self.fields, self.field_params):
                marks = [pytest.mark.skip(reason=f"field {name}: no value for {missing}")] \
                    if missing else []
                values.append(pytest.param((name, fp), id=name, marks=marks))
            metafunc.parametrize("field_case", values)

    def test_force_finite_at_poles_and_antimeridian(self, forcing_case: ForcingCase) -> None:
        check_forcing_finite(forcing_case)

    def test_zero_field_gives_zero_stress(self, forcing_case: ForcingCase) -> None:
        check_forcing_zero_field(forcing_case)

    def test_add_only_adds(self, forcing_case: ForcingCase) -> None:
        check_forcing_only_adds(forcing_case)

    def test_compiled_matches_python_reference(self, forcing_case: ForcingCase) -> None:
        check_forcing_matches_python(forcing_case)

    def test_same_on_a_subset_of_elements(self, forcing_case: ForcingCase) -> None:
        check_forcing_on_ranks(forcing_case)

    def test_field_finite_at_poles_and_antimeridian(self, field_case: tuple) -> None:
        check_field_finite(field_case[0], field_case[1])


__all__ = [
    "CONFORMANCE_ELEMENTS", "CONFORMANCE_TIMES", "ForcingCase", "TestForcingSourceConformance",
    "ZeroField", "build_forcing", "check_field_finite", "check_forcing_finite",
    "check_forcing_matches_python", "check_forcing_on_ranks", "check_forcing_only_adds",
    "check_forcing_zero_field",
    "field_cases", "forcing_cases",
]
