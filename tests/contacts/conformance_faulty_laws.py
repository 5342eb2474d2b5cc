"""Contact laws with planted faults, which the conformance suite must catch (each one differs
from a built-in law by the fault alone)."""
from __future__ import annotations

import numpy as np
from numba import njit

from siku_core.contact_law import G_AREA
from siku_plugins.contact_laws import (
    Collision,
    DistributedSpring,
    collision_evaluator,
    spring_energy,
    spring_evaluator,
)


@njit(cache=True)
def anti_collision(g, pars, out):
    """The collision law with the force reversed: overlapping elements attract."""
    collision_evaluator(g, pars, out)
    out[0] = -out[0]
    out[1] = -out[1]


class AntiSpring(Collision):
    """Fault: an attractive (anti-spring) collision force."""

    name = "anti_spring_test"
    collision_evaluator = anti_collision


@njit(cache=True)
def anti_joint(g, pars, hist, out):
    """The distributed spring with its force and couple reversed."""
    spring_evaluator(g, pars, hist, out)
    out[0] = -out[0]
    out[1] = -out[1]
    out[2] = -out[2]


class AntiJoint(DistributedSpring):
    """Fault: an anti-spring joint (its collisions are the built-in ones)."""

    name = "anti_joint_test"
    joint_evaluator = anti_joint


@njit(cache=True)
def counting_spring(g, pars, hist, out):
    """The distributed spring, counting its calls in ``hist[2]``."""
    spring_evaluator(g, pars, hist, out)
    hist[2] += 1.0


class CallCounter(DistributedSpring):
    """Fault: a history column that counts evaluations."""

    name = "call_counter_test"
    history_names = ("max_strain", "log_strength", "calls")
    joint_evaluator = counting_spring


@njit(cache=True)
def zero_over_zero(g, pars, out):
    """The collision law times ``A / A``: 0/0 for a contact without overlap area."""
    collision_evaluator(g, pars, out)
    r = g[G_AREA] / g[G_AREA]
    out[0] *= r
    out[1] *= r


class ZeroOverZero(Collision):
    """Fault: divides by the overlap area."""

    name = "zero_over_zero_test"
    collision_evaluator = zero_over_zero


def half_spring_energy(g, pars, hist):
    """Half the distributed spring's energy."""
    return 0.5 * spring_energy(g, pars, hist)


class WrongEnergy(DistributedSpring):
    """Fault: a declared energy whose gradient is half the force."""

    name = "wrong_energy_test"
    joint_energy = staticmethod(half_spring_energy)


@njit(cache=True)
def overflowing_spring(g, pars, hist, out):
    """The distributed spring, writing a column past its two history names."""
    spring_evaluator(g, pars, hist, out)
    hist[2] = 1.0


class Overflow(DistributedSpring):
    """Fault: writes history beyond its ``history_names``."""

    name = "overflow_test"
    joint_evaluator = overflowing_spring


FAULTY = {
    "anti_spring": (AntiSpring, "anti_spring_test: passivity: collision cycle, quasi-static: "
                                "the contact did"),
    "anti_joint": (AntiJoint, "anti_joint_test: passivity: joint cycle, quasi-static: the "
                              "contact did"),
    "call_counter": (CallCounter, "call_counter_test: history: evaluating the same joint again "
                                  "changed its history"),
    "zero_over_zero": (ZeroOverZero, "zero_over_zero_test: compiled == python: collision "
                                     "evaluator raised ZeroDivisionError"),
    "wrong_energy": (WrongEnergy, "wrong_energy_test: energy: force on j"),
    "overflow": (Overflow, "overflow_test: history: the joint evaluator wrote history "
                           "column(s) [2] beyond its 2 history_names"),
}

__all__ = ["FAULTY", "np"]
