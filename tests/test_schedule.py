"""Output times: the step is fitted so that snapshots, diagnostics and the end fall exactly on
the scheduled times for any dt (``siku_core.run.schedule.fit_time_step``)."""
from __future__ import annotations

import math
from fractions import Fraction

import h5py
import numpy as np
import pytest

from siku_core.run.schedule import MIN_FIT_SHARE, fit_time_step
from siku_core.run.simulation import Simulation
from siku_core.testing import make_scene


@pytest.mark.parametrize("dt", [7.0, 6.0, 11.0, 13.7, 0.3, 59.0, 1.75])
def test_fitted_step_divides_every_output_time_and_is_never_longer(dt):
    step, exact = fit_time_step(dt, 86400.0, (3600.0, 600.0))
    assert exact and step <= dt
    # at most one extra step per 600 s interval: step >= 600 / (ceil(600 / dt))
    assert step >= 600.0 / math.ceil(600.0 / dt) * (1 - 1e-15)
    for interval in (86400.0, 3600.0, 600.0):
        n = interval / step
        assert n == pytest.approx(round(n), abs=1e-9)


def test_a_step_that_divides_the_times_is_kept_bit_for_bit():
    for dt in (7.2, 60.0, 0.5, 1.0 / 3.0):
        assert fit_time_step(dt, 86400.0, (3600.0,)) == (dt, True)


def test_times_without_a_common_divisor_near_dt_keep_dt():
    # 86400.5 s and 3600 s share only 0.5 s: a step that short would cost 14 times the run
    step, exact = fit_time_step(7.0, 86400.5, (3600.0,))
    assert (step, exact) == (7.0, False)
    assert 0.5 < MIN_FIT_SHARE * 7.0


def test_greatest_common_divisor_of_fractional_times():
    step, exact = fit_time_step(0.4, 30.0, (1.5, 0.75))
    assert exact and Fraction(0.75) / Fraction(step) == pytest.approx(2.0, abs=1e-12)


@pytest.mark.parametrize("dt", [7.0, 13.0, 47.0])
def test_snapshots_fall_on_the_scheduled_times(tmp_path, dt):
    scene = make_scene(elements=[(-150.0, 75.0)],
                       forcing=[{"source": "air_drag",
                                 "field": {"type": "uniform", "params": {"u": 10.0}}}],
                       duration=3 * 3600, dt=dt, output={"every": "1h",
                                                          "diagnostics_every": "20min"})
    out = tmp_path / "run.h5"
    sim = Simulation(scene, out=out, progress=False)
    assert sim.dt <= dt and sim.dt_requested == dt
    sim.run()
    with h5py.File(out) as f:
        t = f["states/time"][...]
        td = f["diagnostics/time"][...]
        assert f.attrs["dt_requested"] == dt and f.attrs["dt"] == sim.dt
    np.testing.assert_allclose(t, [0.0, 3600.0, 7200.0, 10800.0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(td, np.arange(10) * 1200.0, rtol=0, atol=1e-9)
    assert sim.time == pytest.approx(10800.0, abs=1e-9)
