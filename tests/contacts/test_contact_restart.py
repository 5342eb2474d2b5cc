"""Contact state in the HDF5 output and bit-for-bit restart (docs/explanation/physics.md §7).

A 5 × 2 jittered jointed pack at 72°N, its west column static and its east column a steady
handle pulled north-east at 1 m/s: the handle's joints break within a few steps, the others
stretch and (distributed_spring, softening from 30 % of the tensile strain) lose stiffness, or
(mohr_coulomb) lose segments. ``N`` steps, write, restart, ``N`` more must equal ``2N`` steps in
one run bit for bit, which needs the joints' intact flags and history (largest strain, failed
segments) from ``/states/history/contacts``.
"""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.run.simulation import Simulation
from siku_core.testing.contact_conformance import contact_scene, square_pack
from siku_io.output.results import last_snapshot

N = 40
DT = 0.1
PARAMS = {
    "distributed_spring": {"tensile_strain": 2e-4, "damage_onset": 0.3},
    "mohr_coulomb": {"break_share": 0.8},
}


def scene(law, jointed="collide", touching="contact"):
    pack = square_pack(30.0, 72.0, 5, 2, 2000.0, jitter=0.2, seed=7, left="static",
                       right="steady", right_velocity=[1.0, 0.3])
    return contact_scene(law, PARAMS[law], packs=[pack], dt=DT, steps=2 * N,
                         output={"every": N * DT}, jointed=jointed, touching=touching)


# under contact.jointed = "exclude" a joint that breaks adds its pair to the candidate list
# then and there; the restarted run builds the list afresh: the same contacts in the same order
@pytest.mark.parametrize("law, jointed, touching",
                         [(law, "collide", "contact") for law in PARAMS]
                         + [("distributed_spring", "exclude", "contact"),
                            ("distributed_spring", "collide", "ignore")])
def test_restart_after_joints_broke_continues_bit_for_bit(tmp_path, law, jointed, touching):
    sc = scene(law, jointed, touching)
    whole = Simulation(sc, out=False, progress=False).run()
    assert whole.step_index == 2 * N

    part = tmp_path / "part.h5"
    first = Simulation(sc, out=part, progress=False).run(steps=N)
    cm = first.contacts
    assert 0 < cm.n_intact < cm.n_joints, "some joints must have broken, some not"
    assert cm.hist.any()
    last = last_snapshot(part)
    assert last["step"] == N
    g = last["history"]["contacts"]
    assert np.array_equal(g["intact"], cm.intact.astype(np.int8))
    assert np.array_equal(g["hist"], cm.hist)
    assert int(g["n_broken_total"]) == cm.n_broken_total
    hist_n = cm.hist.copy()

    second = Simulation(sc, out=part, restart=part, progress=False)
    assert second.step_index == N
    assert np.array_equal(second.contacts.intact, cm.intact)
    second.run()
    assert second.step_index == 2 * N
    for k in ("q", "V", "w"):
        a, b = getattr(second.state, k), getattr(whole.state, k)
        assert np.array_equal(a, b), f"{k} differs by up to {np.abs(a - b).max():.3e}"
    assert np.array_equal(second.contacts.intact, whole.contacts.intact)
    assert np.array_equal(second.contacts.hist, whole.contacts.hist)
    assert second.contacts.n_broken_total == whole.contacts.n_broken_total
    if law == "distributed_spring":
        # the second half did use and change the joint history (largest strains grew)
        assert not np.array_equal(whole.contacts.hist, hist_n)


def test_restart_without_joint_history_would_differ(tmp_path):
    """Control: the same restart with fresh (undamaged) joints diverges, so the bit-for-bit
    match above depends on the stored contact state."""
    law = "distributed_spring"
    sc = scene(law)
    whole = Simulation(sc, out=False, progress=False).run()
    part = tmp_path / "part.h5"
    Simulation(sc, out=part, progress=False).run(steps=N)
    second = Simulation(sc, out=part, restart=part, progress=False)
    fresh = second.contacts
    fresh.intact[:] = True
    fresh.hist[:] = 0.0
    second.run()
    assert not np.array_equal(second.state.q, whole.state.q)
