"""Floating floes and wave breaking on MPI ranks give the bits of one rank
(docs/explanation/scaling_out.md).

Cases (``siku_core.testing.ranks_cases``): a bonded floe of 24 elements under the ``floating``
process in a wave with two point loads, its joints beams that break in flexure, split by
bisection (``floating``) and with every element changing rank every 40 steps
(``floating_migrate``); the floe floating without beams (``floating_plain``: each element by
itself); the floe under the ``waves`` forcing's flexural breaking (``wave_breaking``: floes
labelled over the whole joint network, split as joints break); a ``spectral`` sea that the ice
damps on a grid, its elements in a flume (``spectral``) and floating floes in it
(``spectral_floating``); three ranks on the floating floe and the sea. Each run on ranks is a
real ``mpiexec -n N`` under a timeout (a deadlock fails).
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.contact_law import BreakMode
from test_ranks import HAVE_MPI, TIMEOUT, assert_same_bits, needs_mpi, one_rank, run_cases

FLEXURE = {int(BreakMode.FLEXURE)}
FLOAT_CASES = ("floating", "floating_migrate", "floating_plain", "wave_breaking")
#: a sea the ice damps on a grid (the ``spectral`` field), by itself and under floating floes
SEA_CASES = ("spectral", "spectral_floating")


@pytest.fixture(scope="module")
def float_ranks(tmp_path_factory):
    if not HAVE_MPI:
        pytest.skip("mpi4py and mpiexec not installed (pip install 'siku[mpi]')")
    return run_cases(2, tmp_path_factory.mktemp("ranks_float"), FLOAT_CASES + SEA_CASES)


@needs_mpi
@pytest.mark.parametrize("name", FLOAT_CASES)
def test_floating_and_wave_breaking_on_two_ranks_same_bits(float_ranks, name):
    """State, joints (broken in flexure by the beams or by the waves' check), heave, roll,
    pitch, their rates, the radiated power and the diagnostics equal one rank's bit for bit;
    a joint both ranks hold is in the same state on both."""
    many = np.load(float_ranks / f"{name}.npz")
    one = one_rank(name)
    assert_same_bits(one, many, name)
    assert bool(many["ranks_joints_agree"])
    assert int(many["ranks_shared_joints"]) >= 2  # the floe lies on both ranks
    n_joints = len(one["joint_intact"])
    broken = int(one["n_broken_total"])
    if name in ("floating", "floating_migrate"):
        # the loads bend the floe: some joints, not all, break in flexure
        assert 1 <= broken < n_joints
        assert set(one["joint_break_mode"][~one["joint_intact"]].tolist()) == FLEXURE
        assert np.ptp(one["field_heave"]) > 0  # the floe bends: its elements heave apart
    if name == "floating_migrate":  # every element changed rank at steps 40 and 80
        assert int(many["ranks_migrated"]) >= 2 * len(one["field_heave"])
    if name == "floating_plain":
        assert broken == 0 and np.abs(one["field_heave"]).max() > 0
        assert float(one["diag_wave_radiated_power"]) > 0
    if name == "wave_breaking":  # the waves' check broke joints, not all, in flexure
        assert 1 <= broken < n_joints
        assert set(one["joint_break_mode"][~one["joint_intact"]].tolist()) == FLEXURE


@needs_mpi
@pytest.mark.parametrize("name", SEA_CASES)
def test_spectral_sea_on_two_ranks_same_bits(float_ranks, name):
    """A ``spectral`` sea damped by the ice on two ranks: the spectrum and its clock, the
    state, the fields of every element (wave height, dissipation, drag power, attenuation
    rates; heave and radiated power of the floating floes) and the diagnostics equal one
    rank's bit for bit at every diagnostics step and at the end; the ice does damp the sea
    (the spectrum in its cells falls below the incident one, which the open cells upstream
    keep), the cells are shared between the ranks' elements, and the elements feel the
    drag of the waves."""
    from siku_core.run.simulation import Simulation
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.testing.ranks_cases import CASES

    many = np.load(float_ranks / f"{name}.npz")
    one = one_rank(name)
    assert_same_bits(one, many, name)
    assert len(one["trace_step"]) >= 4  # several diagnostics steps, each compared
    owner = many["ranks_owner"]
    assert set(owner.tolist()) == {0, 1}
    sim = Simulation(scene_from_text(CASES[name][0], "<sea>"), out=False, progress=False)
    f = sim.forcing[0].field
    E_in = f.E_in[0]
    E = one["history_0_E"][0, 0]  # (one component, one row of cells)
    cells = f.element_cells(one["q"])
    iced = np.unique(cells)
    upstream = np.arange(iced.min())
    # a cell holds elements of both ranks (its ice is summed over them in global order)
    assert any(len(set(owner[cells == c].tolist())) == 2 for c in iced)
    # open water upstream keeps the incident sea; the ice damps it in its cells
    assert len(upstream) and np.array_equal(E[upstream], np.full(len(upstream), E_in))
    assert (E[iced] < E_in).all()
    assert (one["field_wave_dissipation"] > 0).all()
    assert (one["field_wave_height"] < 4 * np.sqrt(E_in)).all()
    assert float(one["diag_wave_power_absorbed"]) > 0
    assert (one["field_wave_drag_power"] != 0).all()
    assert (one["field_wave_response_attenuation"] != 0).all()
    if name == "spectral_floating":
        assert np.abs(one["field_heave"]).max() > 0
        assert float(one["diag_wave_radiated_power"]) > 0


@needs_mpi
@pytest.mark.slow
def test_floating_floe_on_three_ranks_same_bits(tmp_path):
    """Three ranks (oversubscribed) on the bending floe, the waves' breaking and the floes
    floating in a ``spectral`` sea: the bits of one rank."""
    names = ("floating", "wave_breaking", "spectral_floating")
    run_cases(3, tmp_path, names)
    for name in names:
        many = np.load(tmp_path / f"{name}.npz")
        assert_same_bits(one_rank(name), many, name)
        assert bool(many["ranks_joints_agree"])


def test_floe_labels_on_a_rank_are_the_runs():
    """On a rank holding a third of the floe and its ghosts, ``ctx.contacts.floe_labels()``
    gives the run's labels of its elements (one label for a floe over several ranks,
    numbered by global identities), with a joint the rank broke seen at once."""
    from siku_core.geometry.quat import centers
    from siku_core.ranks.decompose import bisect
    from siku_core.ranks.ghosts import local_sets
    from siku_core.ranks.local import local_engine
    from siku_core.run.simulation import Simulation
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.testing.ranks_cases import floe_text

    sim = Simulation(scene_from_text(floe_text(10), "<floe>"), out=False, progress=False)
    gc = sim.contacts
    c = centers(sim.state.q)
    owner = bisect(c, np.ones(sim.state.n), 3).assign(c)
    ids = local_sets(owner, 3, [np.stack([gc.ji, gc.jj], axis=1)])[0]
    loc, jg = local_engine(sim, ids, np.flatnonzero(owner[ids] != 0))
    count, label = loc.context.contacts.floe_labels()
    assert count == 1 and (label == 0).all()
    # cut the floe along a line of joints the rank holds: two floes, as on one rank
    x = c[:, 1]
    cut = np.flatnonzero((x[gc.ji] - np.median(x)) * (x[gc.jj] - np.median(x)) < 0)
    assert np.isin(cut, jg).any()
    held = np.searchsorted(jg, cut[np.isin(cut, jg)])
    loc.contacts.break_joints(held, BreakMode.FLEXURE, 0.0)
    gc.break_joints(cut[np.isin(cut, jg)], BreakMode.FLEXURE, 0.0)
    want = gc.floe_labels()
    got = loc.context.contacts.floe_labels()
    assert got[0] == want[0] and np.array_equal(got[1], want[1][ids])


def test_floating_conforms_on_ranks_with_loads_by_index():
    """The process conformance check on ranks: the floating pack with loads on two
    elements (named by the run's index), set up over every other element from the run's
    set-up, heaves as among all, bit for bit."""
    from siku_core.testing.process_checks import check_process_on_ranks
    from siku_plugins.floating import Floating

    check_process_on_ranks(Floating, {"initial_heave": 0.1, "loads": [[3, 1e8], [4, -5e7]]})


@needs_mpi
@pytest.mark.slow
def test_floating_and_wave_breaking_write_the_same_file_on_two_ranks(tmp_path):
    """``siku run --ranks 2`` of the bending floe and of the waves' breaking writes the
    one-rank file byte for byte (states, heave and tilts, joints, the breaks' log in the
    order one rank logs them, pass by pass of the waves' check, diagnostics)."""
    import subprocess
    import sys

    from siku_core.testing.ranks_cases import floating_text, wave_breaking_text
    from test_ranks import _env

    for name, text in (("float", floating_text()), ("waves", wave_breaking_text())):
        (tmp_path / f"{name}.toml").write_text(text.replace(
            "[run]", "[output]\nevery = 0.02\n\n[run]"), encoding="utf-8")
        for out, extra in ((f"{name}1.h5", []), (f"{name}2.h5", ["--ranks", "2"])):
            p = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run",
                                f"{name}.toml", "--no-progress", "--no-plots", "--out", out,
                                *extra], cwd=tmp_path, env=_env(), capture_output=True,
                               text=True, timeout=2 * TIMEOUT)  # (with the writer)
            assert p.returncode == 0, p.stderr
        one = (tmp_path / f"{name}1.h5").read_bytes()
        assert one == (tmp_path / f"{name}2.h5").read_bytes(), name


def test_what_runs_on_ranks_and_what_is_refused(tmp_path):
    """The floating floe (bending, loads), the waves' breaking and a sea that the ice damps
    on a grid (the ``spectral`` field, under a floating floe) are not refused on ranks; a
    component that says it cannot run on ranks is, in one line naming it and the number of
    ranks."""
    from siku_core.ranks.driver import refusals
    from siku_core.run.simulation import Simulation
    from siku_core.scene.scene_file import scene_from_text
    from siku_core.testing.ranks_cases import floating_text, wave_breaking_text
    from test_spectral import build, flume_scene

    for text in (floating_text(10), wave_breaking_text(10)):
        assert refusals(Simulation(scene_from_text(text, "<f>"), out=False), 2) == []
    path = flume_scene(tmp_path, {})
    path.write_text(path.read_text() + '\n[[process]]\nname = "floating"\n'
                    'params = { coefficients = "scene" }\n')
    sim = build(path)
    assert refusals(sim, 4) == []
    field = sim.forcing[0].field
    try:
        field.runs_on_ranks = False  # (an instance may say so in its set-up)
        got = refusals(sim, 4)
    finally:
        del field.runs_on_ranks
    assert len(got) == 1 and "field 'spectral' cannot run on 4 ranks" in got[0], got


@needs_mpi
@pytest.mark.slow
def test_spectral_sea_writes_the_same_file_on_two_ranks_and_restarts_on_one(tmp_path):
    """``siku run --ranks 2`` of the floes floating in a ``spectral`` sea writes the one-rank
    file byte for byte (states, the wave fields of every element, heave, diagnostics, the
    spectrum in the restart record); a restart from its mid-run snapshot on one rank
    continues the spectrum and the floes as the one-rank run does, bit for bit."""
    import h5py

    from siku_core.testing.ranks_cases import spectral_floating_text
    from test_ranks import cli_scene

    run = cli_scene(tmp_path, spectral_floating_text(), "every = 2.5\ndiagnostics_every = 1.0",
                    name="sea.toml")
    run("part.h5", "--ranks", "2", "--set", "time.duration=5s")
    run("more.h5", "--restart", "part.h5", "--set", "time.duration=5s", "--extend", "5s")
    with h5py.File(tmp_path / "one.h5", "r") as a, h5py.File(tmp_path / "more.h5", "r") as b:
        k = list(a["states/step"][:]).index(int(b["states/step"][-1]))
        assert k > 0
        for name in ("q", "V", "fields/wave_height", "fields/heave"):
            assert np.array_equal(a[f"states/{name}"][k], b[f"states/{name}"][-1]), name
