"""Added mass and radiation damping of a floe small against the wavelength (the long-wave
limit), at one frequency, without a boundary-element solve.

A floe of waterplane area ``A`` [m²], second moments ``J_k`` [m⁴] about its principal axes,
thin (draft ``d`` small against its width), is taken as the disc of the same area, radius
``a = sqrt(A / pi)``, on the surface of deep water. For a wave of angular frequency ``omega``
[rad/s] and wavenumber ``k`` (``omega² = g k tanh(k H)``, ``K = omega² / g`` in deep water)
with ``K a`` small:

* **Added mass** (the low-frequency limit). As ``omega -> 0`` the free-surface condition
  ``-omega² phi + g phi_z = 0`` becomes ``phi_z = 0`` outside the floe: the floe's bottom is a
  piston in a rigid baffle, ``phi = -(1 / 2 pi) ∫ v_n dS' / R``, whose added mass is
  ``(rho / 2 pi) ∫∫ n n' / R dS dS'``. For the disc (with the Fourier transform of the disc
  and ``∫_0^∞ J_nu(t)² t^-2 dt``, Gradshteyn & Ryzhik 6.574.2):

      A33 = (8/3) rho a³ = 0.4789 rho A^{3/2}     (the piston in a rigid wall; Rayleigh 1896)
      A_k = (4/15) rho a⁵ = (16 / 15 pi) rho a J_k  (the rocking piston, J_k = pi a⁴ / 4)

  (a square's baffled piston: 0.4732 rho A^{3/2}, 1.2 % below the disc's). Capytaine gives
  0.45–0.47 rho A^{3/2} and 0.25–0.26 rho a⁵ for boxes 2 m and 10 m wide at ``K a`` below
  0.2 (the boxes' draft and their corners).
* **Radiation damping**, from the Haskind relation ``B_jj = k / (8 pi rho g c_g) ∫ |X_j(θ)|²
  dθ`` (Newman 1977, ch. 6), with the long-wave exciting force of a small body, the
  hydrostatic load less the inertia of the displaced water and the added mass accelerated by
  the wave, ``X_j = C_j - omega² (M_j + A_j)`` times the wave's heave (``a``) or slope
  (``i k a cos θ``): ``X = C (1 - omega² / omega_j²)`` with ``omega_j² = C_j / (M_j + A_j)``
  the mode's natural frequency (a floating floe's mass is the displaced water's). With
  ``C_3 = rho g A``, and the slope's moment ``rho g k J_k cos θ``:

      B33 = rho g k A² / (4 c_g) (1 - omega² / omega_3²)²     -> rho omega³ A² / (2 g)
      B_k = rho g k³ J_k² / (8 c_g) (1 - omega² / omega_k²)²  -> rho omega⁷ J_k² / (4 g³)

  (arrows: deep water, ``c_g = g / 2 omega``). The heave damping rises as ``omega³``, the tilts'
  as ``omega⁷``: a floe small against the wavelength radiates almost nothing, which is why a
  damping ratio fitted at a floe's natural frequency (``K a`` about 1.2 for any thin floe,
  ``omega_3² = g / (d + 0.85 a)``) overstates the damping of long waves by orders of
  magnitude.

The error is of second order in ``K a``: the terms left out are the variation of the wave's
pressure across the floe (``(K a)² / 8`` for the disc), its diffraction and the ``K a log K
a`` dependence of the added mass. Measured against capytaine for a 2 m × 2 m × 0.3 m box
(``tests/test_floating_small_body.py``): the heave damping within 0.7 %, 1.5 %, 4 % and 25 %
at ``K a`` = 0.045, 0.10, 0.18 and 0.41, about ``1.5 (K a)²``. Capytaine's tilt damping is
1.1–1.2 times the formula's at ``K a`` below 0.2 (the tilts' share of the radiated power is
``(K a)⁴ / 32`` of the heave's in a wave, negligible where the approximation holds).

:data:`KA_MAX` bounds where it is used: an element with ``K a`` above it (a floe not small
against the wave) keeps the scene's damping ratios, which were fitted at the natural
frequency, where ``K a`` is about 1 (``siku_plugins.floating.process``).
"""
from __future__ import annotations

import math

import numpy as np

#: the largest ``K a`` at which the approximation is used (its heave damping then within
#: about 40 % of capytaine's, ``1.5 (K a)²``)
KA_MAX = 0.5
#: ``A33 / (rho A^{3/2})`` and ``A_k / (rho sqrt(A) J_k)`` of the disc (module docstring)
HEAVE_ADDED_MASS = 8.0 / (3.0 * math.pi ** 1.5)
TILT_ADDED_INERTIA = 16.0 / (15.0 * math.pi ** 1.5)


def wavenumber(omega: float, g: float, depth: float) -> tuple[float, float]:
    """``(k [1/m], c_g [m/s])`` of ``omega`` [rad/s] in water of ``depth`` [m] (``inf``: deep)."""
    k = omega * omega / g
    if not math.isfinite(depth):
        return k, g / (2.0 * omega)
    for _ in range(100):   # Newton on omega² - g k tanh(k H)
        t = math.tanh(k * depth)
        f = g * k * t - omega * omega
        k_new = k - f / (g * t + g * k * depth * (1.0 - t * t))
        if abs(k_new - k) <= 1e-14 * k:
            k = k_new
            break
        k = k_new
    kh = k * depth
    cg = (omega / k) * (0.5 + (kh / math.sinh(2.0 * kh) if kh < 350.0 else 0.0))
    return k, cg


def coefficients(A, J1, J2, M3, M1, M2, C3, C1, C2, omega: float, rho: float, g: float,
                 depth: float = math.inf):
    """``(A33, B33, A1, B1, A2, B2, ka)`` arrays of the long-wave approximation (module
    docstring) at ``omega`` [rad/s]: ``A`` [m²], ``J_k`` [m⁴], the modes' masses without added
    mass ``M3`` [kg], ``M_k`` [kg m²] and stiffnesses ``C3`` [N/m], ``C_k`` [N m]; ``ka`` is
    ``k a`` of each element (compare with :data:`KA_MAX`)."""
    A = np.asarray(A, dtype=float)
    k, cg = wavenumber(float(omega), g, depth)
    w2 = float(omega) ** 2
    A33 = HEAVE_ADDED_MASS * rho * A ** 1.5
    A1 = TILT_ADDED_INERTIA * rho * np.sqrt(A) * J1
    A2 = TILT_ADDED_INERTIA * rho * np.sqrt(A) * J2
    with np.errstate(divide="ignore", invalid="ignore"):
        x3 = 1.0 - w2 * (M3 + A33) / C3
        x1 = 1.0 - w2 * (M1 + A1) / C1
        x2 = 1.0 - w2 * (M2 + A2) / C2
    B33 = rho * g * k * A * A / (4.0 * cg) * x3 * x3
    B1 = rho * g * k ** 3 * J1 * J1 / (8.0 * cg) * x1 * x1
    B2 = rho * g * k ** 3 * J2 * J2 / (8.0 * cg) * x2 * x2
    return A33, B33, A1, B1, A2, B2, k * np.sqrt(A / math.pi)
