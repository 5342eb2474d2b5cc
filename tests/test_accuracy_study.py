"""The speed/accuracy study (``bench/accuracy.py``, ``python -m bench.accuracy``) on a tiny grid.

The study's functions must measure the physics the verification tests establish: the V2 error
falls at each integrator's free-motion ``order``, the V1 spin-up error at its
``order_with_forces``, and the V6 handle force matches the continuum; the writer produces the
table and the plot. No assertion on wall-clock times (the study reports them, nothing checks
them). A few seconds in all.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import pytest

from siku_core.plugins import get_registry

ROOT = Path(__file__).resolve().parents[1]
if not (ROOT / "bench" / "accuracy.py").is_file():  # pragma: no cover - installed without bench/
    pytest.skip("no bench/ (not a source checkout)", allow_module_level=True)
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from bench import accuracy as acc  # noqa: E402 - bench/ is importable only after the sys.path insert


def order(integrator: str, forces: bool) -> int:
    cls = get_registry().get("integrator", integrator)
    return cls.order_with_forces if forces else cls.order


def test_great_circle_error_falls_at_the_free_motion_order():
    """V2 without spin: halving dt divides the 6-day end error by 2^order (4 and 16).

    siku2's whole error is the Cayley angle, ``R a t (a dt)²/48`` (tests/test_great_circles.py);
    the next term is relative ``O((a dt)²) ≈ 2e-4`` at 1200 s: tolerance 1 %, and the error at
    600 s matches the formula to 1 %. rk4 without spin: ``∝ dt⁴``, next term relative
    ``O((a dt)²) ≈ 8e-4`` at 2400 s; tolerance 2 %. Both far above round-off (≥ 3e-4 m).
    """
    a = acc.GC_SPEED / acc.R_EARTH
    s1, s2 = (acc.great_circle("siku2", dt, spin=False) for dt in (1200.0, 600.0))
    assert s1.error / s2.error == pytest.approx(2 ** order("siku2", False), rel=0.01)
    cayley = acc.R_EARTH * a * acc.GC_T * (a * 600.0) ** 2 / 48
    assert s2.error == pytest.approx(cayley, rel=0.01)  # 44.1 m
    r1, r2 = (acc.great_circle("rk4", dt, spin=False) for dt in (2400.0, 1200.0))
    assert r1.error / r2.error == pytest.approx(2 ** order("rk4", False), rel=0.02)
    assert r2.error > 1e-5
    # cost bookkeeping: one element, rk4 evaluates the forces four times per step
    assert (s2.steps, s2.elements, s2.force_evaluations) == (864, 1, 864)
    assert (r2.steps, r2.force_evaluations) == (432, 4 * 432)


@pytest.mark.parametrize("integrator, dts, tol", [
    ("siku2", (37.5, 18.75), 0.15),  # O(κ dt) ≤ 0.04 on the slope; ± 0.15
    ("rk4", (150.0, 75.0), 0.3),  # slope exceeds 4 by O(κ dt) ≤ 0.16 (measured 4.12); ± 0.3
])
def test_spinup_error_falls_at_the_order_with_forces(integrator, dts, tol):
    """V1: under water drag siku2 is first order (forward-Euler kick), rk4 fourth order."""
    p1, p2 = (acc.spinup(integrator, dt) for dt in dts)
    measured = math.log2(p1.error / p2.error)
    assert abs(measured - order(integrator, True)) < tol, measured
    assert p2.error > 1e-12  # far above round-off (|U| eps ~ 1e-17 m/s)


def test_v6_short_pull_matches_the_continuum_and_converges_in_dt():
    """V6 at 5×2 over 5000 s (2.2 wave round trips), each run against rk4 at dt0/16.

    * ⟨F⟩ over the last period matches ``E h W δ/(L + b)`` + damping within 0.5 % (the V6
      test's tolerance; measured 0.14 % at this short duration);
    * siku2's time-step error is first order (``order_with_forces = 1``): halving dt divides it
      by 2^(1 ± 0.6) (the high joint modes, ``omega dt`` up to 0.9, are not asymptotic);
    * rk4 is at least ten times more accurate than siku2 at the same dt;
    * without the collision law's damping (a force that jumps when touching neighbours part)
      rk4's time-step error is fourth order: ratio 2^(4 ± 0.5).
    """
    pts, _ = acc.v6_grid([(5, 2)], {"siku2": (1.0, 0.5), "rk4": (1.0,)}, log=lambda s: None,
                         duration=5000.0)
    s1, s2, r1 = pts
    assert all(p.error is not None for p in pts)
    for p in pts:
        assert p.extra["vs_continuum"] < 0.005
        assert p.elements == 5 * 2 + 2 * 2 and p.dt <= 0.45 * p.dt_critical + 1e-12
    assert abs(math.log2(s1.error / s2.error) - order("siku2", True)) < 0.6
    assert r1.error < 0.1 * s1.error
    smooth, _ = acc.v6_grid([(5, 2)], {"siku2": (), "rk4": (1.0, 0.5)}, params=acc.SMOOTH,
                            log=lambda s: None, duration=5000.0)
    assert abs(math.log2(smooth[0].error / smooth[1].error) - order("rk4", True)) < 0.5


def test_frontier_keeps_only_points_no_cheaper_point_beats():
    mk = [acc.Point("c", "x", 1.0, 1, 1, 1, sec, err, "m") for sec, err in
          [(1.0, 10.0), (2.0, 20.0), (3.0, 5.0), (4.0, None), (5.0, 1.0)]]
    assert [p.seconds for p in acc.frontier(mk)] == [1.0, 3.0, 5.0]


def test_table_and_plot_are_written(tmp_path):
    pts = [acc.great_circle(i, dt) for i, dt in (("siku2", 4800.0), ("siku2", 2400.0),
                                                  ("rk4", 4800.0))]
    v6 = acc.Point("V6 pack pull", "siku2", 40.0, 10, 14, 10, 0.01, 1e-3, "1", "5×2", 90.0,
                   {"factor": 1.0, "vs_continuum": 5e-4, "vs_finest": 1e-5, "ratio": 5e-4})
    md, png = acc.write(pts + [v6], tmp_path, "_test", header="header\n\n")
    text = md.read_text(encoding="utf-8")
    assert md.name == "speed_accuracy_table_test.md" and text.startswith("header")
    assert "### V2 great circle, spin 1/day" in text and "### V6 pack pull" in text
    assert "★" in text and "| siku2 | 5×2 | 40 | 0.444 |" in text
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
