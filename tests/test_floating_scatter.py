"""Reflection and transmission by free-floating floes from capytaine's multi-body diffraction
(siku_plugins.floating.scatter, the optional extra siku[hydro]): energy is conserved by the
lossless floes (optical theorem: the power taken from the forward wave equals the power
scattered) to the accuracy of the panels, a floe short beside the wave lets it through, and the
results are cached."""
from __future__ import annotations

import math

import pytest

pytest.importorskip("capytaine")

from siku_plugins.floating import scatter  # noqa: E402

G = 9.81
SIZE = 8.0   # panels [m]
TWO = [(91.0, 91.0, 50.0, 0.0), (64.0, 64.0, 150.0, 30.0)]   # two floes, 1 m thick


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return str(tmp_path_factory.mktemp("scatter"))


def _k(period):
    return (2 * math.pi / period) ** 2 / G


@pytest.mark.parametrize("period", [6.0, 9.0])
def test_two_free_floes_conserve_energy(period, cache):
    """Extinction width (from the forward far field) equals the scattering width (the far
    field's power over all directions): the midpoint rule over a panel of side s errs on the
    phase factor ``e^{-ik(x cos + y sin)}`` by at most (ks)²/24 in each direction, so the two
    widths agree within (ks)²/12 of the scattering. The floes do scatter: several per cent of
    their width."""
    far = scatter.solve(TWO, 1.0, period, SIZE)
    sig_s = far["sigma_back"] + far["sigma_forward"]
    assert sig_s > 0.01 * 64.0
    assert abs(far["sigma_ext"] - sig_s) <= (_k(period) * SIZE) ** 2 / 12 * sig_s
    # K_r + K_t = 1 in a flume as wide as the floes' span
    kr, kt, _ = scatter.coefficients(TWO, 1.0, period, 200.0, SIZE, cache=cache)
    assert 0.0 < kr < 1.0 and 0.0 < kt < 1.0
    assert abs(kr + kt - 1.0) <= (_k(period) * SIZE) ** 2 / 12 * sig_s / 200.0


def test_long_wave_passes_a_short_floe(cache):
    """A floe much shorter than the wave (kL = 0.41 at 30 s for 91 m) follows it: the energy
    it reflects and the energy it removes from the transmitted wave, through a flume as wide
    as the floe, are below (kL)²; and both fall as the period grows from 6 to 9 to 30 s."""
    floe = [TWO[0]]
    out = [scatter.coefficients(floe, 1.0, p, 91.0, SIZE, cache=cache) for p in (6.0, 9.0, 30.0)]
    kl = _k(30.0) * 91.0
    kr, kt, far = out[-1]
    assert kr < kl**2 and 1.0 - kt < kl**2
    assert out[0][0] > out[1][0] > out[2][0]
    assert 1 - out[0][1] > 1 - out[1][1] > 1 - out[2][1]
    assert far["rao"][2] == pytest.approx(1.0, abs=kl**2)   # heave follows the wave


def test_results_are_cached(tmp_path, monkeypatch):
    """The second call reads the cache file the first wrote (no capytaine solve)."""
    floe = [(30.0, 30.0, 0.0, 0.0)]
    first = scatter.coefficients(floe, 1.0, 9.0, 30.0, SIZE, cache=str(tmp_path))
    assert len(list(tmp_path.glob("scatter-*.json"))) == 1

    def boom(*a, **k):
        raise AssertionError("solved again")

    monkeypatch.setattr(scatter, "solve", boom)
    assert scatter.coefficients(floe, 1.0, 9.0, 30.0, SIZE, cache=str(tmp_path)) == first
