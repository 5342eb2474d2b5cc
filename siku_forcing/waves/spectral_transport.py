"""The energy balance of a wave spectrum on a regular grid (``siku_forcing.waves.spectral``).

For every component ``j`` (a frequency and direction bin) the variance ``E_j`` [m²] held in the
bin (``E_j = S(f_j) D(theta_j) Δf Δθ``, amplitude ``a_j = sqrt(2 E_j)``) obeys

    ∂E_j/∂t + ∇·(c_g,j E_j) = S_ice,j = -2 c_g,j k_i,j C E_j

with the group velocity ``c_g,j`` [m/s] along the bin's direction of travel, the amplitude
attenuation rate ``k_i`` [1/m] of an attenuation law and the ice concentration ``C`` of the cell.
There is no wind input, no nonlinear transfer, no whitecapping, no refraction and no scattering
into other directions: energy only travels in straight lines at ``c_g`` and is absorbed where
there is ice.

Numerics (one step ``dt``):

1. transport in flux form, first-order upwind, both directions at once:
   ``E_i ← E_i - dt/dx (F_{i+1/2} - F_{i-1/2}) - dt/dy (G_{j+1/2} - G_{j-1/2})`` with
   ``F_{i+1/2} = max(c_x, 0) E_i + min(c_x, 0) E_{i+1}``. Stable and positive for
   ``dt (|c_x|/dx + |c_y|/dy) <= 1``. The faces on the domain's edge carry nothing in a
   closed domain (energy is conserved to round-off); in an open one, energy leaves freely and
   the components travelling inward carry the incident spectrum ``E_in`` in;
2. absorption, integrated exactly over the step: ``E ← E exp(-2 c_g k_i C dt)``.

With uniform ice, one component along ``x`` and Courant number ``c dt/dx = 1`` the steady state
is exactly ``E_i = E_in exp(-2 k_i C x_i)`` with ``x_i = (i + 1) dx`` (the downstream face of
cell ``i``, from the upstream edge); for any Courant number ``nu`` it is the geometric sequence
``E_i = r^(i+1) E_in``, ``r = nu e / (1 - (1 - nu) e)``, ``e = exp(-2 c k_i C dt)``, whose
logarithm is ``-2 k_i C dx`` to first order.
"""
from __future__ import annotations

import numpy as np


def courant(cx, cy, dx: float, dy: float, dt: float) -> float:
    """Largest ``dt (|c_x|/dx + |c_y|/dy)`` over the components (stable when <= 1)."""
    return float(np.max(dt * (np.abs(cx) / dx + np.abs(cy) / dy)))


def transport(E, cx, cy, dx: float, dy: float, dt: float, closed: bool, E_in=None):
    """One upwind step of ``E`` (``(n_comp, ny, nx)`` [m²]) with velocities ``cx``, ``cy``
    (``(n_comp,)`` [m/s]); ``E_in`` (``(n_comp,)`` [m²]) enters across the open edges.
    Returns the new ``E`` and the energy that crossed the edges into the domain this step,
    per component [m² · m²] (variance times area; negative: it left)."""
    nc, ny, nx = E.shape
    cxp, cxm = np.maximum(cx, 0.0)[:, None, None], np.minimum(cx, 0.0)[:, None, None]
    cyp, cym = np.maximum(cy, 0.0)[:, None, None], np.minimum(cy, 0.0)[:, None, None]
    F = np.zeros((nc, ny, nx + 1))
    F[:, :, 1:-1] = cxp * E[:, :, :-1] + cxm * E[:, :, 1:]
    G = np.zeros((nc, ny + 1, nx))
    G[:, 1:-1, :] = cyp * E[:, :-1, :] + cym * E[:, 1:, :]
    if not closed:
        ein = np.zeros(nc) if E_in is None else np.asarray(E_in, float)
        e = ein[:, None]
        F[:, :, 0] = cxp[:, :, 0] * e + cxm[:, :, 0] * E[:, :, 0]
        F[:, :, -1] = cxp[:, :, 0] * E[:, :, -1] + cxm[:, :, 0] * e
        G[:, 0, :] = cyp[:, 0] * e + cym[:, 0] * E[:, 0, :]
        G[:, -1, :] = cyp[:, 0] * E[:, -1, :] + cym[:, 0] * e
    out = E - dt / dx * (F[:, :, 1:] - F[:, :, :-1]) - dt / dy * (G[:, 1:, :] - G[:, :-1, :])
    inflow = dt * (dy * (F[:, :, 0].sum(axis=1) - F[:, :, -1].sum(axis=1))
                   + dx * (G[:, 0, :].sum(axis=1) - G[:, -1, :].sum(axis=1)))
    return out, inflow


def absorb(E, cg, ki, C, dt: float):
    """Absorption over ``dt``: ``E exp(-2 c_g k_i C dt)``, ``cg`` ``(n_comp,)`` [m/s], ``ki``
    ``(n_comp, ny, nx)`` [1/m] (or broadcastable), ``C`` ``(ny, nx)`` [1]. Returns the new
    ``E`` and the variance absorbed per cell and component [m²]."""
    new = E * np.exp(-2.0 * cg[:, None, None] * ki * C[None] * dt)
    return new, E - new


def steady_ratio(nu: float, beta_dt: float) -> float:
    """Cell-to-cell ratio of the discrete steady state under uniform absorption (module
    docstring): ``nu e / (1 - (1 - nu) e)``, ``e = exp(-beta_dt)``."""
    e = np.exp(-beta_dt)
    return float(nu * e / (1.0 - (1.0 - nu) * e))
