"""The guards of the contact network (siku_core.run.guard): the breaking rate and the stable step
rechecked as joints change.

A bonded pack of 6 × 6 cells 2 km across (60 joints, ``tensile_strain = 1e-5``) given random
velocities of 1 mm/s (strains of about ``v / c = 1e-6``, a tenth of the joints' limit):

* at half its estimated critical step nothing breaks and the run ends;
* at 1.5 and 3 times the critical step (the dt check off, ``[run] allow_unstable_dt``; speeds
  far below ``max_speed``: the NaN guard never trips) the unstable modes grow until the joints
  break faster than cracks can run: the run stops with one line naming the step, the share
  broken and what to do, and the state is the last good one (no joint broken);
* ``break_guard = "warn"`` warns once and runs on; ``"off"`` says nothing;
* the dampers as written (unbounded, as the engine applied them before it bounded them by the
  step): the step the default scene shattered at (3 s against its explicit critical 1.665 s,
  1.8 times it) is refused before the run at the widest ``dt_safety`` (1), and run anyway it is
  stopped by the breaking rate, while with the bounded dampers that step lies within the
  critical step and runs without a break;
* breaking joints from outside past ``RECHECK_JOINTS`` of them checks the step again (and
  not before); refreezing them where the step is no longer stable is refused as before a run.
"""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from siku_core.run import guard as guard_module
from siku_core.contact_law import BreakMode
from siku_core.errors import StabilityError
from siku_core.run.guard import BREAK_SHARE, RECHECK_JOINTS
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_cases import contact_scene, square_pack

PARAMS = {"tensile_strain": 1e-5, "damping_ratio": 0.5, "joint_damping_ratio": 0.5}
STEPS = 400


def _sim(dt: float, cells: int = 6, **run) -> Simulation:
    pack = square_pack(10.0, 70.0, cells, cells, 2000.0)
    scene = contact_scene("distributed_spring", PARAMS, packs=[pack], dt=dt, steps=STEPS,
                          size=2000.0, run={"max_speed": 1e30, "break_guard": "stop", **run})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # (the dt check's warning under allow_unstable_dt)
        return Simulation(scene, out=False, progress=False)


@pytest.fixture(scope="module")
def critical() -> float:
    return _sim(1e-3).critical_dt


def _kicked(dt: float, **run) -> Simulation:
    sim = _sim(dt, **run)
    rng = np.random.default_rng(0)
    sim.state.V[:] = 1e-3 * rng.standard_normal((sim.state.n, 2))
    sim.guard.save()  # the kicked state is the last good one
    return sim


def test_a_pack_at_half_its_critical_step_breaks_nothing_and_is_not_stopped(critical):
    sim = _kicked(0.5 * critical)
    for _ in range(STEPS):
        sim.step()
    assert sim.contacts.n_intact == sim.contacts.n_joints


@pytest.mark.parametrize("factor", [1.5, 3.0])
def test_a_pack_far_above_its_critical_step_is_stopped_by_the_breaking_rate(critical, factor):
    sim = _kicked(factor * critical, allow_unstable_dt=True)
    rate = sim.guard.network.rate
    with pytest.raises(StabilityError) as err:
        for _ in range(STEPS):
            sim.step()
    msg = str(err.value)
    assert "\n" not in msg
    m = re.search(r"(\d+) of (\d+) intact joints \((\d+)%\) broke within (\d+) steps", msg)
    assert m, msg
    broke, intact = int(m.group(1)), int(m.group(2))
    assert broke / intact > BREAK_SHARE and broke > rate.one_crack
    assert int(m.group(4)) == rate.window
    assert re.search(r"at step \d+ \(t = ", msg) and "shorten dt" in msg
    assert max(np.abs(sim.state.V).max(), 0.0) < 100.0  # the default max_speed: not tripped
    # the state is the last good one
    assert sim.step_index == 0 and sim.contacts.n_intact == sim.contacts.n_joints


def test_warn_mode_warns_once_and_runs_on_and_off_mode_says_nothing(critical):
    sim = _kicked(3.0 * critical, allow_unstable_dt=True, break_guard="warn")
    with pytest.warns(UserWarning, match="faster than cracks can run") as got:
        for _ in range(50):
            sim.step()
    assert len([w for w in got if "faster than cracks" in str(w.message)]) == 1
    assert sim.step_index == 50
    sim = _kicked(3.0 * critical, allow_unstable_dt=True, break_guard="off")
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        for _ in range(50):
            sim.step()
    assert not [w for w in got if "faster than cracks" in str(w.message)]
    assert sim.contacts.n_intact < sim.contacts.n_joints


def test_the_window_is_a_few_elastic_crossing_times_of_an_element(critical):
    """``c = sqrt(E / rho)`` (1 GPa, 910 kg/m³: 1048 m/s) across cells of about 2 km."""
    sim = _sim(0.5 * critical)
    rate = sim.guard.network.rate
    assert rate.crossing == pytest.approx(2000.0 / np.sqrt(1e9 / 910.0), rel=0.02)
    assert rate.window == max(guard_module.MIN_WINDOW,
                              int(np.ceil(guard_module.CROSSINGS * rate.crossing / sim.dt)))


def test_the_step_is_checked_again_once_enough_joints_broke(critical, monkeypatch):
    sim = _sim(0.25 * critical, cells=10)  # 180 joints: one is 0.56 %, two 1.1 %
    cm = sim.contacts
    assert 1 <= RECHECK_JOINTS * cm.n_joints < 2
    calls = []
    real = Simulation.check_time_step
    monkeypatch.setattr(Simulation, "check_time_step",
                        lambda self, after="": (calls.append(after), real(self, after))[1])
    cm.break_joints(np.array([0]), BreakMode.STRAIN, sim.time)
    sim.step()
    assert calls == []
    cm.break_joints(np.array([1]), BreakMode.STRAIN, sim.time)
    sim.step()
    assert len(calls) == 1 and "2 joints broke or froze" in calls[0]


def test_refreezing_where_the_step_is_no_longer_stable_is_refused_as_before_a_run(critical):
    """All joints broken, the pack's step is longer (its free edges' collisions are softer than
    its joints); a dt stable for it but not for the joints, halfway between the two safe steps,
    is refused once they freeze again, in the words of the check before a run. (Breaking them
    all at once is what the breaking-rate guard stops: off here.)"""
    probe = _sim(0.25 * critical, allow_unstable_dt=True, break_guard="off")
    probe.contacts.break_joints(np.arange(probe.contacts.n_joints), BreakMode.STRAIN, 0.0)
    probe.step()
    assert probe.critical_dt > 1.1 * critical
    safe = probe.scene.cfg.run.dt_safety
    sim = _sim(0.5 * safe * (critical + probe.critical_dt), allow_unstable_dt=True,
               break_guard="off")
    cm = sim.contacts
    every = np.arange(cm.n_joints)
    cm.break_joints(every, BreakMode.STRAIN, sim.time)
    sim.step()
    assert sim.dt < sim.scene.cfg.run.dt_safety * sim.critical_dt  # stable without joints
    sim.scene.cfg.run.allow_unstable_dt = False
    cm.refreeze_joints(every, sim.time)
    with pytest.raises(StabilityError, match=r"is above the safe step .* after 60 joints broke "
                                             r"or froze .* lower dt") as err:
        sim.step()
    assert "\n" not in str(err.value)


def test_joints_broken_from_outside_the_law_are_not_counted(critical):
    """A component breaking every joint at once (``BreakMode.EXTERNAL``: a coupled model, a
    wave field) is not the contacts' integration going unstable."""
    sim = _sim(0.25 * critical)
    cm = sim.contacts
    cm.break_joints(np.arange(cm.n_joints), BreakMode.EXTERNAL, sim.time)
    sim.step()
    assert sim.step_index == 1 and cm.n_intact == 0


def test_the_old_dampers_at_1_8_times_their_critical_step_are_refused_and_stopped(monkeypatch):
    """The dampers unbounded (``ContactModel.damping_mobility`` all zeros: every ``g[J_DTM]``
    is 0, the law's ``step_damper`` returns ``c`` as written, and the estimate is the explicit
    ``4 / (gamma + sqrt(gamma² + 4 omega²))``) at 1.8 times their critical step, the ratio of
    the default scene's 3 s to its explicit 1.665 s."""
    from siku_core.contact.contact_model import ContactModel

    bounded = _sim(1e-3).critical_dt
    monkeypatch.setattr(ContactModel, "damping_mobility",
                        lambda self: np.zeros((self.state.n, 2)))
    explicit = _sim(1e-3).critical_dt
    assert explicit < 0.6 * bounded  # the dampers as written set the step
    dt = 1.8 * explicit
    with pytest.raises(StabilityError, match="is above the safe step"):
        _sim(dt, dt_safety=1.0)
    sim = _kicked(dt, allow_unstable_dt=True)
    with pytest.raises(StabilityError, match="faster than cracks can run"):
        for _ in range(STEPS):
            sim.step()
    assert sim.step_index == 0 and sim.contacts.n_intact == sim.contacts.n_joints
    monkeypatch.undo()
    sim = _kicked(dt, dt_safety=1.0)  # bounded: within the critical step, accepted at 1
    assert dt <= sim.critical_dt
    for _ in range(STEPS):
        sim.step()
    assert sim.contacts.n_intact == sim.contacts.n_joints
