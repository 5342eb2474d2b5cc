"""The ridging law: distributed-spring joints, and collisions whose normal force is capped at a
plastic limit, so that pressed ice overlaps (and the ``ridging`` process turns the overlap into
ridged ice).

A pressure ``P`` [Pa] times the thinner side's thickness ``h = min(h_i, h_j)`` is the largest
force per unit length two floes can press on each other before the thinner one fails and piles
up (Hibler 1979: ``P* h``, ``P* = 27.5 kN/m²``; in floe-scale models, Hopkins 1994). The normal
force of the collision (eqs. 9–11, with damping) is capped at

    F_max = P h w        (w: the contact width [m])

with ``P = strength`` for ice at least ``raft_thickness`` thick and ``P = raft_strength`` for
thinner ice, which rafts (one sheet slides over the other) rather than ridges (Parmerter 1975:
below about 0.17 m). Joints are those of ``distributed_spring``.

References: Hibler, W. D. (1979), A dynamic thermodynamic sea ice model, J. Phys. Oceanogr. 9,
815–846. Hopkins, M. A. (1994), On the ridging of intact lead ice, J. Geophys. Res. 99(C8),
16351–16360. Parmerter, R. R. (1975), A model of simple rafting in sea ice, J. Geophys. Res.
80(15), 1948–1952.
"""
from __future__ import annotations

from numba import njit

from siku_core import Param
from siku_core.contact_law import G_HI, G_HJ, G_WIDTH, ParameterRecord

from .collision import collision_force
from .spring import DistributedSpring

#: the ridging law's collision parameter vector
RIDGING_RECORD = ParameterRecord("sqrt_area", "damping_ratio", "viscosity", "friction",
                                 "strength", "raft_thickness", "raft_strength")
RP = RIDGING_RECORD.index


@njit(cache=True, inline="always")
def plastic_limit(hi, hj, width, strength, raft_thickness, raft_strength):
    """``F_max = P h w`` [N] (module docstring)."""
    h = min(hi, hj)
    return (raft_strength if h < raft_thickness else strength) * h * width


@njit(cache=True)
def ridging_evaluator(g, pars, out):
    """Eqs. 9–11 with the normal force capped at the plastic limit ``P h w``."""
    fmax = plastic_limit(g[G_HI], g[G_HJ], g[G_WIDTH], pars[RP.strength],
                         pars[RP.raft_thickness], pars[RP.raft_strength])
    collision_force(g, pars[RP.sqrt_area], pars[RP.damping_ratio], pars[RP.viscosity],
                    pars[RP.friction], fmax, out)


class Ridging(DistributedSpring):
    """Joints of distributed springs, collisions capped at the plastic limit P h w."""

    bounded_damping = True  # (siku_core.contact.damping)
    name = "ridging"
    params = {
        **DistributedSpring.params,
        "strength": Param(2.75e4, "Pa", "ridging strength P* (plastic limit P* h per unit "
                          "contact width)", min=0),
        "raft_thickness": Param(0.17, "m", "thinner ice rafts instead of ridging", min=0),
        "raft_strength": Param(1.375e4, "Pa", "rafting strength (plastic limit of ice thinner "
                               "than raft_thickness)", min=0),
    }
    collision_evaluator = ridging_evaluator
    collision_record = RIDGING_RECORD
