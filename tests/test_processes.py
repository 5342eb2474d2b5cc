"""Processes that change the ice (siku_core.ice, siku_plugins.processes): Stefan growth,
ocean-flux melt, the volume budget, what follows a thickness change, refreezing, restarts,
outputs, bad input and the process conformance suite."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from siku_core.errors import PluginError, SceneError, SikuError, StabilityError
from siku_core.fields import ElementField
from siku_core.interfaces import Process
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.state import MELTED
from siku_core.testing import scene_text
from siku_core.testing.contact_cases import square_pack
from siku_core.testing.process_checks import (
    check_process,
    check_process_conservation,
    check_process_finite,
    check_process_idempotent,
    check_process_on_ranks,
    check_process_restart,
    ice_volume,
    process_registry,
)
from siku_plugins.processes import Refreeze, Ridging, Thermodynamics
from siku_plugins.processes.refreeze import refrozen_strength

K_I, L_F, T_F = 2.03, 3.34e5, -1.8


def one_floe(process: str, dt=3600.0, steps=240, thickness=0.5, every=None, extra=""):
    table = f'[[process]]\nname = "thermodynamics"\nparams = {process}\n'
    if every is not None:
        table += f"every = {every!r}\n"
    txt = scene_text([(0.0, 80.0)], dt=dt, duration=steps * dt, thickness=thickness,
                     extra=table + extra)
    return Simulation(scene_from_text(txt, "<floe>"), out=False, progress=False)


@pytest.mark.parametrize("Ts,every", [(-30.0, None), (-10.0, 6 * 3600.0), (-25.0, 86400.0)])
def test_growth_follows_stefans_law(Ts, every):
    sim = one_floe(f"{{ surface_temperature = {Ts} }}", every=every)
    h0 = sim.state.thickness[0]
    rho = sim.ice.rho[0]
    sim.run()
    exact = math.sqrt(h0**2 + 2 * K_I * (T_F - Ts) * sim.time / (rho * L_F))
    assert sim.state.thickness[0] == pytest.approx(exact, rel=1e-6)


def test_growth_under_snow_is_the_exact_two_layer_solution():
    hs, ks = 0.2, 0.31
    sim = one_floe(f"{{ surface_temperature = -30.0, snow_thickness = {hs}, "
                   f"snow_conductivity = {ks} }}")
    h0, rho = sim.state.thickness[0], sim.ice.rho[0]
    sim.run()
    h = sim.state.thickness[0]
    # h²/(2 k_i) + h h_s/k_s grows by dT t / (rho L)
    lhs = h**2 / (2 * K_I) + h * hs / ks - (h0**2 / (2 * K_I) + h0 * hs / ks)
    assert lhs == pytest.approx((T_F + 30.0) * sim.time / (rho * L_F), rel=1e-9)


def test_melt_under_an_ocean_heat_flux_is_linear_to_round_off():
    F = 40.0
    sim = one_floe(f"{{ surface_temperature = 0.0, ocean_heat_flux = {F} }}", thickness=2.0)
    rho = sim.ice.rho[0]
    sim.run(steps=100)
    expected = 2.0 - F * sim.time / (rho * L_F)
    assert sim.state.thickness[0] == pytest.approx(expected, rel=1e-13)
    rate = sim.context.fields["growth_rate"][0]
    assert rate == pytest.approx(-F / (rho * L_F), rel=1e-9)


def test_mass_inertia_and_joint_stiffness_follow_the_thickness():
    pack = [square_pack(0.0, 80.0, 3, 2, size=2000.0)]

    def build(h, process):
        extra = '[contact]\nlaw = "distributed_spring"\n'
        if process:
            extra += ('\n[[process]]\nname = "thermodynamics"\nparams = { surface_temperature '
                      '= -40.0 }\n')
        txt = scene_text([], packs=pack, dt=0.4, duration=4.0, thickness=h, extra=extra)
        return Simulation(scene_from_text(txt, "<pack>"), out=False, progress=False)

    grown = build(0.5, True)
    grown.run(steps=1)
    h = grown.state.thickness.copy()
    assert (h > 0.5).all()
    fresh = build(float(h[0]), False)
    assert np.allclose(h, h[0], rtol=0, atol=0)  # uniform growth of a uniform pack
    for name in ("m", "I"):
        np.testing.assert_allclose(getattr(grown.state, name), getattr(fresh.state, name),
                                   rtol=4e-16 * 8)
    np.testing.assert_allclose(grown.contacts.jK, fresh.contacts.jK, rtol=1e-15 * 8)
    np.testing.assert_allclose(grown.contacts.jmeff, fresh.contacts.jmeff, rtol=1e-15 * 8)


def test_joint_constants_left_to_the_joint_loop_are_the_ones_computed_at_once():
    """After thermodynamics changed every element, the joints' eq. 9 stiffness and reduced mass
    wait for the next joint loop (ContactModel.ice_changed); read before it, they are computed
    at once. Either way they are ``contact_frames.joint_constants`` of the new ice bit for bit,
    and a run that reads them after every step reaches the same state, bit for bit, as one
    that leaves them to the joint loop."""
    from siku_core.contact.contact_frames import joint_constants

    pack = [square_pack(0.0, 80.0, 4, 3, size=2000.0)]
    extra = ('[contact]\nlaw = "distributed_spring"\n\n[[process]]\nname = "thermodynamics"\n'
             'params = { surface_temperature = -40.0, ocean_heat_flux = 50.0 }\n')
    txt = scene_text([], packs=pack, dt=0.4, duration=4.0, thickness=0.5, extra=extra)

    def build():
        sim = Simulation(scene_from_text(txt, "<pack>"), out=False, progress=False)
        sim.state.thickness[:] = np.linspace(0.3, 1.2, sim.state.n)  # every joint differs
        return sim

    eager, lazy = build(), build()
    cm = eager.contacts
    eager.run(steps=1)  # (the first step checks the stable step: it reads them)
    for _ in range(5):
        eager.run(steps=1)
        assert cm._joints_stale  # every element changed: left to the joint loop
        st = eager.state
        minv = np.where(st.flags == MELTED, 1.0 / st.m, cm.minv)
        K, meff = joint_constants(st.thickness, cm.E, minv, cm.ji, cm.jj, *cm.arms)
        np.testing.assert_array_equal(cm.jK, K)  # read now: computed at once
        np.testing.assert_array_equal(cm.jmeff, meff)
        assert not cm._joints_stale
    lazy.run(steps=6)
    assert lazy.contacts._joints_stale
    for name in ("q", "V", "w", "thickness", "m"):
        np.testing.assert_array_equal(getattr(lazy.state, name), getattr(eager.state, name))
    np.testing.assert_array_equal(lazy.contacts.jK, cm.jK)
    np.testing.assert_array_equal(lazy.contacts.jmeff, cm.jmeff)
    assert np.ptp(cm.jK) > 0.1 * cm.jK.max()


def test_an_element_that_melts_away_leaves_the_contact_phase_and_the_budget():
    txt = scene_text([], packs=[square_pack(0.0, 80.0, 2, 1, size=2000.0)], dt=0.4,
                     duration=40.0, thickness=0.3, extra=(
                         '[contact]\nlaw = "distributed_spring"\n\n[[process]]\nname = '
                         '"thermodynamics"\nparams = { surface_temperature = 0.0, '
                         'ocean_heat_flux = 2e6, min_thickness = 0.1 }\n'))
    sim = Simulation(scene_from_text(txt, "<melt>"), out=False, progress=False)
    v0 = ice_volume(sim)
    sim.run()
    assert (sim.state.flags == MELTED).all()
    assert not sim.contacts.intact.any()
    assert set(sim.contacts.break_mode.tolist()) == {7}  # BreakMode.MELT
    assert ice_volume(sim) == 0.0
    assert sim.processes[0].budget(sim.context) == pytest.approx(-v0, rel=1e-12)


def test_volume_budget_with_growth_and_melt_to_1e10():
    # thin and thick ice side by side under a strong ocean heat flux: the thin melts away
    txt = scene_text([], packs=[square_pack(0.0, 80.0, 3, 2, size=2000.0, thickness=0.12),
                                square_pack(0.5, 80.0, 3, 2, size=2000.0, thickness=1.5)],
                     dt=0.4, duration=400.0, extra=(
                         '[contact]\nlaw = "distributed_spring"\n\n[[process]]\nname = '
                         '"thermodynamics"\nparams = { surface_temperature = -20.0, '
                         'ocean_heat_flux = 3e5, min_thickness = 0.1 }\nevery = 4.0\n'))
    sim = Simulation(scene_from_text(txt, "<budget>"), out=False, progress=False)
    v0 = ice_volume(sim)
    sim.run()
    melted = sim.state.flags == MELTED
    assert melted.sum() == 6 and not melted[6:].any()
    budget = sim.processes[0].budget(sim.context)
    assert (ice_volume(sim) - v0) == pytest.approx(budget, rel=1e-10)


def test_a_melt_that_makes_dt_unstable_stops_the_run_in_one_line(tmp_path):
    # water drag is stable for dt < rho_i h / (rho_w C_w |dU|): 0.5 m at dU = 2 m/s: 41 s
    scene = tmp_path / "melt.toml"
    scene.write_text(scene_text(
        [(0.0, 80.0)], dt=30.0, duration=86400.0, thickness=0.5, extra=(
            '[[forcing]]\nsource = "water_drag"\nparams = { max_relative_speed = 2.0 }\n'
            'field = { type = "uniform", params = { u = 0.1 } }\n\n'
            '[[process]]\nname = "thermodynamics"\nparams = { surface_temperature = 0.0, '
            'ocean_heat_flux = 1000.0, min_thickness = 0.01 }\nevery = "1 h"\n'
            '\n[run]\ndt_safety = 1.0\n')))
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", str(scene), "--out",
                        str(tmp_path / "o.h5")], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("siku: error")]
    assert len(lines) == 1 and "Traceback" not in r.stderr
    assert "after process 'thermodynamics' changed the ice" in lines[0]
    assert "element 0" in lines[0] and "safe step" in lines[0]
    import h5py  # the snapshots before the stop are kept and open

    with h5py.File(tmp_path / "o.h5", "r") as f:
        assert f["states/step"].shape[0] >= 1


def test_a_scene_without_processes_allocates_nothing():
    txt = scene_text([(0.0, 80.0)], dt=60.0, duration=600.0)
    sim = Simulation(scene_from_text(txt, "<plain>"), out=False, progress=False)
    assert not sim.ice.active and sim.ice.values == {}
    assert "elements" not in sim.history_arrays()
    assert set(sim.element_fields()) == {"speed"}


# ---------------------------------------------------------------------------- refreezing
def pair_scene(freeze_time=20.0, gap=0.5, steps=200, strength=1e4, strength_time=40.0):
    # two jointed 2 km elements, at rest
    pack = square_pack(0.0, 80.0, 2, 1, size=2000.0)
    txt = scene_text([], packs=[pack], dt=0.4, duration=steps * 0.4, thickness=1.0, extra=(
        '[contact]\nlaw = "distributed_spring"\nparams = { tensile_strain = 1.0 }\n\n'
        '[[process]]\nname = "refreeze"\n'
        f'params = {{ freeze_time = {freeze_time}, gap = {gap}, strength = {strength}, '
        f'strength_time = {strength_time} }}\n'))
    return Simulation(scene_from_text(txt, "<pair>"), out=False, progress=False)


def test_a_broken_joint_held_closed_refreezes_after_the_set_time_to_one_step():
    sim = pair_scene(freeze_time=20.0)
    cm = sim.contacts
    sim.run(steps=5)
    cm.break_joints(np.arange(cm.n_joints), 5, sim.time)  # BreakMode.EXTERNAL
    t_break = sim.time
    refrozen = None
    for _ in range(80):
        sim.step()
        if cm.intact.all():
            refrozen = sim.time
            break
    # the first check after the break finds it closed (at t_break + dt): 20 s later it holds
    assert refrozen == pytest.approx(t_break + sim.dt + 20.0, abs=0.5 * sim.dt)
    assert np.isnan(cm.break_time).all() and (cm.break_mode == 0).all()


def test_a_broken_joint_held_open_never_refreezes():
    sim = pair_scene(freeze_time=4.0, gap=0.5)
    cm = sim.contacts
    cm.break_joints(np.arange(cm.n_joints), 5, 0.0)
    # move the right element 5 m east (a turn about the polar axis at 80 N): its side of
    # the joint is 5 m from the left's
    from siku_core.geometry.quat import qmul
    ang = 5.0 / (sim.radius * math.cos(math.radians(80.0)))
    axis = np.array([0.0, 0.0, 1.0])
    rot = np.array([math.cos(ang / 2), *(math.sin(ang / 2) * axis)])
    sim.state.q[1] = qmul(rot, sim.state.q[1])
    assert cm.joint_gaps(np.arange(cm.n_joints)).min() > 4.0
    for _ in range(100):
        sim.step()
    assert not cm.intact.any()


def test_a_refrozen_joint_breaks_when_its_tension_exceeds_the_stated_strength():
    sim = pair_scene(freeze_time=0.0, strength=2e4, strength_time=400.0, steps=2000)
    cm = sim.contacts
    cm.break_joints(np.arange(cm.n_joints), 5, 0.0)
    sim.step()  # closed at once: refreezes at the first check
    assert cm.intact.all()
    proc = sim.processes[0]
    t_frozen = float(proc.refrozen_at[0])
    # pull the elements apart with opposite velocities (the joint opens steadily)
    from siku_core.geometry.quat import east_north_local
    for i, u in ((0, -0.02), (1, 0.02)):  # east [m/s]
        ex, ey, _, _ = east_north_local(sim.state.q[i])
        sim.state.V[i] = u * ex, u * ey
    broke_at = None
    for _ in range(1500):
        tension_before = float(cm.joint_tension(np.array([0]))[0]) if cm.intact[0] else None
        sim.step()
        if not cm.intact[0]:
            broke_at = sim.time
            break
    assert broke_at is not None
    assert cm.break_mode[0] == 2  # tension
    limit = refrozen_strength(broke_at - t_frozen, 2e4, 400.0)
    # it held while the traction was below the law, and broke when it was above it
    assert float(cm.joint_tension(np.array([0]))[0]) > limit
    assert tension_before <= refrozen_strength(broke_at - sim.dt - t_frozen, 2e4, 400.0)
    assert broke_at - t_frozen < 400.0  # before full strength: the refrozen law, not the law's


# ---------------------------------------------------------------------------- conformance
@pytest.mark.parametrize("cls,params,law", [
    (Thermodynamics, {"surface_temperature": -30.0, "ocean_heat_flux": 5.0}, None),
    (Refreeze, {"freeze_time": 2.0}, None),
    (Ridging, {}, "ridging"),
])
def test_built_in_processes_pass_the_conformance_suite(cls, params, law, tmp_path):
    check_process(cls, params, tmp_path, **({"law": law} if law else {}))


class _Growth(Process):
    """A growth process for the planted faults: every element grows at ``rate``."""

    name = "test_growth"
    owned_fields = (ElementField("test_grown", "m3", "volume grown", grid="sum"),)

    def apply(self, ctx, dt):
        st = ctx.state
        dh = 1e-4 * dt
        st.thickness += dh
        ctx.fields["test_grown"] += st.area * dh

    def budget(self, ctx):
        return math.fsum(ctx.fields["test_grown"])


class _NaNThickness(_Growth):
    name = "test_nan"

    def apply(self, ctx, dt):
        ctx.state.thickness[0] = np.nan


class _WrongBudget(_Growth):
    name = "test_wrong_budget"

    def budget(self, ctx):
        return 0.5 * super().budget(ctx)


class _GrowsOnNothing(_Growth):
    name = "test_dt_zero"

    def apply(self, ctx, dt):
        super().apply(ctx, dt + 1.0)


class _Forgetful(_Growth):
    """Keeps a counter it does not declare as history: restarts differ."""

    name = "test_forgetful"

    def setup(self, ctx):
        self.calls = 0

    def apply(self, ctx, dt):
        self.calls += 1
        super().apply(ctx, dt * self.calls)


class _GrowsWithTheMean(_Growth):
    """Declares itself element-local but grows every element by the mean thickness of all:
    on a rank's subset of the elements it grows them differently."""

    name = "test_mean"
    runs_on_ranks = True

    def apply(self, ctx, dt):
        st = ctx.state
        dh = 1e-4 * dt * st.thickness.mean() * (1.0 + np.arange(st.n) % 3)
        st.thickness += dh
        ctx.fields["test_grown"] += st.area * dh


def test_the_ranks_check_passes_local_growth_and_catches_one_reading_all():
    """An element-local process passes the ranks check; one whose change of an element
    depends on the others fails it, naming the element."""
    class Local(_Growth):
        name = "test_local"
        runs_on_ranks = True

    check_process_on_ranks(Local)
    with pytest.raises(AssertionError, match="must change each element by itself"):
        check_process_on_ranks(_GrowsWithTheMean)


class _GrowsByItsJoints(_Growth):
    """Reads the contacts: each element grows by the number of its intact joints, and keeps
    per joint how often it saw it intact (history the ranks split by joint)."""

    name = "test_by_joints"
    runs_on_ranks = True
    reads_contacts = True
    rank_history = {"seen": "joint"}

    def setup(self, ctx):
        self.seen = np.zeros(ctx.contacts.joint_slots)

    def apply(self, ctx, dt):
        cm, st = ctx.contacts, ctx.state
        k = np.flatnonzero(cm.intact)
        self.seen[k] += 1.0
        per = np.bincount(cm.ji[k], minlength=st.n) + np.bincount(cm.jj[k], minlength=st.n)
        dh = 1e-4 * dt * (1.0 + per)
        st.thickness += dh
        ctx.fields["test_grown"] += st.area * dh

    def history(self):
        return {"seen": self.seen.copy()}

    def set_history(self, arrays):
        self.seen[:] = arrays["seen"]


class _GrowsByTheCount(_GrowsByItsJoints):
    """Reads the contacts but grows every element by the count of all intact joints: on a
    rank, which holds some of them, it grows its elements differently."""

    name = "test_by_count"

    def apply(self, ctx, dt):
        super().apply(ctx, dt)
        ctx.state.thickness += 1e-6 * ctx.contacts.n_intact


def test_the_ranks_check_of_a_process_reading_the_contacts():
    """A process that reads an element's own joints passes the ranks check (its element's
    joints are all on the rank that owns it; its per-joint history is split by joint); one
    that reads all the joints fails it, naming the element; the built-in ones pass."""
    check_process_on_ranks(_GrowsByItsJoints)
    with pytest.raises(AssertionError, match="must change an element from its own contacts"):
        check_process_on_ranks(_GrowsByTheCount)


def test_a_correct_growth_process_passes_and_planted_faults_fail(tmp_path):
    check_process(_Growth, None, tmp_path / "ok")
    with pytest.raises((AssertionError, SikuError)):
        check_process_finite(_NaNThickness)
    with pytest.raises(AssertionError, match="budget"):
        check_process_conservation(_WrongBudget)
    with pytest.raises(AssertionError, match="dt = 0"):
        check_process_idempotent(_GrowsOnNothing)
    (tmp_path / "f").mkdir()
    with pytest.raises(AssertionError, match="restart"):
        check_process_restart(_Forgetful, None, tmp_path / "f")


# ---------------------------------------------------------------------------- bad input
def run_cli(tmp_path, text, *args):
    scene = tmp_path / "s.toml"
    scene.write_text(text)
    return subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", str(scene),
                           "--out", str(tmp_path / "o.h5"), *args],
                          capture_output=True, text=True, cwd=tmp_path)


def _one_line(r, *words):
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    lines = [ln for ln in r.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1, r.stderr
    for w in words:
        assert w in lines[0], lines[0]


def test_unknown_process_and_a_field_declared_twice_are_refused(tmp_path):
    base = scene_text([(0.0, 80.0)], dt=60.0, duration=600.0)
    _one_line(run_cli(tmp_path, base + '\n[[process]]\nname = "growht"\n'),
              "growht", "thermodynamics")
    twice = '\n[[process]]\nname = "thermodynamics"\n' * 2
    _one_line(run_cli(tmp_path, base + twice), "grown_volume", "declared by both")


def test_negative_thickness_is_refused(tmp_path):
    base = scene_text([(0.0, 80.0)], dt=60.0, duration=600.0, thickness=-1.0)
    assert "thickness = -1.0" in base
    _one_line(run_cli(tmp_path, base), "thickness")


@pytest.mark.parametrize("file_units,declared,ok", [
    ("K", "degC", False), ("degC", "K", False), ("K", "", True), ("degC", "degC", True)])
def test_a_temperature_file_in_the_wrong_units_is_refused(tmp_path, file_units, declared, ok):
    import xarray as xr

    lat = np.array([70.0, 75.0, 80.0, 85.0])
    lon = np.array([-10.0, 0.0, 10.0])
    value = 243.15 if file_units == "K" else -30.0
    air = xr.DataArray(np.full((4, 3), value), dims=("lat", "lon"),
                       coords={"lat": ("lat", lat, {"units": "degrees_north"}),
                               "lon": ("lon", lon, {"units": "degrees_east"})},
                       attrs={"units": file_units})
    xr.Dataset({"air": air}).to_netcdf(tmp_path / "air.nc")
    params = '{ temperature_file = "air.nc"' + (
        f', temperature_units = "{declared}"' if declared else "") + " }"
    text = scene_text([(0.0, 80.0)], dt=3600.0, duration=86400.0, thickness=0.5,
                      extra=f'[[process]]\nname = "thermodynamics"\nparams = {params}\n')
    r = run_cli(tmp_path, text)
    if not ok:
        _one_line(r, "air.nc", file_units, declared)
        return
    assert r.returncode == 0, r.stderr
    import xarray as xr2

    ds = xr2.open_dataset(tmp_path / "o.h5", engine="siku")
    h = float(ds.thickness[-1, 0])
    rho = 910.0  # the default material's density [kg/m3]
    exact = math.sqrt(0.25 + 2 * K_I * (T_F + 30.0) * 86400.0 / (rho * L_F))
    assert h == pytest.approx(exact, rel=1e-6)


def test_a_bad_field_declaration_is_one_line():
    class Bad(_Growth):
        name = "test_bad_field"
        owned_fields = (ElementField("thickness", "m", "clash"),)

    with pytest.raises(PluginError, match="siku's own"):
        Simulation(scene_from_text(scene_text([(0.0, 80.0)], dt=60.0, duration=600.0) +
                                   '\n[[process]]\nname = "test_bad_field"\n', "<bad>"),
                   out=False, progress=False, registry=process_registry(Bad))


def test_every_must_be_a_whole_number_of_steps():
    txt = scene_text([(0.0, 80.0)], dt=60.0, duration=600.0) + (
        '\n[[process]]\nname = "thermodynamics"\nevery = 61.7\n')
    with pytest.raises(SceneError, match="whole number of steps"):
        Simulation(scene_from_text(txt, "<every>"), out=False, progress=False)


def test_stability_error_is_a_siku_error():
    assert issubclass(StabilityError, SikuError)


def test_the_growth_process_of_the_plugin_guide_passes_the_conformance_suite(tmp_path):
    """The how-to page's code, run as written: its process passes the suite."""
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[1] / "docs" / "howto" / "processes.md").read_text()
    blocks = re.findall(r"```python\n(.*?)```", page, flags=re.S)
    assert len(blocks) == 4  # the class, its hook, a scene that names it, the suite
    ns: dict = {}
    exec(compile(blocks[0], "processes.md[0]", "exec"), ns)
    exec(compile(blocks[1], "processes.md[1]", "exec"), ns)
    assert ns["siku_register_processes"]() == [ns["ConstantGrowth"]]
    exec(compile(blocks[3], "processes.md[3]", "exec"), ns)  # runs check_process
    # and a planted fault in the same class fails it
    grow = ns["ConstantGrowth"]

    class Liar(grow):
        name = "constant_growth_liar"

        def budget(self, ctx):
            return 0.0

    with pytest.raises(AssertionError, match="budget"):
        check_process_conservation(Liar, {"rate": 1e-4})


# ---------------------------------------------------------------------------- ridging
def _clip_area(P, Q):
    """Area [m²] of the intersection of convex polygons ``P`` and ``Q`` (counter-clockwise
    ``(k, 2)`` arrays), by Sutherland–Hodgman and the shoelace formula."""
    out = [tuple(p) for p in P]
    for a, b in zip(Q, np.roll(Q, -1, axis=0)):
        src, out = out, []
        if not src:
            break

        def inside(p):
            return (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0]) >= 0.0

        for p, q in zip(src, src[1:] + src[:1]):
            if inside(q):
                if not inside(p):
                    out.append(_cross(p, q, a, b))
                out.append(q)
            elif inside(p):
                out.append(_cross(p, q, a, b))
    if len(out) < 3:
        return 0.0
    x, y = np.array(out).T
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def _cross(p, q, a, b):
    d1 = np.subtract(q, p)
    d2 = np.subtract(b, a)
    t = ((a[0] - p[0]) * d2[1] - (a[1] - p[1]) * d2[0]) / (d1[0] * d2[1] - d1[1] * d2[0])
    return (p[0] + t * d1[0], p[1] + t * d1[1])


def _overlap_in_plane(sim, i, j):
    """Overlap area of elements ``i`` and ``j`` [m²]: ``j``'s vertices put in ``i``'s tangent
    plane (gnomonic, as the model's geometry is) and clipped here, independently of the
    engine's clip."""
    from siku_core.geometry.quat import from_tangent, to_tangent

    st, R = sim.state, sim.radius
    pj = np.array([to_tangent(st.q[i], from_tangent(st.q[j], x, y, R), R)
                   for x, y in st.polygon(j)])
    return _clip_area(st.polygon(i), pj)


def ridging_scene(steps=400, diamond=False):
    """A static wall (5 m), a free carrier (2 m) pressed on it, and thin ice (0.5 m) driven
    west into the carrier at 5 cm/s: a square face to face (1 m apart), or with ``diamond`` a
    square turned by 45 degrees whose corner (0.5 m apart) presses into the carrier's face, so
    that the contact width (twice the depth) grows in every step."""
    size = 2000.0
    dlon = math.degrees(size / 6371000.0) / math.cos(math.radians(80.0))
    thin = {"center": (dlon * 1.0005, 80.0), "flag": "steady", "velocity": (-0.05, 0.0),
            "thickness": 0.5}
    if diamond:  # half-diagonals of 1000 m along the parallel and the meridian
        a = math.degrees(0.5 * size / 6371000.0)
        x0, da = dlon * 1.00025, a / math.cos(math.radians(80.0))
        thin = {k: v for k, v in thin.items() if k != "center"}
        thin["vertices"] = [[x0 - da, 80.0], [x0, 80.0 - a], [x0 + da, 80.0], [x0, 80.0 + a]]
    els = [{"center": (-dlon, 80.0), "flag": "static", "thickness": 5.0},  # a thick wall
           {"center": (0.0, 80.0), "thickness": 2.0},  # the carrier, pressed on the wall
           thin]
    txt = scene_text(els, size=size, dt=0.25, duration=steps * 0.25, extra=(
        '[contact]\nlaw = "ridging"\njoints = "none"\n\n[[process]]\nname = "ridging"\n'))
    return Simulation(scene_from_text(txt, "<ridging>"), out=False, progress=False)


def _ridge_by_hand(sim, steps, P=2.75e4):
    """Step ``sim`` (:func:`ridging_scene`) and follow the ridging of the thin ice (2) onto the
    carrier (1) by hand; yields per step ``(force [N], limit [N], width before, width after
    [m], plastic, ridged [m³], expected [m³], c_thin [1], converted [m²])``. The law caps the
    normal force at ``P h w`` of the evaluation, which siku2 makes at the state before the
    step: the pair is plastic when its force (the generalised force on ``i``, equal to the
    contact force to ``(size / R)² ~ 1e-7``) is at least ``1 - 1e-6`` of ``P h w`` at the width
    before the step; then the growth of the overlap after the step (clipped here) beyond the
    largest area converted is ice of the thin element, which has no open water to close: its
    area leaves the thin ice (concentration ``c_thin``), its volume (at the thin ice's own
    thickness, which does not change) moves onto the carrier."""
    from siku_core.contact.contact_frames import rotation_matrices
    from siku_core.contact.contact_overlaps import overlaps, pair_overlaps

    st, cm = sim.state, sim.contacts
    rm = np.empty((st.n, 3, 3))
    nmax = int(np.max(np.diff(st.vert_offsets)))
    expected = converted = 0.0
    h_thin = float(st.thickness[2])
    c_thin = 1.0
    for _ in range(steps):
        rotation_matrices(st.q, rm, 1)
        w0 = pair_overlaps(rm, st.vert_offsets, st.verts, np.array([[1, 2]]), np.array([0]),
                           float(cm.radius), nmax)[0, 1]
        sim.step()
        pairs, _, width, force = overlaps(cm)
        ks = [n for n, (a, b) in enumerate(pairs) if {a, b} == {1, 2}]
        f = float(force[ks[0]]) if ks else 0.0
        w1 = float(width[ks[0]]) if ks else 0.0
        plastic = f > 0.0 and w0 > 0.0 and f >= (1 - 1e-6) * P * h_thin * w0
        A = _overlap_in_plane(sim, 1, 2)
        if plastic and A > converted:
            dV = (A - converted) * h_thin
            expected += dV
            c_thin -= (A - converted) / st.area[2]
            converted = A
        if A == 0.0:
            converted = 0.0  # apart: forgotten
        yield (f, P * h_thin * w0, w0, w1, plastic,
               float(sim.context.fields["ridged_volume"][1]), expected, c_thin, converted)


def test_ridging_caps_the_force_conserves_volume_and_converts_the_overlap():
    """Thin ice ridging onto a carrier: the force stays at the plastic limit, the ridged
    volume is the overlap the test clips itself times the thin ice's thickness, the thin ice
    keeps its thickness and loses that area (its concentration falls, open water takes its
    place: its ice covers its footprint less the overlap, none of it counted twice) and the
    total volume is unchanged."""
    sim = ridging_scene()
    st, cats = sim.state, sim.context.categories
    v0 = ice_volume(sim)
    plastic_steps = 0
    for force, limit, _, _, plastic, ridged, expected, c_thin, A in _ridge_by_hand(sim, 400):
        assert ridged == pytest.approx(expected, rel=1e-9)
        assert st.thickness[2] == 0.5  # m: the ice that stays is as thick as it was
        assert cats.fraction[2, 0] == pytest.approx(c_thin, rel=1e-12)
        if plastic_steps:  # once reached, the force stays at the plastic limit P* h w (to 1 %)
            assert force == pytest.approx(limit, rel=0.01)
        # the thin ice covers its footprint less the overlap converted: no ice counted twice
        assert cats.fraction[2, 0] * st.area[2] == pytest.approx(st.area[2] - A, rel=1e-12)
        plastic_steps += plastic
    assert plastic_steps > 100 and expected > 2e3  # m3: a real ridge
    assert 1.0 - c_thin > 1e-3  # a real opening: 4000 m² and more of 4e6
    assert sim.context.fields["ridged_volume"][2] == 0.0  # the thin ice carries nothing
    assert ice_volume(sim) == pytest.approx(v0, rel=1e-12)  # ridging alone conserves volume
    assert st.thickness[1] > 2.0  # the ridge: thicker ice on the carrier


def test_ridging_converts_a_capped_pair_whose_contact_widens_in_the_step():
    """A corner pressed into a face: the contact width grows in every step, so the force the
    law capped at ``P h w`` of the evaluation falls short of ``P h w`` after the step. The pair
    is converted in every step the law capped it (before the law's flag, the process compared
    the force with the limit at the width after the step and converted nothing here)."""
    sim = ridging_scene(steps=240, diamond=True)
    v0 = ice_volume(sim)
    # the engine's clip and the test's agree to the round-off of coordinates of 1000 m, eps
    # (1000 m)² per area; the ridged volume adds one area difference times h = 0.5 m per step
    # converted (while the overlap is still a sliver of a few m², more than 1e-9 of it)
    per_step = np.finfo(float).eps * 1000.0**2 * 0.5  # m³
    capped = 0
    for force, limit, w0, w1, plastic, ridged, expected, _, _ in _ridge_by_hand(sim, 240):
        if plastic:
            capped += 1
            assert force == pytest.approx(limit, rel=1e-6)  # at the limit of the evaluation
            assert w1 > w0 * (1 + 1e-3)  # ... and the contact widened in the step
            assert force < (1 - 1e-6) * limit * w1 / w0  # below the limit after the step
            assert ridged > 0.0
        assert ridged == pytest.approx(expected, rel=1e-9, abs=capped * per_step)
    assert capped > 100 and expected > 10.0  # m³
    assert ridged == pytest.approx(expected, rel=1e-9)
    assert ice_volume(sim) == pytest.approx(v0, rel=1e-12)


def converging_channel(hours=2.0, speed=0.1):
    """Five rows of seven irregular 5 km elements 1 m thick at the equator (a lon/lat grid is
    equal-area there to 1e-6): the west column a static coast, the east column a piston driven
    west at ``speed`` [m/s], static rows 20 m off both sides; ``hours`` of convergence (2 h at
    10 cm/s: 720 m, 2.9 % of the 25 km of free ice)."""
    size, dt = 5000.0, 0.6  # m; s, below the safe step of 0.69 s
    dlat = math.degrees(size / 6371000.0)
    gap = math.degrees(20.0 / 6371000.0)
    pack = square_pack(0.0, 0.0, 7, 5, size, jitter=0.2, seed=3, left="static", right="steady",
                       right_velocity=[-speed, 0.0])
    sides = [dict(square_pack(0.0, lat, 7, 1, size, flag="static"), lon=pack["lon"])
             for lat in (-dlat - gap, 5 * dlat + gap)]
    txt = scene_text([], packs=[pack, *sides], size=size, dt=dt, duration=hours * 3600.0,
                     thickness=1.0, extra=('[contact]\nlaw = "ridging"\njoints = "none"\n\n'
                                           '[[process]]\nname = "ridging"\n'))
    return Simulation(scene_from_text(txt, "<channel>"), out=False, progress=False)


def _footprints(sim):
    """The elements' polygons (shapely) in the Lambert azimuthal equal-area plane about the
    first element's centre [m]: its vertices' gnomonic coordinates (the model's tangent plane,
    radius ``R tan t`` at angle ``t`` from the centre) moved to the radius ``2 R sin(t / 2)``,
    so that the areas are those on the sphere (the edges' curvature aside: 1e-6 over 5 km)."""
    from shapely.geometry import Polygon

    from siku_core.geometry.quat import from_tangent, to_tangent

    st, R = sim.state, sim.radius
    out = []
    for k in range(st.n):
        xy = np.array([to_tangent(st.q[0], from_tangent(st.q[k], x, y, R), R)
                       for x, y in st.polygon(k)])
        rho = np.hypot(xy[:, 0], xy[:, 1])
        laea = 2 * R * np.sin(0.5 * np.arctan(rho / R))
        out.append(Polygon(xy * np.where(rho > 0, laea / np.maximum(rho, 1e-300), 1.0)[:, None]))
    return out


def test_ridging_in_a_converging_pack_counts_no_ice_twice():
    """Two hours of convergence against a coast: the elements' footprints overlap (1.4 % of
    their area covered twice; before ridging opened water, their ice covered it twice too, 2 %
    of the free ice), but the ice area ``sum c A`` stays within the union of the footprints
    (to 0.1 %), the gridded concentration at most 1 (cells of about four elements across, to
    the gridding's own error on the intact tiling at the start), the volume to 1e-12; the ice
    area lost carried the ridged volume (at the givers' thickness, 1 m to the thickest ice),
    and the givers hold open water."""
    from shapely.ops import unary_union

    from siku_io.analysis.gridded_fields import grid_snapshot, snapshot_of
    from siku_forcing.gridded.regular_grid import Grid, GridCfg

    sim = converging_channel()
    st, cats = sim.state, sim.context.categories
    grid = Grid(GridCfg(kind="lonlat", lon=(-0.1, 0.7), lat=(-0.2, 0.6), resolution=0.2),
                sim.radius)
    tiling = float(np.nanmax(grid_snapshot(grid, snapshot_of(sim))["concentration"])) - 1.0
    assert abs(tiling) < 1e-6  # the cells the intact pack covers are full
    v0, a0 = ice_volume(sim), float(st.area @ cats.fraction.sum(1))
    sim.run()
    polys = _footprints(sim)
    shapes = np.array([p.area for p in polys])
    np.testing.assert_allclose(shapes, st.area, rtol=1e-6)
    union = unary_union(polys).area
    twice = shapes.sum() - union
    assert twice > 0.01 * union  # m²: a pack that converged
    ice = float(st.area @ cats.fraction.sum(1))
    assert ice <= union * (1 + 1e-3)  # no ice counted twice
    gridded = grid_snapshot(grid, snapshot_of(sim))["concentration"]
    assert np.nanmax(gridded) <= 1.0 + max(tiling, 0.0)
    assert ice_volume(sim) == pytest.approx(v0, rel=1e-12)
    f = sim.context.fields
    moved = float(f["ridged_volume"].sum() + f["rafted_volume"].sum())  # m³
    lost = a0 - ice  # m²
    assert moved / st.thickness.max() * (1 - 1e-9) <= lost <= moved / 1.0 * (1 + 1e-9)
    assert cats.fraction.sum(1).min() < 0.95  # open water in the givers
    assert np.array_equal(cats.thickness[:, 0], st.thickness)


def test_ridging_needs_the_ridging_law():
    txt = scene_text([(0.0, 80.0)], dt=60.0, duration=600.0) + (
        '\n[contact]\nlaw = "collision"\n\n[[process]]\nname = "ridging"\n')
    with pytest.raises(SceneError, match='law = "ridging"'):
        Simulation(scene_from_text(txt, "<no law>"), out=False, progress=False)


def test_ridging_leaves_an_element_melted_earlier_in_the_step_alone():
    """A process that runs before ridging melts the thin ice while it is ridging: ridging in
    the same step moves nothing from or to it (its volume has left the budget)."""
    sim = ridging_scene()
    for _ in range(400):  # to a step at which the thin ice is ridging
        before = float(sim.context.fields["ridged_volume"][1])
        sim.step()
        if sim.context.fields["ridged_volume"][1] > before > 0:
            break
    ridging = sim.processes[0]
    h, ridged = sim.state.thickness.copy(), sim.context.fields["ridged_volume"].copy()
    # applied again to the same state, ridging would convert the thin ice's whole overlap
    # again if it had converted none of it yet: forget the pair (1, 2) (key 1 * 3 + 2)
    ridging.converted[ridging.keys == 5] = 0.0
    sim.context.melt([2])  # an earlier process of this step melted the thin ice
    ridging.apply(sim.context, sim.dt)
    assert np.array_equal(sim.state.thickness, h)
    assert np.array_equal(sim.context.fields["ridged_volume"], ridged)


def test_refreezing_after_an_element_beside_a_static_one_melted():
    """Thin ice jointed to a static cell melts away; elsewhere a thick floe's joint breaks and
    refreezes: every joint's constants are recomputed then, those of the melted element's
    joint with a static one included (they stay finite), and no joint of a melted element
    refreezes, even in the step it melted."""
    thin = square_pack(0.0, 80.0, 2, 1, size=2000.0, left="static", thickness=0.3)
    thick = square_pack(0.5, 80.0, 2, 1, size=2000.0, thickness=2.0)
    txt = scene_text([], packs=[thin, thick], dt=0.4, duration=40.0, extra=(
        '[contact]\nlaw = "distributed_spring"\n\n[[process]]\nname = "thermodynamics"\n'
        'params = { surface_temperature = 0.0, ocean_heat_flux = 2e6, min_thickness = 0.1 }\n'
        '\n[[process]]\nname = "refreeze"\nparams = { freeze_time = 0.0 }\n'))
    sim = Simulation(scene_from_text(txt, "<static melt>"), out=False, progress=False)
    cm = sim.contacts
    assert cm.n_joints == 2
    while sim.state.flags[1] != MELTED:
        sim.step()
    melted = [k for k in range(2) if 1 in (cm.ji[k], cm.jj[k])]
    other = [k for k in range(2) if k not in melted]
    assert not cm.intact[melted].any()  # broken when it melted, not refrozen
    cm.break_joints(np.array(other), 5, sim.time)
    sim.step()  # the thick floe's joint refreezes at once
    assert cm.intact[other].all() and not cm.intact[melted].any()
    assert np.isfinite(cm.jK).all() and np.isfinite(cm.jmeff).all()
