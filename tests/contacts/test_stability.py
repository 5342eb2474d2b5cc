"""Time-step stability of contacts (docs/explanation/physics.md §5).

A 4 × 3 jittered jointed pack of 2 km cells of 1 m ice at 70°N (distributed_spring, no damping,
joints that do not break unless said), every cell spinning at 1e-4 rad/s and nothing driving it.
The engine estimates the critical step ``dt_c = 2 / omega_max`` from a Gershgorin bound on
the contact stiffness and refuses ``dt > dt_safety × dt_c`` unless told.

Symplectic Euler (siku2) is stable for ``omega dt < 2``: then each mode keeps the modified
energy ``v² + omega² x² - omega² dt x v``, so with all energy kinetic at the start (the pack is
unstrained) the kinetic energy never exceeds ``1 / (1 - (omega dt / 2)²)`` times its initial
value: 4/3 at the largest accepted step (``omega dt <= 2 × 0.5 = 1``).
"""
from __future__ import annotations

import re
import warnings

import numpy as np
import pytest

from siku_core.errors import NonFiniteError, StabilityError
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import contact_scene, square_pack

LAW = "distributed_spring"
UNBREAKABLE = {"tensile_strain": 1.0, "joint_damping_ratio": 0.0, "damping_ratio": 0.0}


def scene(dt, steps=10, params=UNBREAKABLE, allow=False, safety=None):
    run = {"allow_unstable_dt": allow}
    if safety is not None:
        run["dt_safety"] = safety
    pack = square_pack(10.0, 70.0, 4, 3, 2000.0, jitter=0.2, seed=3, spin=1e-4)
    return contact_scene(LAW, params, packs=[pack], dt=dt, steps=steps, run=run)


@pytest.fixture(scope="module")
def estimate():
    """Critical step [s] and the element that sets it, from an accepted scene."""
    sim = Simulation(scene(0.01), out=False, progress=False)
    omega, elem = sim.contacts.stiffness_bound()
    assert sim.critical_dt == pytest.approx(2.0 / omega, rel=1e-12)
    assert sim.contacts.n_joints == 17
    return sim.critical_dt, elem


def test_dt_above_safe_share_is_refused_naming_law_and_element(estimate):
    dt_c, elem = estimate
    with pytest.raises(StabilityError) as err:
        Simulation(scene(0.6 * dt_c), out=False, progress=False)  # dt_safety = 0.5
    msg = str(err.value)
    assert f"'{LAW}'" in msg
    assert re.search(rf"\belement {elem}\b", msg)
    assert "allow_unstable_dt" in msg
    # a stricter safety share refuses smaller steps too
    with pytest.raises(StabilityError):
        Simulation(scene(0.3 * dt_c, safety=0.25), out=False, progress=False)
    Simulation(scene(0.5 * dt_c), out=False, progress=False)  # the largest accepted


def test_allow_unstable_dt_warns_instead(estimate):
    dt_c, elem = estimate
    with pytest.warns(UserWarning, match=rf"element {elem} under law '{LAW}'.*allow_unstable_dt"):
        sim = Simulation(scene(0.6 * dt_c, allow=True), out=False, progress=False)
    assert sim.dt == 0.6 * dt_c


def test_clearly_unstable_dt_is_stopped_by_the_divergence_guard(estimate):
    """5 × dt_c: the energy grows by orders of magnitude within a few steps (a stable run keeps
    it below 4/3 of its start) and the state stays finite for a long time (measured: 2.5e9 ×
    the start within 20 steps, ~1e28 × after 2000 steps with unbreakable joints), so only the
    speed check of the guard ([run] max_speed, 100 m/s by default: sea ice drifts at most a few
    m/s) catches it. The error names the element and step, and the state is the last good one."""
    dt_c, _ = estimate
    with pytest.warns(UserWarning):
        sim = Simulation(scene(5 * dt_c, steps=50, allow=True), out=False, progress=False)
    with pytest.raises(NonFiniteError, match=r"speed of element \d+ is .* above \[run\] "
                       r"max_speed = 100 m/s: the run is diverging .* at step \d+"):
        sim.run()
    assert all(np.isfinite(getattr(sim.state, k)).all() for k in ("q", "V", "w"))
    assert np.hypot(sim.state.V[:, 0], sim.state.V[:, 1]).max() <= 100.0


def test_energy_bounded_below_the_estimate(estimate):
    """At the largest accepted step, 2000 steps: kinetic energy <= 4/3 of the start (see the
    module docstring), every joint intact."""
    dt_c, _ = estimate
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # accepted without a warning
        sim = Simulation(scene(0.5 * dt_c, steps=2000), out=False, progress=False)
    ke0 = sim.diagnostics()["kinetic_energy"]
    assert ke0 > 0
    ke = [ke0]
    for _ in range(20):
        sim.run(100)
        ke.append(sim.diagnostics()["kinetic_energy"])
    assert sim.step_index == 2000
    assert max(ke) <= 4 / 3 * ke0, f"max KE / KE0 = {max(ke) / ke0:.4f}"
    assert min(ke) > 0.0  # it oscillates between kinetic and elastic, not decaying to rest
    assert sim.contacts.n_intact == sim.contacts.n_joints
