"""Per-contact history of collision laws (``contact_history_names``,
docs/explanation/contacts.md).

A test law counts, in its contact's row, the committed evaluations (one per step) at which the
pair overlapped, and softens with that count (its force is the collision law's divided by
``1 + steps / 100``; the evaluator of tests/contacts/test_contact_history_conformance.py, whose
compiled collision loop the two files share), so the history changes the motion and a
restart that lost it would differ.
Two 2 km squares on the equator start 1 m into each other and closing at 1 m/s: their contact
lasts about ``pi / omega`` = 4 s (``omega`` = 0.74 rad/s, tests/contacts/test_v3_collision.py),
80 steps of 0.05 s, longer than any run here, which checks the pair overlaps at every step.
"""
from __future__ import annotations

import math
import types

import numpy as np
import pytest

from siku_core import hookimpl
from siku_core.contact_law import G_AREA, G_K, G_MEFF, G_NX, G_SIZE, G_WIDTH, check_contact_law
from siku_core.contact.contact_forces import contact_loops
from siku_core.errors import PluginError
from siku_core.contact.kernel_cache import instantiate
from siku_core.run.simulation import Simulation
from siku_core.testing.contact_cases import rotate_about
from siku_core.testing.contact_conformance import contact_scene
from siku_io.output.results import last_snapshot
from siku_plugins.contact_laws import Collision, collision_evaluator
from test_contact_history_conformance import aging_evaluator

R = 6_371_000.0
SIZE = 2000.0
OVERLAP = 1.0  # [m] at the start
DT = 0.05
N = 30  # steps in contact, well inside the contact's 80


class Aging(Collision):
    """Collisions that count their steps in contact and soften with them."""

    name = "contact_age_test"
    contact_history_names = ("steps",)
    collision_evaluator = aging_evaluator


@pytest.fixture
def aging(siku_register):
    mod = types.ModuleType("contact_age_plugin")
    mod.siku_register_contact_laws = hookimpl(lambda: [Aging])
    siku_register(mod)
    return Aging


def pressed(law="contact_age_test", steps=N, **kw):
    dlon = math.degrees((SIZE - OVERLAP) / R)
    return contact_scene(
        law, {"damping_ratio": 0.0},
        elements=[{"center": (-0.5 * dlon, 0.0), "velocity": (0.5, 0.0)},
                  {"center": (0.5 * dlon, 0.0), "velocity": (-0.5, 0.0)}],
        size=SIZE, dt=DT, steps=steps, **kw)


def steps_in_contact(sim, n: int) -> int:
    """Step ``n`` times; how many of them had the pair overlapping."""
    on = 0
    for _ in range(n):
        sim.step()
        on += sim.contacts.n_overlap == 1
    return on


def row(sim) -> np.ndarray:
    """The rows of the pairs in contact, as a restart reads them."""
    h = sim.contacts.history()
    assert int(h["contact_count"]) == len(h["contact_pairs"]) == len(h["contact_hist"])
    return h["contact_hist"]


def test_the_row_counts_the_steps_in_contact(aging):
    sim = Simulation(pressed(), out=False, progress=False)
    assert steps_in_contact(sim, N) == N
    h = sim.contacts.history()
    assert h["contact_pairs"].tolist() == [[0, 1]]
    assert h["contact_hist"].tolist() == [[float(N)]]


class Shuffled:
    """A broad phase that returns its pairs plus a far pair, in an order reversed at every
    call: each rebuild puts the pair in contact elsewhere in the list."""

    def __init__(self, broad):
        self.broad = broad
        self.calls = 0

    def pairs(self, centers, radii, skip):
        p = [tuple(x) for x in self.broad.pairs(centers, radii, skip)] + [(2, 3)]
        self.calls += 1
        return np.array(p[::-1] if self.calls % 2 else p, dtype=np.int64)


def test_the_row_survives_rebuilds_that_reorder_the_candidates(aging):
    dlon = math.degrees((SIZE - OVERLAP) / R)
    far = math.degrees(20 * SIZE / R)
    sc = contact_scene(
        "contact_age_test", {"damping_ratio": 0.0},
        elements=[{"center": (-0.5 * dlon, 0.0), "velocity": (0.5, 0.0)},
                  {"center": (0.5 * dlon, 0.0), "velocity": (-0.5, 0.0)},
                  {"center": (far, 0.0)}, {"center": (2 * far, 0.0)}],
        size=SIZE, dt=DT, steps=N)
    sim = Simulation(sc, out=False, progress=False)
    cm = sim.contacts
    cm.broad = Shuffled(cm.broad)
    places = set()
    for _ in range(N):
        cm._ref_centers = None  # a rebuild at every step
        sim.step()
        assert cm.n_overlap == 1
        places.add(int(np.flatnonzero(cm.pair_active == 1)[0]))
    assert cm.rebuilds >= N and places == {0, 1}
    assert row(sim).tolist() == [[float(N)]]
    assert cm.chist[cm.pair_active != 1].tolist() == [[0.0]]  # the far pair's row


def shift(sim, k: int, metres: float) -> None:
    """Move element ``k`` east by ``metres`` (a turn about the polar axis)."""
    sim.state.q[k] = rotate_about(sim.state.q[k], [0.0, 0.0, 1.0], metres / R)


def test_the_row_is_reset_when_the_pair_separates_and_meets_again(aging):
    sim = Simulation(pressed(steps=3 * N), out=False, progress=False)
    cm = sim.contacts
    assert steps_in_contact(sim, 10) == 10
    assert row(sim).tolist() == [[10.0]]
    rebuilds = cm.rebuilds
    shift(sim, 1, 30.0)  # 30 m apart, within the skin: still a candidate, no rebuild
    sim.step()
    assert cm.n_overlap == 0 and cm.rebuilds == rebuilds and len(cm.pairs) == 1
    assert len(row(sim)) == 0 and not cm.chist.any()
    shift(sim, 1, -30.0)
    assert steps_in_contact(sim, 5) == 5
    assert row(sim).tolist() == [[5.0]]  # counted afresh
    # far apart: the pair leaves the candidate list; back: a new candidate, a fresh row
    shift(sim, 1, 3 * SIZE)
    sim.step()
    assert len(cm.pairs) == 0 and len(row(sim)) == 0
    shift(sim, 1, -3 * SIZE)
    assert steps_in_contact(sim, 3) == 3
    assert row(sim).tolist() == [[3.0]]


def test_restart_mid_contact_continues_bit_for_bit(aging, tmp_path):
    sc = pressed(steps=2 * N, output={"every": N * DT})
    whole = Simulation(sc, out=False, progress=False)
    assert steps_in_contact(whole, 2 * N) == 2 * N

    part = tmp_path / "part.h5"
    first = Simulation(sc, out=part, progress=False).run(steps=N)
    g = last_snapshot(part)["history"]["contacts"]
    assert int(g["contact_count"]) == 1
    assert g["contact_pairs"].tolist() == [[0, 1]]
    assert g["contact_hist"].tolist() == [[float(N)]] == row(first).tolist()

    second = Simulation(sc, out=part, restart=part, progress=False)
    assert row(second).tolist() == [[float(N)]]
    second.run()
    assert second.step_index == 2 * N
    for k in ("q", "V", "w"):
        a, b = getattr(second.state, k), getattr(whole.state, k)
        assert np.array_equal(a, b), f"{k} differs by up to {np.abs(a - b).max():.3e}"
    assert row(second).tolist() == row(whole).tolist() == [[float(2 * N)]]
    # the continued file holds both snapshots, the row of each
    g2 = last_snapshot(part)["history"]["contacts"]
    assert g2["contact_hist"].tolist() == [[float(2 * N)]]


def test_restart_without_the_rows_would_differ(aging, tmp_path):
    """Control: the same restart with the rows forgotten diverges (the softening depends on
    them), so the match above depends on the stored rows."""
    sc = pressed(steps=2 * N, output={"every": N * DT})
    whole = Simulation(sc, out=False, progress=False).run()
    part = tmp_path / "part.h5"
    Simulation(sc, out=part, progress=False).run(steps=N)
    second = Simulation(sc, out=part, restart=part, progress=False)
    keys, rows = second.contacts._chist_pending
    second.contacts._chist_pending = (keys, np.zeros_like(rows))
    second.run()
    assert not np.array_equal(second.state.V, whole.state.V)


def test_a_law_without_contact_history_allocates_nothing(tmp_path):
    sim = Simulation(pressed("collision", output={"every": N * DT}),
                     out=tmp_path / "run.h5", progress=False)
    cm = sim.contacts
    assert steps_in_contact(sim, 5) == 5
    assert cm.n_contact_hist == 0
    assert cm.chist.size == 0 and cm.pair_contact.size == 0
    assert not any(k.startswith("contact_") for k in cm.history())
    # its collision loop is the instance without the row (the branches that pass it pruned)
    assert instantiate(contact_loops, cm._cev).CHIST is False
    sim.run()
    assert not any(k.startswith("contact_")
                   for k in last_snapshot(tmp_path / "run.h5")["history"]["contacts"])


def test_a_declared_history_needs_the_evaluator_that_takes_the_row():
    class Wrong(Collision):
        name = "wrong_contact_history_test"
        contact_history_names = ("steps",)

    with pytest.raises(PluginError, match=r"collision_evaluator .* takes 3 parameters, "
                       r"expected 4: \(g, pars, hist, out\) \(contact_history_names"):
        check_contact_law(Wrong, "pkg")

    class Twice(Aging):
        name = "twice_contact_history_test"
        contact_history_names = ("steps", "steps")

    with pytest.raises(PluginError, match="contact_history_names .* names a column twice"):
        check_contact_law(Twice, "pkg")


def test_the_guide_s_law_registers_and_counts(tmp_path, monkeypatch):
    """The counting law of docs/howto/contact_laws.md, loaded as a module (numba caches only
    functions defined in a file): it passes the registration checks, and its evaluator adds
    one to the row and gives the collision law's force."""
    import importlib
    import re
    from pathlib import Path

    page = Path(__file__).resolve().parents[2] / "docs" / "howto" / "contact_laws.md"
    text = page.read_text(encoding="utf-8")
    block = next(b for b in re.findall(r"```python\n(.*?)```", text, re.S)
                 if "contact_history_names" in b)
    (tmp_path / "guide_counting_law.py").write_text(block, encoding="utf-8")
    monkeypatch.syspath_prepend(str(tmp_path))
    mod = importlib.import_module("guide_counting_law")
    law = mod.CountingCollision
    assert law.contact_history_names == ("steps",)
    g = np.zeros(G_SIZE)  # 1 ha overlap, normal +x, 100 m wide, K = 5e8 Pa, 1e6 kg
    g[[G_AREA, G_NX, G_WIDTH, G_K, G_MEFF]] = [1e4, 1.0, 100.0, 5e8, 1e6]
    pars = Collision({}).collision_parameters()
    hist = np.array([2.0])
    out, ref = np.zeros(4), np.zeros(4)
    law.collision_evaluator(g, pars, hist, out)
    collision_evaluator(g, pars, ref)
    assert hist[0] == 3.0 and np.array_equal(out, ref) and out[0] > 0
