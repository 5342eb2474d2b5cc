"""The vertical three-point bending test of a bonded beam (``siku_plugins.lab_bending``, the
flexural test of Orzech et al. (the coupled NHWAVE–LIGGGHTS wave–ice model) §3a, with the bonds
that bend of the ``floating`` process) gives the modulus and the flexural strength of the
bonds' law within the bounds of beam theory.

Beam theory: a simply supported beam of span L, width b and depth h under a central force F
deflects ``delta = F L³ / (48 E I)``, ``I = b h³ / 12``, and its outer fibre under the load
carries ``sigma = 3 F L / (2 b h²)``. The bonds are cubic Hermite beams of rigidity ``E h³ w /
(12 (1 - nu²))``, exact for nodal loads, so the macro modulus is ``E / (1 - nu²)`` to the
solver's rounding (the stiffness's condition number is about ``(L / a)^4``: 1e-8 allowed);
the first joints lie ``a / 2`` from the load, where the moment is ``F (L - a) / 4``, so the
macro strength lies in ``[sigma_crit, sigma_crit L / (L - a)]`` and the ``2 ny`` joints beside
the load break first.
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_plugins.lab_bending import vertical_flexure


@pytest.mark.parametrize("sigma,a,length,width,nu", [
    (1e6, 1.0, 30.0, 2.0, 0.3), (0.25e6, 2.0, 40.0, 6.0, 0.0), (2e6, 1.0, 12.0, 1.0, 0.33)])
def test_modulus_and_strength_within_beam_theory(sigma, a, length, width, nu):
    r = vertical_flexure(sigma, element_size=a, length=length, width=width, E=2e9, nu=nu)
    assert r.span == pytest.approx(length - (0 if round(length / a) % 2 else a), abs=a)
    assert r.modulus == pytest.approx(2e9 / (1 - nu**2), rel=1e-8)
    lo, hi = r.strength_bounds
    assert lo * (1 - 1e-9) <= r.strength <= hi * (1 + 1e-9)
    assert len(r.broken_at) == 2 * round(width / a)
    np.testing.assert_allclose(r.broken_at, a / 2)


def test_siku_lab_flexure_prints_the_vertical_test(monkeypatch, capsys, tmp_path):
    """``siku lab flexure`` prints, after the in-plane table, the vertical test per strength."""
    import siku_plugins.lab as rep
    from siku_core.run.cli import main

    class Table:
        def rows(self):
            return ["in-plane"]

    monkeypatch.setattr(rep, "strength_table", lambda *a, **k: Table())
    monkeypatch.setattr(rep, "plot_curves", lambda tables, out: out)
    assert main(["lab", "flexure", "--strength", "0.5,1", "--out-dir", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert out.count("vertical three-point bending") == 2
    hi = 0.5 * 30 / 29           # sigma_crit L / (L - a), default span 30 m, 1 m elements
    assert f"macro strength {hi:.4f} MPa (beam theory 0.5000–{hi:.4f})" in out


def test_siku_lab_flexure_with_half_metre_elements_bends_a_thinner_beam(monkeypatch, capsys,
                                                                        tmp_path):
    """``--element-size 0.5`` (offered in lab.md): 0.5 m elements 1 m thick would capsize
    alone, so the vertical beam is 0.5 m thick; beam theory bounds its strength by
    ``sigma_crit L / (L - a)`` and its modulus is ``E / (1 - nu²)`` whatever the thickness."""
    import siku_plugins.lab_report as rep
    from siku_core.run.cli import main

    class Table:
        def rows(self):
            return ["in-plane"]

    monkeypatch.setattr(rep, "strength_table", lambda *a, **k: Table())
    monkeypatch.setattr(rep, "plot_curves", lambda tables, out: out)
    assert main(["lab", "flexure", "--strength", "1", "--element-size", "0.5", "--out-dir",
                 str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "0.5 m thick, elements 0.5 m" in out
    hi = 30 / 29.5
    assert f"macro strength {hi:.4f} MPa (beam theory 1.0000–{hi:.4f})" in out
    assert "modulus 1.0989 GPa" in out
