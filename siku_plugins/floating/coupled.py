"""The incident wave of the ``floating`` process from a coupled wave model (``wave =
"exchange"``): its sea surface elevation and, where it gives it, the dynamic pressure on the
ice bottom, set through the BMI (``siku_io.coupling.bmi``: ``sea_water_surface__elevation``,
``sea_ice_bottom_surface__dynamic_pressure``) on the exchange grid
(``siku_forcing.gridded.exchange``).

The Froude–Krylov head on an element's bottom is ``eta_d = p / (rho_w g)``, ``p`` the cell's
dynamic pressure (the pressure in excess of the still-water hydrostatic one at the bottom, as
Orzech et al. (the coupled NHWAVE–LIGGGHTS wave–ice model) eq. 14: ``P_dyn = P_NH + rho_w g
eta``), once the coupled model has set the pressure; before, the cell's elevation ``eta``
(the pressure of a wave long beside the draft ``d``: ``e^{-kd} = 1 - kd``). Over the element
it is the plane of the cells' mean and gradient: with ``frac_ec`` the share of element ``e``'s
area in cell ``c`` (the exchange's overlap, refreshed at every exchange)

    eta_e = sum_c frac_ec eta_d,c,    grad_e = sum_c frac_ec grad eta_d,c

(``grad`` by ``siku_forcing.gridded.exchange.cell_gradient``, turned from the grid's axes to east
and north and then to the element's principal axes ``u, v``), so that the loads are

    ∫ eta_d dA = A eta_e,   ∫ u eta_d dA = J_1 (grad_e · u),   ∫ v eta_d dA = J_2 (grad_e · v)

(``J_k`` the waterplane's principal second moments), held through the engine's step (the BMI
sets the fields between steps) and added to those of a wave field, if any.
"""
from __future__ import annotations

import numpy as np


def exchange_load(bodies, ctx, ex) -> np.ndarray:
    """``(n, 3)`` loads of the module docstring for the floating elements ``bodies``
    (``siku_plugins.floating.kernels.FloatingBodies``) from the exchange source ``ex``."""
    from siku_forcing.gridded.exchange import cell_gradient

    from .kernels import centres_and_frames

    n = ctx.state.n
    fields = ex.fields
    if "pressure" in getattr(ex, "given", ()):
        head = fields["pressure"] / bodies.rho_g
    else:
        head = fields["eta"]
    gx, gy = cell_gradient(ex.grid, head)
    el, cell, frac, ca, sa = ex.pairs
    hc, gxc, gyc = head.ravel()[cell], gx.ravel()[cell], gy.ravel()[cell]
    eta = np.bincount(el, frac * hc, n)
    ge = np.bincount(el, frac * (gxc * ca - gyc * sa), n)     # grid axes -> east, north
    gn = np.bincount(el, frac * (gxc * sa + gyc * ca), n)
    _, _, e0, e1 = centres_and_frames(ctx.state.q)
    gl_x = ge * e0 - gn * e1                                 # the element's local axes
    gl_y = ge * e1 + gn * e0
    c, s = bodies.cphi, bodies.sphi
    out = np.column_stack([bodies.area * eta, bodies.J1 * (gl_x * c + gl_y * s),
                           bodies.J2 * (-gl_x * s + gl_y * c)])
    out[~bodies.free] = 0.0
    return np.ascontiguousarray(out)
