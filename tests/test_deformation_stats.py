"""Deformation statistics (siku_io.analysis.deformation_stats) on synthetic fields with known
scaling.

* A velocity field whose increments scale as ``|du(L)| ∝ L^H`` (a fractional Brownian field,
  spectral synthesis with ``|u(k)|² ∝ k^-(2H + 2)`` in two dimensions) has box-mean gradients
  ``∝ L^(H - 1)``: ``beta = 1 - H``. Sampled on a lattice of "elements" and coarse-grained over
  boxes of 8-64 lattice spacings (an octave and more from both the lattice and the field's size),
  the tool recovers the field's ``beta`` (``1 - H`` for an infinite field; computed for this
  finite one from its spectrum) within its stated 95 % interval plus the scatter of one
  realisation, and the mean of four within their standard error.
* A uniform strain (``u = a x``, ``v = b y``) is the same at every scale and time:
  ``beta = alpha = 0`` and ``<eps> = sqrt((a + b)² + (a - b)²)`` to the strain of the
  snapshots' interval.
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_io.analysis.deformation_stats import DAY, plane_positions, statistics

N = 256  # lattice points per side
D = 5e3  # m between them


def fbm(H: float, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Two independent periodic fractional Brownian fields ``(N, N)`` of Hurst exponent ``H``
    [m/s, arbitrary scale]."""
    rng = np.random.default_rng(seed)
    k = np.fft.fftfreq(N)
    K = np.hypot(*np.meshgrid(k, k))
    K[0, 0] = np.inf
    amp = K ** (-(H + 1.0))
    out = []
    for _ in range(2):
        phase = np.exp(2j * np.pi * rng.random((N, N)))
        out.append(np.real(np.fft.ifft2(amp * phase)))
    return out[0], out[1]


def lattice():
    x, y = np.meshgrid(np.arange(N) * D, np.arange(N) * D)
    return x.ravel(), y.ravel()


def expected_beta(H: float, scales) -> float:
    """The exponent of this finite periodic field: for independent isotropic Gaussian ``u``,
    ``v`` the mean ``eps²`` of a box is ``6 <ux²>_box``, and ``<ux²>_box = sum_k |u_k|² (2 pi
    kx)² F(k)²`` with ``F`` the box mean over the hull of its lattice points (side ``L - D``):
    ``sinc(kx (L - D)) sinc(ky (L - D))``. ``<eps>`` is a fixed multiple of ``sqrt(<eps²>)``
    when the components are Gaussian, so ``beta`` is the slope of ``-log <ux²>_box / 2``
    against ``log L`` over the same scales: ``1 - H`` for an infinite field, more here because
    the field has no scales beyond ``N D``."""
    k = np.fft.fftfreq(N, d=D)
    KX, KY = np.meshgrid(k, k)
    K = np.hypot(KX, KY)
    K[0, 0] = np.inf
    p = (K * D) ** (-2 * (H + 1.0)) * (2 * np.pi * KX) ** 2
    g = [np.sum(p * (np.sinc(KX * (L - D)) * np.sinc(KY * (L - D))) ** 2) for L in scales]
    slope = np.polyfit(np.log(scales), 0.5 * np.log(g), 1)[0]
    return -slope


@pytest.mark.parametrize("H", [0.9, 0.8, 0.6])
def test_the_spatial_exponent_of_a_fractional_field_is_recovered(H):
    """Each realisation within its stated 95 % interval plus 0.03 (the scatter of one
    realisation), the mean of four within the standard error of their mean."""
    x, y = lattice()
    scales = [8 * D, 16 * D, 32 * D, 64 * D]
    want = expected_beta(H, scales)
    got = []
    for seed in range(4):
        u, v = fbm(H, seed)
        dt = 3600.0
        pos = [(x, y), (x + dt * 1e-3 * u.ravel(), y + dt * 1e-3 * v.ravel())]
        s = statistics(pos, dt, scales, steps=(1,), min_cover=0.5)
        b, ci = s.beta[0], 1.96 * s.beta_se[0]
        assert abs(b - want) <= ci + 0.03, (H, b, ci, want)
        got.append(b)
    # the mean of the realisations: within 2.5 standard errors of their scatter, plus 0.02 for
    # the approximations of the expectation (the hull for the box; <eps> for sqrt(<eps²>))
    tol = 2.5 * np.std(got, ddof=1) / np.sqrt(len(got)) + 0.02
    assert abs(np.mean(got) - want) <= tol, (H, got, want, tol)


def test_a_uniform_strain_is_the_same_at_every_scale_and_time():
    x, y = lattice()
    a, b = 2e-7, -0.5e-7  # 1/s
    dt = 60.0
    pos = [(x * (1 + a * k * dt), y * (1 + b * k * dt)) for k in range(5)]
    s = statistics(pos, dt, [8 * D, 16 * D, 32 * D], steps=(1, 2, 4))
    # in the mid positions' frame the gradient is a / (1 + a (k + n/2) dt): a to within
    # a 4 dt = 5e-5 here
    eps = np.hypot(a + b, abs(a - b))
    tol = abs(a) * 4 * dt
    np.testing.assert_allclose(s.moments[1], eps, rtol=tol)
    np.testing.assert_allclose(s.beta, 0.0, atol=tol)
    np.testing.assert_allclose(s.alpha, 0.0, atol=tol)
    assert s.active_share == (1.0 if eps * DAY > 0.01 else 0.0)


def test_the_plane_keeps_distances_from_its_centre():
    lon = np.array([-150.0, -150.0, -140.0])
    lat = np.array([75.0, 76.0, 75.0])
    x, y = plane_positions(lon, lat, -150.0, 75.0, 6371e3)
    assert x[0] == pytest.approx(0.0, abs=1e-6) and y[0] == pytest.approx(0.0, abs=1e-6)
    assert y[1] == pytest.approx(6371e3 * np.radians(1.0), rel=1e-12)
    assert x[1] == pytest.approx(0.0, abs=1e-6)
