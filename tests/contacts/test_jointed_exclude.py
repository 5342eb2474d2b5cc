"""``contact.jointed``: whether an intact joint's pair is also a collision contact.

``"collide"`` (the report's rule, the default) keeps every jointed pair in the candidate list;
``"exclude"`` (the bonded-particle convention: LAMMPS BPM's ``special_bonds lj 0 1 1``) leaves a
pair out while its joint holds and lets it collide once the joint breaks
(docs/explanation/contacts.md §3.1).

The physics checked here: two equal squares of side ``L`` whose shared edge is pressed in by
``delta`` (a strip ``L × delta`` of overlap). Every joint law resists with the joint's normal
stiffness ``K L`` (eq. 9's ``K``, two-point springs ``K L / 2`` each, the bond's ``k_n A = K w``
with ``w = L``, Mohr-Coulomb's ``(h E)_eff w / L0``), and the linear collision law with ``K A =
K L delta``: under ``"collide"`` the pair pushes back exactly twice as hard as under
``"exclude"``, to the relative size of the strip (the overlap centroid sits ``delta / 2``
nearer both centres than the joint midpoint, so the collision's ``K`` is ``L / (L - delta)``
times the joint's) and the projection's ``(L / R)²``; once the joint breaks the collision
alone is left, under either setting.
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.contact_law import BREAK_EXTERNAL
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import contact_scene, rotate_about, square_pack

L = 2000.0  # side of the squares [m]
DELTA = 0.2  # how far the shared edge is pressed in [m]
LAWS = ("distributed_spring", "mohr_coulomb", "bonded_particle")


def pair(law: str, jointed: str, nx: int = 2, ny: int = 1, **kw) -> Simulation:
    """``nx × ny`` squares of side ``L`` on the equator, every shared edge jointed."""
    sc = contact_scene(law, packs=[square_pack(0.0, 0.0, nx, ny, L)], jointed=jointed,
                       dt=0.01, steps=10, **kw)
    return Simulation(sc, out=False, progress=False)


def push(sim: Simulation) -> float:
    """East force [N] on the eastern square of a pair once it is moved ``DELTA`` west, at rest
    (no damping): one force evaluation of the contact phase."""
    st = sim.state
    q = st.q.copy()
    q[1] = rotate_about(q[1], [0.0, 0.0, 1.0], -DELTA / sim.radius)
    F = np.zeros((st.n, 2))
    T = np.zeros(st.n)
    sim.contacts.add(0.0, q, np.zeros((st.n, 2)), np.zeros(st.n), F, T, commit=False)
    assert F[0, 0] == pytest.approx(-F[1, 0], rel=1e-9)  # action and reaction
    return float(F[1, 0])


@pytest.mark.parametrize("law", LAWS)
def test_collide_presses_back_twice_as_hard_as_the_joint_alone(law):
    f_ex = push(pair(law, "exclude"))
    f_co = push(pair(law, "collide"))
    assert f_ex > 0.0
    # joint K L delta, collision K L delta (L / (L - delta)): the ratio is 2 + delta / L
    assert f_co / f_ex == pytest.approx(2.0 + DELTA / L, abs=1e-6)


@pytest.mark.parametrize("law", LAWS)
def test_a_broken_joint_leaves_the_collision_under_either_setting(law):
    forces = {}
    for jointed in ("collide", "exclude"):
        sim = pair(law, jointed)
        f_intact = push(sim)  # builds the candidate list
        assert sim.contacts.break_joints(np.array([0]), BREAK_EXTERNAL, 0.0) == 1
        forces[jointed] = push(sim)
        if jointed == "exclude":
            # the joint's K L delta, then the collision's K L delta L / (L - delta)
            assert forces[jointed] / f_intact == pytest.approx(1.0 + DELTA / L, abs=1e-6)
    assert forces["exclude"] == forces["collide"]


def test_exclude_leaves_exactly_the_intact_joints_out_of_the_candidates():
    """3 × 3 pack: 12 joints (shared edges), 8 corner-touching diagonal pairs. Under
    ``"exclude"`` the candidates are the diagonals; a broken joint's pair joins them at once,
    in the broad phase's order, the other candidates keeping their state; restoring the joints
    (a rollback or a restart) rebuilds the list."""
    sims = {j: pair("distributed_spring", j, 3, 3) for j in ("collide", "exclude")}
    for sim in sims.values():
        sim.step()
    cm = sims["exclude"].contacts
    every = {tuple(p) for p in sims["collide"].contacts.pairs.tolist()}
    joints = set(zip(cm.ji.tolist(), cm.jj.tolist()))
    assert len(every) == 20 and len(joints) == 12 and joints <= every
    assert {tuple(p) for p in cm.pairs.tolist()} == every - joints

    saved = cm.history()
    before = {tuple(p): (cm.pair_active[k], cm.separating_hint[k])
              for k, p in enumerate(cm.pairs.tolist())}
    k = 5
    cm.break_joints(np.array([k]), BREAK_EXTERNAL, 1.0)
    now = [tuple(p) for p in cm.pairs.tolist()]
    assert set(now) == every - joints | {(int(cm.ji[k]), int(cm.jj[k]))}
    assert now == sorted(now)
    for idx, p in enumerate(now):
        if p in before:
            assert (cm.pair_active[idx], cm.separating_hint[idx]) == before[p]
    assert len(cm.poff) == sims["exclude"].state.n + 1 and cm.poff[-1] == 2 * len(now)

    cm.set_history(saved)  # the joint holds again
    sims["exclude"].step()
    assert {tuple(p) for p in cm.pairs.tolist()} == every - joints


def test_without_joints_exclude_changes_nothing():
    """The collision law has no joints: both settings give the same run, bit for bit."""
    runs = []
    for jointed in ("collide", "exclude"):
        sc = contact_scene("collision", packs=[square_pack(0.0, 0.0, 3, 2, L, jitter=0.3,
                                                          seed=3)],
                           jointed=jointed, dt=0.05, steps=20)
        runs.append(Simulation(sc, out=False, progress=False).run())
    assert np.array_equal(runs[0].state.q, runs[1].state.q)
    assert np.array_equal(runs[0].state.V, runs[1].state.V)
