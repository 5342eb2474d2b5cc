"""Virtual ice tests (Orzech et al. §3a, Fig. 3; ``siku_plugins.lab``, docs/explanation/lab.md).

Linearity: the block is linear elastic up to brittle bond failure, and the only stress scale
of the bonded-particle model is the bond strength (the collision law's stiffness is ``E``, like
the bonds'; the default strain rate reaches the bond's failure strain in the same number of
crossing times at every strength), so the macro strength must be proportional to the bond
strength: the least-squares line through 0.1, 0.5, 1 and 2 MPa has R² ≥ 0.98 (the issue's
bar; measured 1.0000 for the three tests).

Modulus: for a network of bonds of normal stiffness ``k_N = K w`` and shear stiffness ``k_S``,
the affine (Voigt) estimate is ``E_2D = (C11 C22 - C12²) / C22`` of the bond tensor
(:func:`~siku_plugins.lab.affine_moduli`): an upper bound for the relaxed network when the
block may contract freely across the load; the glued handles stop that contraction near the
ends, which raises the bound towards ``C11`` (3.6 % above ``E_2D`` here). The measured modulus
therefore lies below ``C11``; non-affine relaxation of the disordered packing lowers it below
``E_2D`` by a few per cent at most (measured: +0.8 %, the end constraint winning), and the test
allows 5 %.
"""
from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest

from siku_core.run.cli import main
from siku_core.contact_law import BREAK_SHEAR
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_plugins.lab import affine_moduli, measure, virtual_test
from siku_plugins.lab import strength_table

ROOT = Path(__file__).resolve().parents[1]
STRENGTHS = [0.1e6, 0.5e6, 1.0e6, 2.0e6]


@pytest.mark.parametrize("test", ["tension", pytest.param("compression", marks=pytest.mark.slow),
                                  pytest.param("flexure", marks=pytest.mark.slow)])
def test_macro_strength_is_linear_in_bond_strength(test):
    """Four bond strengths per test: a study of a dozen virtual tests, so compression and
    flexure are long validation runs (``-m slow``); tension stays in the default run."""
    tab = strength_table(test, STRENGTHS, element_size=1.0, seed=1,
                         length=18.0 if test != "flexure" else 24.0,
                         width=9.0 if test != "flexure" else 6.0)
    assert tab.r2 >= 0.98, "\n".join(tab.rows())
    for r in tab.results:
        assert sum(r.broken.values()) > 0, f"{test} at {r.sigma_crit:g} Pa: nothing broke"
    if test == "tension":
        assert all(r.broken.get("tension", 0) > r.broken.get("shear", 0) for r in tab.results)


def test_tension_modulus_against_the_affine_estimate_of_the_packing():
    r = virtual_test("tension", 1e6, element_size=1.0, seed=2)
    assert 0.95 * r.affine_modulus <= r.modulus <= r.affine_c11, (
        f"E = {r.modulus:.4g} Pa, affine E_2D = {r.affine_modulus:.4g}, C11 = {r.affine_c11:.4g}")
    # the isotropic value of the affine estimate for k_S / k_N = 1 / 2.6: 0.818 E
    assert r.affine_modulus == pytest.approx(0.818e9, rel=0.05)


def test_ignoring_touching_keeps_the_virtual_tension_test():
    """``contact.touching = "ignore"``: the bonds carry the load and the touching neighbours'
    contact forces go (elastic part below 1e-9 of a full overlap, damping proportional to the
    slow loading rate), so modulus and strength stay within 1e-4, far inside the 5 % the
    modulus is held to above (measured: 3e-6 and 2e-6, python -m bench.touching)."""
    exact = virtual_test("tension", 1e6, element_size=1.0, seed=2)
    fast = virtual_test("tension", 1e6, element_size=1.0, seed=2, touching="ignore")
    assert fast.modulus == pytest.approx(exact.modulus, rel=1e-4)
    assert fast.strength == pytest.approx(exact.strength, rel=1e-4)
    assert sum(fast.broken.values()) > 0


def test_bonds_alone_make_compression_as_stiff_as_tension():
    """``contact.jointed = "exclude"``: the block is its bond network alone, linear and the
    same in compression as in tension, so the compression modulus obeys the tension test's
    bounds above (``0.95 E_2D`` to ``C11``). Under the report's rule (``"collide"``) every
    pressed pair of neighbours also pushes through the collision law, whose stiffness per
    depth ``K w`` equals the bond's normal stiffness: compression is stiffer than ``C11``
    (measured 1.72 ``E_2D``), and at most twice it (each pair's normal stiffness at most
    doubles; shear stiffness does not). Measured: 1.018 ``E_2D`` under ``"exclude"``."""
    bond = virtual_test("compression", 1e6, element_size=1.0, seed=2, jointed="exclude")
    assert 0.95 * bond.affine_modulus <= bond.modulus <= bond.affine_c11, (
        f"E = {bond.modulus:.4g} Pa, E_2D = {bond.affine_modulus:.4g}, "
        f"C11 = {bond.affine_c11:.4g}")
    both = virtual_test("compression", 1e6, element_size=1.0, seed=2)
    assert both.affine_c11 < both.modulus <= 2.0 * both.affine_c11
    assert sum(bond.broken.values()) > 0 and sum(both.broken.values()) > 0


def with_law(text: str, law: str) -> str:
    new, n = re.subn(r'^law = "[a-z_]+"', f'law = "{law}"', text, count=1, flags=re.MULTILINE)
    assert n == 1
    return new


def test_same_pull_scene_three_laws():
    """``examples/bonded_pull.toml`` with only ``law = ...`` changed. Documented expectations
    (docs/explanation/lab.md §4):

    * stiffness: all three laws give a bond the normal stiffness ``K w``, but the spring's is
      isotropic (shear stiffness ``K w`` too) while the bond's and the Mohr–Coulomb joint's shear
      stiffness is ``K w / (2 (1 + nu))``: the spring block is stiffer by the ratio of the affine
      moduli of the packing for the two shear ratios (1.26 here), within 5 %; Mohr–Coulomb
      and bonded particles agree within 3 %;
    * strength: at the defaults the Mohr–Coulomb joints (pure-shear strength tan 15° × 128.5
      kPa = 34 kPa) fail in shear at a macro stress of about 50 kPa, where the bonds (1 MPa)
      and the springs (strain 2e-4, about 200 kPa) all hold: every joint that breaks up to the
      peak stress breaks in shear. After the peak the cascade redistributes stress and a joint
      may open in tension; which ones do depends on round-off (changes of 1e-15 in the joint
      forces and 1e-13 in the element geometry turned one of 57 into a tension break, after the
      peak), so only the share is asserted there.
    """
    text = (ROOT / "examples" / "bonded_pull.toml").read_text()
    res, sims = {}, {}
    for law in ("bonded_particle", "distributed_spring", "mohr_coulomb"):
        sim = sims[law] = Simulation(scene_from_text(with_law(text, law)), out=False,
                                     progress=False)
        if law == "bonded_particle":
            e_bond = affine_moduli(sim)[0]
            e_spring = affine_moduli(sim, shear_ratio=1.0)[0]
        res[law] = measure(sim)
    bp, ds, mc = (res[k] for k in ("bonded_particle", "distributed_spring", "mohr_coulomb"))
    assert ds.modulus / bp.modulus == pytest.approx(e_spring / e_bond, rel=0.05)
    assert mc.modulus == pytest.approx(bp.modulus, rel=0.03)
    assert not bp.broken and not ds.broken
    cm = sims["mohr_coulomb"].contacts
    broke = ~cm.intact
    t_peak = (int(np.argmax(mc.stress)) + 1) * mc.dt  # the peak's force evaluation ends then
    before = broke & (cm.break_time <= t_peak)
    assert before.sum() >= 10  # failure began before the peak
    assert np.all(cm.break_mode[before] == BREAK_SHEAR)
    assert mc.broken.get("shear", 0) >= 0.9 * broke.sum()


def test_lab_command_writes_table_and_picture(tmp_path, capsys):
    assert main(["lab", "tension", "--strength", "0.5,1", "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr()
    assert "linear fit" in out.out and "R²" in out.out
    assert (tmp_path / "siku_lab_tension.png").stat().st_size > 10_000
    assert main(["lab", "tension", "--strength", "a,b"]) == 2
    assert "--strength" in capsys.readouterr().err


def test_a_smaller_element_size_refines_the_same_block(monkeypatch):
    """``siku lab --element-size D``: the block keeps its size in metres (24 m × 12 m; flexure
    30 m × 8 m, or ``--length``/``--width``), so halving ``D`` quadruples the elements; the
    tables are run with those sizes."""
    import siku_plugins.lab as lab

    seen = []

    def fake_table(test, strengths, **kw):
        seen.append((test, kw["element_size"], kw["length"], kw["width"]))
        raise SystemExit(0)

    monkeypatch.setattr(lab, "strength_table", fake_table)
    for D in (1.0, 0.5):
        with pytest.raises(SystemExit):
            main(["lab", "flexure", "--strength", "1", "--element-size", str(D)])
    assert seen == [("flexure", 1.0, 30.0, 8.0), ("flexure", 0.5, 30.0, 8.0)]
    with pytest.raises(SystemExit):
        main(["lab", "tension", "--strength", "1", "--element-size", "0.25", "--length", "10"])
    assert seen[-1] == ("tension", 0.25, 10.0, 12.0)
    assert main(["lab", "tension", "--strength", "1", "--element-size", "5"]) == 2


def test_lab_packings_runs_each_seed_and_reports_the_spread(monkeypatch, capsys):
    """``siku lab TEST --packings N --seed S``: the test on the packings of seeds S … S + N − 1
    at each strength, and the ratios' mean and sample standard deviation."""
    import siku_plugins.lab as lab

    seen = []

    def fake_test(test, sigma, seed, **kw):
        seen.append((test, sigma, seed, kw["length"], kw["width"]))
        return lab.LabResult(test, sigma, sigma, 1.0, np.zeros(1), np.zeros(1), 1e9,
                             sigma * (0.6 + 0.05 * seed), 1e-3)

    monkeypatch.setattr(lab, "virtual_test", fake_test)
    assert main(["lab", "tension", "--strength", "1", "--packings", "3", "--seed", "2"]) == 0
    assert seen == [("tension", 1e6, s, 24.0, 12.0) for s in (2, 3, 4)]
    out = capsys.readouterr().out
    ratios = 0.6 + 0.05 * np.arange(2, 5)
    assert "over 3 packings (seeds 2, 3, 4)" in out
    assert f"mean {ratios.mean():.3f}, standard deviation {ratios.std(ddof=1):.3f}" in out
    assert main(["lab", "tension", "--packings", "0"]) == 2
    assert "--packings" in capsys.readouterr().err


# ------------------------------------------------------------------ calibration
SMALL = {"tension": (18.0, 9.0), "compression": (18.0, 9.0), "flexure": (24.0, 6.0)}


def test_calibration_puts_every_macro_strength_in_its_range():
    """``siku lab calibrate``: the macro strengths are proportional to the bond strength
    (``test_macro_strength_is_linear_in_bond_strength``), so the bond strength chosen from one
    run per test puts each test, run again at it, inside its wanted range, with the same ratio
    macro / bond to the 0.1 % the lines depart from proportionality (1 % asserted)."""
    from siku_plugins.lab import calibrate

    ranges = {"tension": (0.2e6, 0.8e6), "compression": (0.5e6, 3.0e6),
              "flexure": (0.3e6, 1.5e6)}
    cal = calibrate(ranges, 1e6, sizes=SMALL, element_size=1.0, seed=1)
    assert cal.low <= cal.bond <= cal.high
    assert cal.bond == pytest.approx(math.sqrt(cal.low * cal.high), rel=1e-12)
    for t, (lo, hi) in ranges.items():
        assert lo <= cal.check[t] <= hi, "\n".join(cal.rows())
        assert cal.check[t] / cal.bond == pytest.approx(cal.ratios[t], rel=0.01)
    # the feasible interval is set by the tightest ends: each end meets its own range exactly
    lows = [lo / cal.ratios[t] for t, (lo, _) in ranges.items()]
    highs = [hi / cal.ratios[t] for t, (_, hi) in ranges.items()]
    assert (cal.low, cal.high) == (max(lows), min(highs))


def test_calibration_names_the_conflicting_tests():
    from siku_plugins.lab import feasible_bonds

    ratios = {"tension": 0.7, "compression": 2.08, "flexure": 1.29}
    low, high, t_lo, t_hi = feasible_bonds(
        {"tension": (0.2e6, 0.8e6), "compression": (2.0e6, 4.0e6), "flexure": (0.3e6, 0.8e6)},
        ratios)
    assert low > high and (t_lo, t_hi) == ("compression", "flexure")
    assert low == pytest.approx(2.0e6 / 2.08) and high == pytest.approx(0.8e6 / 1.29)


@pytest.mark.parametrize("args, key", [
    (["--tension", "0.8"], "--tension"), (["--flexure", "1:0.5"], "--flexure"),
    ([], "give at least one"), (["--tension", "0.2:0.5", "--reference", "-1"], "--reference")])
def test_lab_calibrate_refuses_bad_ranges_in_one_line(capsys, args, key):
    assert main(["lab", "calibrate", *args]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and key in err[0], err


# ------------------------------------------------------------------ compression
def test_compression_splits_the_block_along_the_load():
    """The mechanism of the compressive strength (docs/explanation/lab.md §3.1). A bond fails
    only when its opening stress ``k_n (d_n + (w/2)|theta|)`` or its shear stress ``k_s |d_s|``
    reaches its strength (eqs. 10–11); closing never breaks it. Under a uniaxial stress along
    the block, a bond's normal strain is ``eps_xx cos² phi + eps_yy sin² phi`` (``phi`` from the
    load to the bond's normal): in tension the bonds along the load open most, in compression
    only the bonds across it open (``cos² phi < nu_2 / (1 + nu_2)``, ``nu_2`` the network's
    Poisson ratio: by the lateral expansion) and the shear is largest at 45° (``cos² phi =
    1/2``). So the bonds broken up to the peak lie across the load in compression (mean
    ``cos² phi`` below the mean over all bonds of the packing) and along it in tension (above
    it): a block that splits along the load, not one crushed across it (measured 0.11 and 0.16
    against 0.51; tension 0.74). A law that broke bonds in compression would break those along
    the load first, as in tension (made to break at ``k_n (|d_n| + (w/2)|theta|)``, it gives
    0.91 and this test fails).

    And the strength is not carried by the collision law: the contacts of pressed neighbours
    (``jointed = "collide"``) push along their normals, mostly along the load, and make the
    block stiffer along it (by ``m``, measured 1.7). Were failure set by a strain along the load,
    the strength would rise by the same factor ``m``; set by the opening of the bonds across the
    load, which those contacts do not resist, it stays about the same (ratio near 1). The test
    asserts that the ratio of the strengths is nearer 1 than ``m`` (or ``1/m``) in logarithm,
    i.e. inside ``(m^-1/2, m^1/2)``: measured 0.98 here, 0.92–1.04 on four blocks; the law made to
    break in compression gives 1.68 for ``m = 1.70``."""
    size = {"element_size": 1.0, "length": 18.0, "width": 9.0, "seed": 1}
    ten = virtual_test("tension", 1e6, **size)
    both = virtual_test("compression", 1e6, **size)
    bond = virtual_test("compression", 1e6, jointed="exclude", **size)
    assert ten.peak_cos2.mean() > ten.cos2_mean, ten.peak_cos2
    for r in (both, bond):
        assert len(r.peak_modes) > 0, "nothing broke up to the peak"
        assert r.peak_cos2.mean() < r.cos2_mean, (r.peak_cos2, r.peak_modes)
    m = both.modulus / bond.modulus
    assert m ** -0.5 < both.strength / bond.strength < m ** 0.5, (both.strength, bond.strength, m)
