"""Built-in contact laws (rheologies): collision, distributed_spring, mohr_coulomb,
bonded_particle, ridging.

One module per law (``collision``, ``spring``, ``mohr_coulomb``, ``bonded_particle``,
``ridging``); this
package registers them and offers their public names.

docs/explanation/physics.md §4.3. Each law is an ``@njit`` evaluator of one contact; the engine's
loops in :mod:`siku_core.contact.contact_forces` call it (the contract, layouts of ``g`` and sign
conventions are
in :mod:`siku_core.contact_law`: forces and couples returned act on element ``j``, in ``i``'s
frame). Each law declares the entries of its parameter vectors once, as a
:class:`~siku_core.contact_law.ParameterRecord`; its evaluator reads them by name through the
record's index (``pars[CP.damping_ratio]``). Every law collides overlapping elements with the
collision evaluator; joint laws add their joint evaluator for intact frozen joints, and a broken
joint continues as a collision contact.
"""
from __future__ import annotations

from siku_core import hookimpl

from .bonded_particle import (
    BOND_RECORD,
    BondedParticle,
    bond_rotation,
    bonded_particle_energy,
    bonded_particle_evaluator,
)
from .collision import COLLISION_RECORD, Collision, collision_evaluator
from .mohr_coulomb import MOHR_COULOMB_RECORD, MohrCoulomb, mohr_coulomb_evaluator
from .ridging import RIDGING_RECORD, Ridging, ridging_evaluator
from .spring import SPRING_RECORD, DistributedSpring, spring_energy, spring_evaluator

__all__ = [
    "BOND_RECORD", "COLLISION_RECORD", "MOHR_COULOMB_RECORD", "RIDGING_RECORD", "SPRING_RECORD",
    "BondedParticle", "Ridging", "ridging_evaluator",
    "Collision", "DistributedSpring", "MohrCoulomb", "bond_rotation", "bonded_particle_energy",
    "bonded_particle_evaluator", "collision_evaluator", "mohr_coulomb_evaluator", "spring_energy",
    "spring_evaluator", "siku_register_contact_laws",
]


@hookimpl
def siku_register_contact_laws():
    return [Collision, DistributedSpring, MohrCoulomb, BondedParticle, Ridging]
