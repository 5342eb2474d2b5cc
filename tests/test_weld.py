"""Joints that processes create: the ``refreeze`` process's ``weld`` (elements that stay in
contact freeze into a new joint), the joint slots the engine reserves for them, their strength
growth, restarts, outputs and the one-line refusals; and the sign of ``joint_tension``."""
from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from siku_core.errors import SceneError
from siku_core.geometry.quat import centers, east_north_local, from_tangent, to_tangent
from siku_core.scene.scene_file import scene_from_text
from siku_core.run.simulation import Simulation
from siku_core.testing import scene_text
from siku_core.testing.contact_cases import square_pack
from siku_plugins.processes.refreeze import refrozen_strength

SIZE = 2000.0  # m, the elements' side
DT = 0.25  # s
DLON = math.degrees(SIZE / 6371000.0) / math.cos(math.radians(80.0))


def wall_text(weld=True, weld_time=20.0, gap=3.0, push=0.02, steps=600, carrier=0.0,
              jointed="collide", extra_params="", output=None):
    """A static wall (0), a free carrier (1) east of it ``gap`` [m] away (at the middle of the
    facing sides) and, jointed to the carrier, a steady pusher (2) driving west at ``push``
    [m/s] (none when ``push`` is None; the carrier then moves at ``carrier`` m/s east)."""
    g = gap / SIZE
    els = [{"center": (-DLON * (1 + g), 80.0), "flag": "static", "thickness": 1.0},
           {"center": (0.0, 80.0), "thickness": 1.0, "velocity": (carrier, 0.0)}]
    joints = 'joints = "none"\n'
    if push is not None:
        els.append({"center": (DLON, 80.0), "flag": "steady", "velocity": (-push, 0.0),
                    "thickness": 1.0})
        joints = 'joints = "pairs"\npairs = [[1, 2]]\n'
    return scene_text(els, size=SIZE, dt=DT, duration=steps * DT, output=output, extra=(
        f'[contact]\nlaw = "distributed_spring"\n{joints}jointed = "{jointed}"\n'
        'params = { tensile_strain = 1.0 }\n\n[[process]]\nname = "refreeze"\n'
        f'params = {{ weld = {str(weld).lower()}, weld_time = {weld_time}, strength = 2e4, '
        f'strength_time = 400.0{extra_params} }}\n'))


def build(text, **kw):
    return Simulation(scene_from_text(text, "<wall>"), progress=False, **{"out": False, **kw})


def touching(cm, a=0, b=1) -> bool:
    """Whether elements ``a`` and ``b`` carried a contact force in the last evaluation."""
    return any({int(p[0]), int(p[1])} == {a, b} and act == 1
               for p, act in zip(cm.pairs, cm.pair_active))


def centre_distance(sim, i, j) -> float:
    c = centers(sim.state.q)
    return sim.radius * math.atan2(float(np.linalg.norm(np.cross(c[i], c[j]))),
                                   float(np.dot(c[i], c[j])))


def to_outline(poly, p) -> float:
    """Distance [m] from point ``p`` to the outline of polygon ``poly`` (same plane)."""
    best = math.inf
    for a, b in zip(poly, np.roll(poly, -1, axis=0)):
        d = b - a
        s = min(max(np.dot(p - a, d) / np.dot(d, d), 0.0), 1.0)
        best = min(best, float(np.hypot(*(a + s * d - p))))
    return best


def run_to_weld(sim, steps=600):
    """Step until the carrier and the wall weld: (first time seen touching, weld time)."""
    cm = sim.contacts
    first = None
    for _ in range(steps):
        sim.step()
        if cm.n_joints > 1:
            return first, sim.time
        if first is None and touching(cm):
            first = sim.time
    return first, None


@pytest.mark.parametrize("jointed", ["collide", "exclude"])
def test_elements_held_in_contact_weld_after_the_set_time_to_one_step(jointed):
    sim = build(wall_text(weld_time=20.0, jointed=jointed))
    cm = sim.contacts
    assert cm.n_joints == 1 and cm.joint_slots == 1 + 3  # weld_capacity 1 per element
    first, welded = run_to_weld(sim)
    # the pusher closes the 3 m gap (less the corners' 1.8 m lean at 80 N) at 2 cm/s: the
    # contact begins during the run, and the weld follows it by weld_time
    assert first is not None and first > 40 * DT
    assert welded == pytest.approx(first + 20.0, abs=0.5 * DT)
    k = 1
    assert {int(cm.ji[k]), int(cm.jj[k])} == {0, 1} and cm.intact[k]
    i, j = int(cm.ji[k]), int(cm.jj[k])
    # at rest where the two sides are: its ends coincide (round-off of the projections), its
    # rest distance is the centres' distance now, the law's history starts from zero
    assert cm.joint_gaps(np.array([k]))[0] < 1e-6
    assert cm.L0[k] == pytest.approx(centre_distance(sim, i, j), rel=1e-12)
    assert not cm.hist[k].any()
    # along the line where the outlines cross: both ends on both outlines (to the clip's
    # tolerance, 1e-9 of the size), the width its length, the normal towards j
    st = sim.state
    for e in range(2):
        assert to_outline(st.polygon(i), cm.ends_i[k, e]) < 1e-6
        assert to_outline(st.polygon(j), cm.ends_j[k, e]) < 1e-6
    d = cm.ends_i[k, 1] - cm.ends_i[k, 0]
    assert cm.width[k] == pytest.approx(np.hypot(*d), rel=1e-12) and cm.width[k] > 10.0
    cx, cy = to_tangent(st.q[i], from_tangent(st.q[j], 0.0, 0.0, sim.radius), sim.radius)
    assert d[1] * cx - d[0] * cy > 0
    # its stiffness is the eq. 9 one of every joint (E h over the lever arms)
    from siku_core.contact.contact_frames import joint_arms, joint_constants
    K, _ = joint_constants(st.thickness, cm.E, cm.minv, cm.ji, cm.jj,
                           *joint_arms(cm.ends_i, cm.ends_j))
    assert cm.jK[k] == K[k] > 0
    assert sim.processes[0].diagnostics(sim.context)["welded_joints"] == 1.0
    sim.step()
    if jointed == "exclude":  # the welded pair is no collision candidate any more
        assert not any({int(p[0]), int(p[1])} == {0, 1} for p in cm.pairs)
    else:
        assert touching(cm)


def test_a_welded_joint_holds_up_to_the_growing_strength_and_breaks_above_it():
    sim = build(wall_text(weld_time=20.0, steps=2000))
    cm = sim.contacts
    _, welded = run_to_weld(sim)
    assert welded is not None
    # the pusher turns back east: it drags the carrier (through their strong joint) off the
    # wall, and the weld opens
    ex, ey, _, _ = east_north_local(sim.state.q[2])
    sim.state.V[2] = 0.02 * ex, 0.02 * ey
    k = 1
    broke_at = tension_before = None
    for _ in range(1500):
        tension_before = float(cm.joint_tension(np.array([k]))[0])
        sim.step()
        if not cm.intact[k]:
            broke_at = sim.time
            break
    assert broke_at is not None and cm.break_mode[k] == 2  # tension
    assert cm.intact[0]  # the carrier's joint to the pusher holds
    tension = float(cm.joint_tension(np.array([k]))[0])
    assert tension > refrozen_strength(broke_at - welded, 2e4, 400.0)
    assert tension_before <= refrozen_strength(broke_at - DT - welded, 2e4, 400.0)
    assert 0.0 < broke_at - welded < 400.0  # the growing strength, not the law's own


def test_elements_that_part_before_the_set_time_never_weld():
    # the carrier alone, thrown at the wall at 5 cm/s: it touches twice (bounce, turn, a
    # second touch), each time for less than weld_time = 30 s, together for more
    sim = build(wall_text(weld_time=30.0, push=None, carrier=-0.05, steps=1500))
    cm = sim.contacts
    on = []
    for _ in range(1500):
        sim.step()
        on.append(touching(cm))
    edges = np.diff(np.concatenate([[0], np.array(on, int), [0]]))
    spans = (np.flatnonzero(edges == -1) - np.flatnonzero(edges == 1)) * DT  # [s]
    assert len(spans) >= 2 and spans.max() < 30.0 < spans.sum()
    assert not on[-100:].count(True)  # parted for good
    assert cm.n_joints == 0 and not sim.processes[0].count
    # the same contacts weld when weld_time is shorter than the longest of them
    sim = build(wall_text(weld_time=0.5 * spans.max(), push=None, carrier=-0.05, steps=1500))
    sim.run()
    assert sim.contacts.n_joints == 1


def test_reserving_joint_slots_changes_nothing_until_a_weld():
    """A scene without weld reserves no slots and keeps its history as before; with weld but
    no contact long enough it runs bit for bit as without (the joints then are a view of the
    reserved arrays)."""
    plain = build(wall_text(weld=False, steps=200))
    cm = plain.contacts
    assert cm.joint_slots == cm.n_joints == 1
    assert not {"joints", "pairs", "ends_i"} & set(cm.history())
    assert "welded_joints" not in plain.diagnostics()
    reserved = build(wall_text(weld=True, weld_time=1e6, steps=200))
    assert reserved.contacts.joint_slots == 4
    plain.run()
    reserved.run()
    for k in ("q", "V", "w"):
        assert np.array_equal(getattr(plain.state, k), getattr(reserved.state, k)), k
    for k in ("intact", "hist", "ends_j", "L0"):
        assert np.array_equal(getattr(cm, k), getattr(reserved.contacts, k)), k


def test_restart_after_a_weld_continues_bit_for_bit_and_outputs_see_the_new_joint(tmp_path):
    from siku_io.analysis.fsd import output_floes
    from siku_io.output.results import open_results

    text = wall_text(weld_time=20.0, steps=360, output={"every": 60 * DT})
    whole = build(text, out=tmp_path / "whole.h5")
    whole.run()
    assert whole.contacts.n_joints == 2  # welded at about 52 s, before the restart at 60 s
    part = tmp_path / "part.h5"
    build(text, out=part).run(steps=240)
    again = build(text, out=part, restart=part)
    assert again.step_index == 240 and again.contacts.n_joints == 2
    again.run()
    for k in ("q", "V", "w"):
        assert np.array_equal(getattr(whole.state, k), getattr(again.state, k)), k
    a, b = whole.history_arrays(), again.history_arrays()
    assert a.keys() == b.keys()
    for key in a:
        for name in a[key]:
            assert np.array_equal(a[key][name], b[key][name], equal_nan=True), (key, name)
    # the file: the created joint's pair per snapshot, and floes over it (wall + carrier +
    # pusher: two floes before the weld, one after)
    with open_results(tmp_path / "whole.h5") as f:
        pairs = f["states/history/contacts/pairs"][()]
        joints = f["states/history/contacts/joints"][()]
        t = f["states/time"][()]
    assert list(joints) == [1 if x < 52.0 else 2 for x in t]
    assert sorted(pairs[-1, 1]) == [0, 1] and (pairs[-1, 2:] == -1).all()
    floes = output_floes(tmp_path / "whole.h5", calipers=False)
    assert [int(fl.label.max()) + 1 for fl in floes] == [2 if x < 52.0 else 1 for x in t]


def test_running_out_of_joint_slots_is_one_line(tmp_path):
    text = wall_text(weld_time=2.0, steps=400, extra_params=", weld_capacity = 0.0")
    scene = tmp_path / "s.toml"
    scene.write_text(text)
    r = subprocess.run([sys.executable, "-m", "siku_core.run.cli", "run", str(scene), "--out",
                        str(tmp_path / "o.h5")], capture_output=True, text=True, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    lines = [ln for ln in r.stderr.splitlines() if ln.startswith("siku: error")]
    assert len(lines) == 1 and "Traceback" not in r.stderr, r.stderr
    assert "refreeze" in lines[0] and "weld_capacity" in lines[0], lines[0]


def test_weld_needs_a_law_with_joints():
    text = wall_text(push=None).replace('"distributed_spring"', '"collision"').replace(
        "params = { tensile_strain = 1.0 }\n", "")
    with pytest.raises(SceneError, match="weld = true needs a contact law with joints"):
        build(text)


def test_joint_tension_is_positive_when_the_joint_is_pulled_open():
    pack = square_pack(0.0, 80.0, 2, 1, size=SIZE)
    text = scene_text([], packs=[pack], dt=0.4, duration=40.0, thickness=1.0, extra=(
        '[contact]\nlaw = "distributed_spring"\nparams = { tensile_strain = 1.0 }\n'))
    for sign in (1.0, -1.0):
        sim = build(text)
        cm = sim.contacts
        for i, u in ((0, -0.02 * sign), (1, 0.02 * sign)):  # east [m/s]: apart, or together
            ex, ey, _, _ = east_north_local(sim.state.q[i])
            sim.state.V[i] = u * ex, u * ey
        sim.step()
        opening = centre_distance(sim, 0, 1) - cm.L0[0]
        assert np.sign(opening) == sign
        # opening and closing both at 4 cm/s: spring and damping pull (push) the same way
        assert np.sign(cm.joint_tension(np.array([0]))[0]) == sign


def test_refreeze_leaves_a_pair_whose_joint_broke_to_refreezing():
    """A broken joint's pair in contact is the refreezing's, never welded a second time."""
    sim = build(wall_text(weld_time=0.0, steps=300, extra_params=", freeze_time = 1e6"))
    cm = sim.contacts
    cm.break_joints(np.array([0]), 5, 0.0)  # the carrier's joint to the pusher, which press
    sim.run(steps=300)
    keys = {tuple(sorted((int(a), int(b)))) for a, b in zip(cm.ji, cm.jj)}
    assert (1, 2) in keys and len(keys) == cm.n_joints  # no second joint on any pair
    assert not cm.intact[0]


def test_refreeze_with_weld_passes_the_process_conformance_suite(tmp_path):
    from siku_core.testing.process_checks import check_process, process_simulation
    from siku_plugins.processes import Refreeze

    params = {"weld": True, "weld_time": 2.0, "freeze_time": 2.0}
    check_process(Refreeze, params, tmp_path)
    # (its jointed pack at rest welds nothing: the slots are reserved, the rest is as without)
    cm = process_simulation(Refreeze, params).contacts
    assert cm.joint_slots == cm.n_joints + 12


def test_wave_breaking_checks_the_joints_a_weld_creates():
    # a gentle swell along the wall and carrier: far below the critical strain, nothing breaks,
    # but every intact joint, the welded one included, gets its strain at each check
    text = wall_text(weld_time=20.0) + (
        '\n[[forcing]]\nsource = "waves"\n'
        'params = { breaking = true, critical_strain = 1.0, break_every = 0.25, slope = false }\n'
        'field = { type = "linear_wave", params = { amplitude = 0.1, period = 8.0, '
        'direction = 90.0 } }\n')
    sim = build(text)
    breaker = next(f for f in sim.forcing if getattr(f, "breaker", None) is not None).breaker
    assert len(breaker.strain) == sim.contacts.joint_slots
    _, welded = run_to_weld(sim)
    assert welded is not None
    sim.step()
    sim.step()
    strain = breaker.strain[:sim.contacts.n_joints]
    # the welded joint (slot 1) lies along the wall, across the swell: a finite, positive strain
    assert np.isfinite(strain).all() and strain[1] > 0.0


def test_bending_beams_and_welds_are_refused_together_in_one_line():
    text = wall_text().replace('[[process]]\nname = "refreeze"', (
        '[[process]]\nname = "floating"\nparams = { bending = true }\n\n'
        '[[process]]\nname = "refreeze"'))
    with pytest.raises(SceneError, match="bending = true .* one or the other"):
        build(text)


def test_weld_runs_on_ranks_and_passes_the_ranks_conformance_check():
    """``refreeze`` with ``weld = true`` is not refused on ranks, and the conformance check of
    a process on ranks (a rank holding a third of the pack and its ghosts, stepped beside the
    whole run) passes it bit for bit."""
    from siku_core.ranks.driver import refusal_reason
    from siku_core.testing.process_checks import check_process_on_ranks
    from siku_plugins.processes.refreeze import Refreeze

    sim = build(wall_text())
    assert refusal_reason(sim.processes[0]) == ""
    check_process_on_ranks(Refreeze, {"weld": True, "weld_time": 0.0, "freeze_time": 2.0})
