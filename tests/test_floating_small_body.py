"""The floating process's default coefficients depend on the wave's frequency: the long-wave
(small-body) approximation (``siku_plugins.floating.small_body``) against capytaine for one
box, the choice ``coefficients = "auto"`` makes, and the attenuation a field of pancakes
implies by its radiation (``examples/floating/pancakes.py``) with the default coefficients
against capytaine's."""
from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from siku_plugins.floating import small_body

RHO, G, RHO_I = 1026.0, 9.81, 917.0
ROOT = Path(__file__).resolve().parents[1]


def box(s=2.0, h=0.3):
    d = h * RHO_I / RHO
    A, J = s * s, s ** 4 / 12
    m = RHO_I * h * A
    inertia = RHO_I * h * J + m * h * h / 12
    return dict(s=s, h=h, d=d, A=A, J=J, m=m, I=inertia, C3=RHO * G * A,
                C1=RHO * G * (J - A * d * (h - d) / 2))


def test_the_disc_limits_are_the_baffled_pistons():
    # A33 = (8/3) rho a^3 and A_k = (4/15) rho a^5 for the disc of radius a (J = pi a^4 / 4)
    a = 1.3
    A = math.pi * a * a
    J = math.pi * a ** 4 / 4
    A33, B33, A1, *_ = small_body.coefficients(np.array([A]), J, J, 1.0, 1.0, 1.0, 1e9, 1e9,
                                               1e9, 1e-3, RHO, G)
    assert A33[0] == pytest.approx(8 / 3 * RHO * a ** 3, rel=1e-14)
    assert A1[0] == pytest.approx(4 / 15 * RHO * a ** 5, rel=1e-14)
    # deep water, far below the natural frequency: B33 -> rho omega^3 A^2 / (2 g)
    w = 1e-3
    assert B33[0] == pytest.approx(RHO * w ** 3 * A * A / (2 * G), rel=1e-6)
    # finite depth: the dispersion relation and group velocity
    k, cg = small_body.wavenumber(0.5, G, 30.0)
    assert G * k * math.tanh(k * 30.0) == pytest.approx(0.25, rel=1e-13)
    assert cg == pytest.approx(0.5 / k * (0.5 + k * 30.0 / math.sinh(2 * k * 30.0)), rel=1e-13)


@pytest.mark.parametrize("frequency", [pytest.param(0.1, marks=pytest.mark.slow), 0.15,
                                       pytest.param(0.2, marks=pytest.mark.slow)])
def test_the_approximation_against_capytaine_within_its_order(frequency):
    """Heave added mass and damping of a 2 m × 2 m × 0.3 m box. The error of the damping: the
    terms left out are of second order in K a (the pressure's variation over the floe,
    diffraction): at most 2 (K a)²; and the disc's added mass stands for the box's within 10 %
    (its corners and draft), which enters the exciting force ``1 - omega² (m + A33) / C``
    at first order: ``2 × 0.1 × A33 K / (rho A) = 0.17 K a``."""
    pytest.importorskip("capytaine")
    from siku_plugins.floating.hydro import body, radiation

    b = box()
    poly = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]]) * b["s"] / 2
    w = 2 * math.pi * frequency
    A3, B3 = radiation(body(poly, b["d"], b["h"], b["s"] / 16), "Heave", w, RHO, G)
    A33, B33, *_, ka = small_body.coefficients(
        np.array([b["A"]]), b["J"], b["J"], b["m"], b["I"], b["I"], b["C3"], b["C1"], b["C1"],
        w, RHO, G)
    ka = float(ka[0])
    assert ka < 0.2
    assert abs(A33[0] / A3 - 1) <= 0.10
    assert abs(B33[0] / B3 - 1) <= 0.17 * ka + 2 * ka * ka
    # the scene's damping ratio, fitted at the natural frequency, fails the same bound (by
    # three to seven times capytaine's damping here)
    scene = 2 * 0.172 * math.sqrt((b["m"] + 0.244 * RHO * b["A"] ** 1.5) * b["C3"])
    assert scene / B3 - 1 > 0.17 * ka + 2 * ka * ka


def pancakes():
    spec = importlib.util.spec_from_file_location(
        "pancakes", ROOT / "examples" / "floating" / "pancakes.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("frequency", [0.05, 0.15])
def test_the_pancake_field_attenuates_with_the_defaults_as_with_capytaine(frequency):
    """The emergent attenuation of 2 m pancakes: with the default coefficients without
    capytaine (the small-body approximation) within a factor 3 of capytaine's at the wave's
    frequency; the default picks capytaine where it is installed."""
    pytest.importorskip("capytaine", reason="capytaine (siku[hydro]) is not installed: no "
                        "reference to compare the default coefficients with")
    p = pancakes()
    k_cap, used = p.attenuation(frequency, "capytaine")
    k_sb, used_sb = p.attenuation(frequency, "small_body")
    assert used_sb == "small_body" and used == "capytaine"
    assert k_cap > 0 and 1 / 3 <= k_sb / k_cap <= 3
    k_auto, used_auto = p.attenuation(frequency)
    assert used_auto == "capytaine" and k_auto == k_cap


def test_auto_chooses_by_what_the_scene_gives(tmp_path, monkeypatch):
    """"auto": the scene's ratios where the scene sets one, or in still water; the
    small-body approximation where capytaine cannot be imported."""
    import builtins

    from siku_core.scene.scene_file import load_scene
    from siku_core.run.simulation import Simulation

    p = pancakes()

    def used(txt):
        path = tmp_path / "s.toml"
        path.write_text(txt)
        sim = Simulation(load_scene(path), out=False, progress=False)
        return next(q for q in sim.processes if q.name == "floating").coefficients_used

    txt = p.scene(0.1, "auto")
    given = txt.replace("ramp =", "damping_ratio = 0.2, ramp =")
    assert used(given) == "scene"
    still = txt.replace("ramp =", 'wave = "none", ramp =')
    assert used(still) == "scene"
    real = builtins.__import__

    def no_capytaine(name, *a, **k):
        if name == "capytaine" or name.startswith("capytaine."):
            raise ImportError(name)
        return real(name, *a, **k)

    monkeypatch.setattr(builtins, "__import__", no_capytaine)
    assert used(txt) == "small_body"
