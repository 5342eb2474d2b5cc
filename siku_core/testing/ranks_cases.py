"""Small scenes run on MPI ranks and on one, for the checks that both give the same bits.

``python -m siku_core.testing.ranks_cases DIR CASE...`` runs each case to its end (under
``mpiexec -n N`` on N ranks, else on one) and writes ``DIR/CASE.npz`` from rank 0: the final
element state, the joint table and the diagnostics and per-element fields of the gathered
run, and the same at each step the run writes diagnostics (``trace_*``: the diagnostics and
fields its writers would write, on ranks gathered before any redistribution). Cases
(:data:`CASES`): ``spring`` (a bonded pack whose joints break, the ranks' boundary
across the joints that break), ``mohr`` (the pack with ``mohr_coulomb``), ``collision`` (a
jittered pack without joints pushed by a moving edge), ``migrate`` (the spring pack with every
element moving to the other rank and back every 60 steps), ``rebalance`` (the collision pack
split again whenever the ranks' measured work differs at all), ``rk4`` (on three ranks, the
spring pack under an integrator that evaluates forces four times a step), ``thermo`` (the
spring pack thinning and melting under ``thermodynamics``), ``ridge_freeze`` (the pack
pulled apart under ``thermodynamics``, ``ridging`` and ``refreeze``: joints across the ranks'
boundary break and refreeze), ``ridge_freeze_split`` (the same, split by bisection),
``ridge_freeze_migrate`` (the same, every element changing rank every 60 steps),
``cycle4`` (on four ranks, the spring pack to its joints' breaks, every element moving to the
next rank every 60 steps), ``raise`` (rank 1's integrator raises at step 10: the run ends on
every rank with one line), ``floating`` (a bonded floe of 24 elements under the ``floating``
process in a wave with two loads, its joints beams that break in flexure),
``floating_migrate`` (the same, every element changing rank every 40 steps),
``floating_plain`` (the floe floating without beams), ``wave_breaking`` (the floe under the
``waves`` forcing's flexural breaking), ``spectral`` (six elements in a flume under the
``waves`` forcing of a ``spectral`` field whose spectrum the ice damps, a grid cell holding
elements of both ranks), ``spectral_floating`` (ten floes floating in a ``spectral`` field,
dragged by it: their drag and radiated power set its response attenuation), ``weld`` (a pack
without joints pressed together under ``refreeze`` with ``weld = true``: pairs in contact weld
into new joints, across the ranks' boundary too, which break and refreeze), ``weld4`` (on four
ranks, the same with welded pairs leaving the candidate list, ``jointed = "exclude"``, every
element moving to the next rank every 60 steps).

The record of a run holds the history of the forcing's fields (``history_<k>_<name>``: a
``spectral`` field's spectrum and clock), as rank 0 writes them to a restart.
"""
from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from ..scene.scene_file import scene_from_text
from .contact_cases import contact_scene_text, square_pack
from .scenes import scene_text

SPRING = {"tensile_strain": 2e-4, "damage_onset": 0.3}


def spring_text(steps: int = 3000, law: str = "distributed_spring",
                params: dict | None = None) -> str:
    """The 5 × 2 bonded pack between a static and a steady edge whose joints break (dt 0.1 s;
    two of its joints, between the last two columns, break within 3000 steps)."""
    pack = square_pack(30.0, 72.0, 5, 2, 2000.0, jitter=0.2, seed=7, left="static",
                       right="steady", right_velocity=[0.004, 0.0012])
    return contact_scene_text(law, SPRING if params is None else params, packs=[pack],
                              dt=0.1, steps=steps, run={"progress": False})


def collision_text(steps: int = 400) -> str:
    """A 5 × 3 jittered pack without joints, its right edge pushed in at 0.05 m/s."""
    pack = square_pack(30.0, 72.0, 5, 3, 2000.0, jitter=0.3, seed=3, left="static",
                       right="steady", right_velocity=[-0.05, 0.0])
    return contact_scene_text("collision", None, packs=[pack], joints="none", dt=0.1,
                              steps=steps, run={"progress": False})


def thermo_text(steps: int = 600, flux: float = 6e6) -> str:
    """The spring pack under ``thermodynamics`` every second: an ocean heat flux ``flux``
    [W/m²] thins the ice (its mass and joints' stiffness follow; the stable step is checked
    again as it thins); at the default, every element melts away at about step 480 (its
    joints break with mode ``melt``), at 3e6 none within 600 steps."""
    return spring_text(steps) + f"""
[[process]]
name = "thermodynamics"
every = 1.0
params = {{ surface_temperature = -20.0, ocean_heat_flux = {flux!r} }}
"""


def ridge_freeze_text(steps: int = 500) -> str:
    """The spring pack, its right edge pulled three times as fast, under the ``ridging`` law
    (joints of ``distributed_spring`` with a tensile strain of 8e-5, collisions capped at a
    plastic limit of 100 Pa × h) with ``thermodynamics`` every second, ``ridging`` and
    ``refreeze`` (sides within 2 m for 5 s refreeze, at 2 kPa growing over 100 s): within 500
    steps joints between the last two columns break, refreeze and break again (about ten
    times), and pressed pairs ridge."""
    pack = square_pack(30.0, 72.0, 5, 2, 2000.0, jitter=0.2, seed=7, left="static",
                       right="steady", right_velocity=[0.012, 0.0036])
    law = {"tensile_strain": 8e-5, "damage_onset": 0.3, "strength": 100.0}
    return contact_scene_text("ridging", law, packs=[pack], dt=0.1, steps=steps,
                              run={"progress": False}) + """
[[process]]
name = "thermodynamics"
every = 1.0
params = { surface_temperature = -20.0, ocean_heat_flux = 50.0 }

[[process]]
name = "ridging"

[[process]]
name = "refreeze"
params = { gap = 2.0, freeze_time = 5.0, strength = 2e3, strength_time = 100.0 }
"""


def weld_text(steps: int = 200) -> str:
    """The collision pack without joints under ``distributed_spring``, its right edge pushed
    in at 0.15 m/s, with ``refreeze``'s weld (pairs in contact for 2 s freeze into a new
    joint; broken ones within 2 m for 3 s refreeze, at 2 kPa growing over 100 s): within 50
    steps about twenty joints are welded (across the ranks' boundary too), from step 50 on
    some break and refreeze, and new pairs weld (at 120 steps: 20 welded, 3 broken in
    tension, 3 refrozen)."""
    pack = square_pack(30.0, 72.0, 5, 3, 2000.0, jitter=0.3, seed=3, left="static",
                       right="steady", right_velocity=[-0.15, 0.0])
    return contact_scene_text("distributed_spring", {"tensile_strain": 2e-4}, packs=[pack],
                              joints="none", dt=0.1, steps=steps,
                              run={"progress": False}) + """
[[process]]
name = "refreeze"

[process.params]
weld = true
weld_time = 2.0
weld_capacity = 3.0
gap = 2.0
freeze_time = 3.0
strength = 2e3
strength_time = 100.0
"""


FLOE = ('outline = "rectangle", center = [0.0, 0.0], length = 80.0, width = 30.0, '
        'element_size = 10.0')
WAVE = "amplitude = 0.5, period = 3.0, direction = 90.0, origin = [0.0, 0.0]"


def floe_text(steps: int = 100, process: str = "", forcing: str = "") -> str:
    """A bonded 8 × 3 floe of 10 m elements, 1 m thick (``distributed_spring``, dt 1 ms), in
    a linear wave of 0.5 m amplitude and 3 s period (the ``waves`` forcing with ``forcing``'s
    parameters), with the ``[[process]]`` tables ``process``."""
    return f"""
title = "a floe in waves"

[time]
duration = {steps * 0.001!r}
dt = 0.001

[elements]
thickness = 1.0

[[elements.source]]
name = "floe"
params = {{ {FLOE} }}

[contact]
law = "distributed_spring"
params = {{ tensile_strain = 1e-2 }}

[[forcing]]
source = "waves"
params = {{ {forcing} }}
field = {{ type = "linear_wave", params = {{ {WAVE} }} }}

[run]
progress = false
{process}"""


def floating_text(steps: int = 100, bending: bool = True) -> str:
    """The floe under the ``floating`` process: heave, roll and pitch in the wave, two
    constant loads; with ``bending`` its joints are beams that break in flexure (at 100 kPa
    four of them within 100 steps)."""
    extra = ", bending = true, flexural_strength = 1e5" if bending else ""
    return floe_text(steps, f"""
[[process]]
name = "floating"
params = {{ coefficients = "scene", loads = [[5, 2e5], [20, -1e5]]{extra} }}
""", "drag = true")


def wave_breaking_text(steps: int = 60) -> str:
    """The floe under the ``waves`` forcing's flexural breaking, checked every 20 steps
    (floes labelled over the whole joint network, split into pieces as joints break)."""
    return floe_text(steps, forcing="breaking = true, critical_strain = 4e-5, "
                     "break_every = 0.02")


R_EARTH = 6_371_000.0


def spectral_text(steps: int = 60) -> str:
    """Six 100 m elements, 1 m thick, free in a flume 0..2100 m east of the origin at the
    equator (from x = 1000 m on), under the ``waves`` forcing (drag and slope) of a
    ``spectral`` field: an 8 s wave of 0.5 m amplitude on 300 m cells, damped by the ice at
    ``alpha = 1e-3`` (dt 0.05 s). Bisection puts elements 0-2 on one rank and 3-5 on the
    other: the cell from 1200 to 1500 m holds elements 2, 3 and 4 of both."""
    pack = square_pack(math.degrees(1000.0 / R_EARTH), -math.degrees(50.0 / R_EARTH), 6, 1,
                       size=100.0)
    field = {"type": "spectral", "params": {
        "spectrum": "monochromatic", "amplitude": 0.5, "period": 8.0, "x": [0.0, 2100.0],
        "y": [-150.0, 150.0], "resolution": 300.0, "origin": [0.0, 0.0],
        "attenuation": "constant", "attenuation_params": {"alpha": 1e-3}}}
    return scene_text([], packs=[pack], dt=0.05, duration=steps * 0.05, thickness=1.0,
                      forcing=[{"source": "waves", "params": {"drag": True}, "field": field}],
                      run={"progress": False})


def spectral_floating_text(steps: int = 40) -> str:
    """Ten 10 m floes, 1 m thick, from x = 100 m in a flume 0..400 m (20 m cells) under an
    8 s wave of 5 cm amplitude of a ``spectral`` field damped by the ice (``alpha = 2e-3``),
    floating (``floating``, ramped over 8 s) and dragged by the orbital flow (dt 0.25 s)."""
    pack = square_pack(math.degrees(100.0 / R_EARTH), -math.degrees(5.0 / R_EARTH), 10, 1,
                       size=10.0)
    field = {"type": "spectral", "params": {
        "spectrum": "monochromatic", "amplitude": 0.05, "period": 8.0, "x": [0.0, 400.0],
        "y": [-10.0, 10.0], "resolution": 20.0, "origin": [0.0, 0.0],
        "attenuation": "constant", "attenuation_params": {"alpha": 2e-3}}}
    return scene_text([], packs=[pack], dt=0.25, duration=steps * 0.25, thickness=1.0,
                      forcing=[{"source": "waves", "params": {"drag": True, "slope": False},
                                "field": field}],
                      run={"progress": False}, extra='[[process]]\nname = "floating"\n'
                      'params = { ramp = 8.0, coefficients = "scene" }')


def _last_column(step: int, c: np.ndarray) -> np.ndarray:
    """Rank 1 owns the last column of the spring pack (elements 8 and 9), rank 0 the rest."""
    return (np.arange(len(c)) >= 8).astype(np.int64)


def _three_columns(step: int, c: np.ndarray) -> np.ndarray:
    """On three ranks: elements 0-5, 6-7 and 8-9 of the spring pack (the breaking joints
    between the last two parts, beyond what rank 0 holds)."""
    return np.minimum(np.arange(len(c)) // 2 - 2, 2).clip(0)


def _swapping(step: int, c: np.ndarray) -> np.ndarray:
    """Elements alternate between the ranks by index; every 60 steps each changes rank."""
    return (np.arange(len(c)) + step // 60) % 2


def _cycling(step: int, c: np.ndarray) -> np.ndarray:
    """On four ranks: elements take the ranks in turn by index, and every 60 steps each moves
    to the next rank (the breaking joints of the spring pack always join two ranks)."""
    return (np.arange(len(c)) + step // 60) % 4


def _swapping_floe(step: int, c: np.ndarray) -> np.ndarray:
    """Elements of the floe alternate between the ranks in blocks of three; every 40 steps
    each changes rank."""
    return (np.arange(len(c)) // 3 + step // 40) % 2


#: name -> (scene text, options of the ranks driver)
CASES: dict[str, tuple[str, dict[str, Any]]] = {
    "spring": (spring_text(), {"owner": _last_column}),
    "mohr": (spring_text(1000, "mohr_coulomb", {}), {}),
    "collision": (collision_text(), {}),
    "migrate": (spring_text(600), {"owner": _swapping, "every": 30}),
    "rebalance": (collision_text(), {"margin": 0.0, "min_work": 0.001}),
    "thermo": (thermo_text(), {"owner": _last_column}),
    "ridge_freeze": (ridge_freeze_text(), {"owner": _last_column}),
    "ridge_freeze_split": (ridge_freeze_text(), {}),
    "ridge_freeze_migrate": (ridge_freeze_text(), {"owner": _swapping, "every": 30}),
    "rk4": (spring_text(3000).replace('"siku2"', '"rk4"'), {"owner": _three_columns}),
    "raise": (spring_text(100), {}),
    "cycle4": (spring_text(1700), {"owner": _cycling, "every": 30}),
    "floating": (floating_text(), {}),
    "floating_migrate": (floating_text(), {"owner": _swapping_floe, "every": 20}),
    "floating_plain": (floating_text(60, bending=False), {}),
    "wave_breaking": (wave_breaking_text(), {}),
    "spectral": (spectral_text(), {}),
    "spectral_floating": (spectral_floating_text(), {}),
    "weld": (weld_text(120), {"every": 25}),
    "weld4": (weld_text().replace("[contact]", '[contact]\njointed = "exclude"'),
              {"owner": _cycling, "every": 30}),
}


def run_case(name: str, ranks: bool) -> dict[str, np.ndarray] | None:
    """Run case ``name`` (on the launched ranks if ``ranks``); its record on rank 0."""
    from ..run.simulation import Simulation

    text, opts = CASES[name]
    sim = Simulation(scene_from_text(text, f"<ranks case {name}>"), out=False,
                     progress=False)
    trace = _trace(sim)
    if not ranks:
        sim.run()
        return {**record(sim), **_traced(trace)}
    from ..ranks.driver import RankRun

    run = RankRun(sim, **opts)
    if name == "raise" and run.rank == 1:
        step = type(sim.integrator).step

        def failing(self, state, t, dt, forces):
            if t >= 10 * dt:
                raise RuntimeError("integrator failed on purpose")
            return step(self, state, t, dt, forces)
        type(sim.integrator).step = failing  # type: ignore[method-assign]
    run.run()
    run.gather_all()
    agree = run.joints_agree()
    if not run.root:
        return None
    out = {**record(sim), **_traced(trace)}
    out["ranks_joints_agree"] = np.array(agree)
    out["ranks_shared_joints"] = np.array(_shared(run))
    out["ranks_splits"] = np.array(run.splits)
    out["ranks_migrated"] = np.array(run.migrated)
    out["ranks_shared_pairs"] = np.array(_shared_pairs(run))
    out["ranks_owner"] = np.array(run.owner)
    out["ranks_welded_across"] = np.array(_created_across(run))
    return out


def _trace(sim) -> list[dict[str, np.ndarray]]:
    """The diagnostics and per-element fields of ``sim`` at each of its diagnostics steps, as
    its writers would write them (on ranks: rank 0's, gathered), appended to the list
    returned."""
    trace: list[dict[str, np.ndarray]] = []
    write = sim._write

    def traced(force: bool = False, diagnostics: bool = True) -> None:
        write(force=force, diagnostics=diagnostics)
        if sim.diag_schedule.due(sim.step_index, sim.n_steps):
            got = {f"diag_{k}": np.asarray(v) for k, v in sim.diagnostics().items()}
            got.update({f"field_{k}": np.asarray(v) for k, v in sim.element_fields().items()})
            trace.append({"step": np.asarray(sim.step_index), **got})
    sim._write = traced
    return trace


def _traced(trace: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """The trace as arrays ``trace_<name>`` (first axis: the diagnostics steps that have it;
    ``trace_<name>_steps``: which, where not every one has)."""
    names = list(dict.fromkeys(k for t in trace for k in t))
    out = {}
    for k in names:
        rows = [t for t in trace if k in t]
        out[f"trace_{k}"] = np.stack([t[k] for t in rows])
        if len(rows) != len(trace):
            out[f"trace_{k}_steps"] = np.array([int(t["step"]) for t in rows])
    return out


def _shared_pairs(run) -> int:
    """How many pairs a process remembers (``rank_history`` layout ``pair_keys``) whose two
    elements different ranks own."""
    n, own = run.sim.state.n, run.owner
    count = 0
    for proc in run.sim.processes:
        layout = proc.rank_history or {}
        hist = proc.history() or {}
        for name, kind in layout.items():
            if kind == "pair_keys" and name in hist:  # (a configuration may keep none)
                keys = np.asarray(hist[name])
                keys = keys[keys >= 0]
                count += int(np.count_nonzero(own[keys // n] != own[keys % n]))
    return count


def _created_across(run) -> int:
    """How many joints created during the run join two elements that different ranks own at
    its end."""
    cm = run.sim.contacts
    if cm is None:
        return 0
    built = cm.n_joints - int(run.sim.diagnostics().get("welded_joints", 0))
    own = run.owner
    new = np.arange(built, cm.n_joints)
    return int(np.count_nonzero(own[cm.ji[new]] != own[cm.jj[new]]))


def _shared(run) -> int:
    """How many joints rank 0 holds with an element owned elsewhere."""
    cm = run.sim.contacts
    if cm is None:
        return 0
    own = run.owner
    return int(np.count_nonzero(own[cm.ji[run.jg]] != own[cm.jj[run.jg]]))


def record(sim) -> dict[str, np.ndarray]:
    """What the comparison checks: state, joints, diagnostics, per-element fields."""
    st = sim.state
    out = {k: np.array(getattr(st, k)) for k in ("q", "V", "w", "F", "T")}
    cm = sim.contacts
    if cm is not None:
        for k in ("ji", "jj", "ends_i", "ends_j", "L0", "width", "intact", "hist",
                  "break_mode", "break_time"):
            out[f"joint_{k}"] = np.array(getattr(cm, k))
        out["n_broken_total"] = np.array(cm.n_broken_total)
    for k, proc in enumerate(sim.processes):  # (on ranks: gathered by global identities)
        for name, v in (proc.history() or {}).items():
            out[f"history_{k}_{name}"] = np.asarray(v)
    for k, v in sim.diagnostics().items():
        out[f"diag_{k}"] = np.asarray(v)
    for k, v in sim.element_fields().items():
        out[f"field_{k}"] = np.asarray(v)
    for k, f in enumerate(sim.forcing):
        hist = f.field.history() if f.field is not None else None
        for name, v in (hist or {}).items():
            out[f"history_{k}_{name}"] = np.asarray(v)
    return out


def main(argv: list[str]) -> int:
    from ..ranks import launched_ranks

    out = Path(argv[0])
    ranks = launched_ranks() > 1
    for name in argv[1:]:
        rec = run_case(name, ranks)
        if rec is not None:
            np.savez(out / f"{name}.npz", **rec)
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main(sys.argv[1:]))
