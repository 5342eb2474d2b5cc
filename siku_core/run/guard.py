"""The run's guards: a diverging or shattering run stops at the last good snapshot, never with
bad data, and the stable step follows the contact network.

:class:`Guard` checks the state on the scene's schedule (``[run] nan_check_every``) and before
every snapshot: a non-finite force, torque, velocity, spin or orientation, or a speed above
``[run] max_speed``, puts the state and every component's history back to the last good
snapshot (the last one written, or due to be written when the run writes nothing) and raises
:class:`~siku_core.errors.NonFiniteError` naming the quantity, the element and the step.
:func:`check_initial_state` refuses a run that starts from non-finite numbers.

After every step :class:`NetworkWatch` (owned by the guard) follows the joints: once more than
:data:`RECHECK_JOINTS` of them have broken or frozen since the last stable-step check, the
engine checks the step again (:meth:`~siku_core.run.simulation.Simulation.check_time_step`, which
refuses or warns as before the run); and :class:`BreakRate` stops a run whose joints break
faster than cracks can run (a run gone unstable without blowing up: its speeds stay modest
while the pack shatters), by the same path as the NaN guard but with a
:class:`~siku_core.errors.StabilityError`, or warns, as ``[run] break_guard`` says.
"""
from __future__ import annotations

import math
import warnings
from collections import deque
from typing import TYPE_CHECKING

import numpy as np

from .. import parallel
from ..contact_law import BreakMode
from ..diagnostics import all_finite, fastest, state_sound
from ..errors import NonFiniteError, PluginError, SceneError, StabilityError
from ..state import DYNAMIC, FREE

if TYPE_CHECKING:  # pragma: no cover
    from ..context import Run

#: quantities checked by the NaN guard, in the order their failure is reported
GUARDED = ("F", "T", "V", "w", "q")
#: the bounds a component may declare on a field it integrates (``Component.integrates``)
BOUNDS = ("finite", "speed")
#: break modes the contact law does not give (melting, waves, other components): not counted
#: by the breaking-rate guard, which watches the contacts' own integration
OUTSIDE_BREAKS = np.array([int(BreakMode.MELT), int(BreakMode.FLEXURE), int(BreakMode.EXTERNAL)])

#: share of the joints (of those intact at the last stable-step check) that may break or
#: freeze before the step is checked again. A joint changes the stiffness of its two elements
#: only, and the check costs time linear in the contacts (siku_core.contact.stable_step), so the
#: network is never more than this share away from the one the step was last checked on
RECHECK_JOINTS = 0.01
#: the window of the breaking-rate guard, in elastic crossing times ``L / c`` of an element
#: (``L`` the median element size, ``c = sqrt(E / rho)``)
CROSSINGS = 4
#: the fewest steps in that window
MIN_WINDOW = 10
#: joints a crack breaks at most per element it crosses (along the edges of the cells)
JOINTS_PER_CROSSING = 2
#: share of the intact joints whose breaking within the window stops the run: a crack's tip
#: runs at most at ``c`` (and in the model at most one element per step), so within the
#: window one crack breaks at most ``JOINTS_PER_CROSSING (CROSSINGS + 1)`` joints; a tenth of
#: the joints of a pack (about 3 per element) then takes a crack started every 30 or so
#: elements within seconds: the pack ground to floes of a few elements faster than any
#: forcing loads it. The default scene breaks at most 27 joints (0.2 %) in its 72-step window
#: at its step 0.75 s, and 26 in its 36-step window at 1.5 s (over 24 h)
BREAK_SHARE = 0.1


class Guard:
    """The NaN guard of one run and the last good snapshot it returns to."""

    def __init__(self, sim: "Run"):
        self.sim = sim
        #: the step the state was last checked at (``-1``: not yet)
        self.checked_step = -1
        #: the fields the components integrate: ``[(owner, name, array, bound)]``
        self.integrated = integrated_fields(sim)
        #: the joints' watch (stable-step rechecks and the breaking rate)
        self.network = NetworkWatch(sim, self)
        self.save()

    def after_step(self) -> None:
        """What the guard checks after every step: the joints (:class:`NetworkWatch`)."""
        self.network.after_step()

    def check(self) -> None:
        """Stop on a non-finite value or a speed above ``[run] max_speed`` (a diverging run)."""
        sim = self.sim
        st = sim.state
        self.checked_step = sim.step_index
        vmax = sim.scene.cfg.run.max_speed
        nch = parallel.chunks(st.n, parallel.GUARD_NS)
        with parallel.alone(nch):
            sound = state_sound(st.F, st.T, st.V, st.w, st.q, vmax * vmax, nch)
        if sound:
            self.check_integrated()
            return
        for name in GUARDED:
            arr = getattr(st, name)
            if not all_finite(arr.reshape(-1)):
                bad = np.argwhere(~np.isfinite(arr.reshape(st.n, -1)))[0]
                self.fail(f"non-finite {name} of element {int(bad[0])}")
        i, speed2 = fastest(st.V)
        if st.n and speed2 > vmax * vmax:
            self.fail(
                f"speed of element {i} is {np.sqrt(speed2):.3g} m/s, above [run] max_speed = "
                f"{vmax:g} m/s: the run is diverging (is dt above the stable step?)"
            )

        self.check_integrated()

    def check_integrated(self) -> None:
        """Stop on a field a component integrates (``Component.integrates``) out of its bound:
        a non-finite value, or a rate above ``[run] max_speed``."""
        vmax = self.sim.scene.cfg.run.max_speed
        for owner, name, arr, bound in self.integrated:
            if not all_finite(arr):
                i = int(np.argmax(~np.isfinite(arr)))
                self.fail(f"non-finite {name} of element {i} ({owner})")
            if bound == "speed" and arr.size:
                i = int(np.argmax(np.abs(arr)))
                if abs(arr[i]) > vmax:
                    self.fail(f"{name} of element {i} is {arr[i]:.3g} m/s ({owner}), above "
                              f"[run] max_speed = {vmax:g} m/s: the run is diverging (is dt "
                              "or the component's sub-step above its stable step?)")

    def save(self) -> None:
        """Remember the current state and history as the last good snapshot."""
        sim = self.sim
        self._good = {k: getattr(sim.state, k).copy() for k in DYNAMIC}
        self._good_hist = sim.history_arrays()
        self._good_step = sim.step_index

    def fail(self, what: str, error: type = NonFiniteError, hint: str = "") -> None:
        """Go back to the last good snapshot and raise ``error``, saying where the good state is
        kept (``hint``: what to do, at the end of the line)."""
        sim = self.sim
        st = sim.state
        step = sim.step_index
        for k in DYNAMIC:
            getattr(st, k)[:] = self._good[k]
        sim.set_history_arrays(self._good_hist)
        sim.step_index = self._good_step
        saved = ""
        if sim._opened and sim.writers:
            if all(w.published for w in sim.writers):
                saved = (f"; {sim.output_path} holds the snapshots to the last good state "
                         f"(step {self._good_step}, t = {sim.time:g} s)")
            else:  # stopped before its first snapshot: the writer left nothing
                saved = f"; nothing was written to {sim.output_path}"
        raise error(f"{what} at step {step} (t = {step * sim.dt:g} s){saved}"
                    + (f"; {hint}" if hint else ""))


def integrated_fields(sim: "Run") -> list[tuple[str, str, np.ndarray, str]]:
    """``[(owner, field, values, bound)]`` of every field a component declares it integrates
    (``Component.integrates``); a declaration of a field it does not own, or of an unknown
    bound, is a :class:`~siku_core.errors.PluginError`."""
    out = []
    thick = ("engine", "thickness", sim.state.thickness, "finite")
    if sim.processes:  # the processes integrate the thickness
        out.append(thick)
    for comp in sim.components():
        owner = f"{comp.kind} '{comp.name}'"
        owned = {f.name for f in comp.owned_fields}
        for name, bound in dict(comp.integrates or {}).items():
            if name not in owned or bound not in BOUNDS:
                raise PluginError(f"{owner}: integrates {name!r} as {bound!r}; it must name a "
                                  f"field of its owned_fields and one of {', '.join(BOUNDS)}")
            out.append((owner, name, sim.ice.values[name].reshape(-1), bound))
    return out


class NetworkWatch:
    """The joints after every step: the stable step rechecked as they change (one comparison
    per joint, whoever broke or froze them), and the breaking rate (:class:`BreakRate`)."""

    def __init__(self, sim: "Run", guard: Guard):
        cm = sim.contacts
        self.sim = sim
        self.cm = cm if cm is not None and cm.law.uses_joints else None
        if self.cm is None:
            return
        self._seen = cm.n_broken_total
        self._checked = cm.intact.copy()
        self._n_checked = int(self._checked.sum())
        mode = sim.scene.cfg.run.break_guard
        self.rate = BreakRate(sim, guard) if mode != "off" and cm.n_joints else None

    def after_step(self) -> None:
        cm = self.cm
        if cm is None:
            return
        broke = cm.n_broken_total - self._seen
        self._seen = cm.n_broken_total
        if self.rate is not None:
            if broke:  # the law's own breaks only: not melting, waves or other components
                sim = self.sim
                new = cm.break_time > sim.time - 1.5 * sim.dt  # (broke in this step)
                broke -= int(np.count_nonzero(new & np.isin(cm.break_mode, OUTSIDE_BREAKS)))
            self.rate.record(broke)
        self._recheck()

    def _recheck(self) -> None:
        """Check the step again once more than :data:`RECHECK_JOINTS` of the joints changed."""
        cm = self.cm
        now, old = cm.intact, self._checked
        changed = int(np.count_nonzero(now[:len(old)] != old)
                      + np.count_nonzero(now[len(old):]))
        if changed <= RECHECK_JOINTS * max(self._n_checked, 1):
            return
        before = self._n_checked
        self._checked = now.copy()
        self._n_checked = int(now.sum())
        self.sim.check_time_step(
            after=f"{changed} joint{'s' if changed > 1 else ''} broke or froze "
                  f"({changed / max(before, 1):.1%} of the {before} intact at the last check)")


class BreakRate:
    """Stop (or warn on) a run in which more than :data:`BREAK_SHARE` of the intact joints
    break within :data:`CROSSINGS` elastic crossing times of an element (at least
    :data:`MIN_WINDOW` steps), and more than one fracture could break in that time.

    The window is ``max(MIN_WINDOW, CROSSINGS L / (c dt))`` steps, ``L`` the median size
    ``sqrt(area)`` [m] of the free elements, ``c = sqrt(E / rho)`` [m/s] the fastest
    elastic wave of their ice; one fracture breaks at most ``JOINTS_PER_CROSSING (sqrt(n) +
    min(c dt / L, 1) W + 1)`` joints in ``W`` steps: a line across the pack of ``n`` free
    elements at once, and a crack tip's run from it."""

    def __init__(self, sim: "Run", guard: Guard):
        self.sim = sim
        self.guard = guard
        st, cm = sim.state, sim.contacts
        free = st.flags == FREE
        rho = st.m / (st.area * st.thickness)  # [kg/m³] (the ice's density)
        c = float(np.sqrt(cm.E[free] / rho[free]).max()) if free.any() else 0.0
        size = float(np.median(np.sqrt(st.area[free]))) if free.any() else 0.0
        #: the elastic crossing time of an element [s]
        self.crossing = size / c if c > 0 else math.inf
        self.window = max(MIN_WINDOW, math.ceil(CROSSINGS * self.crossing / sim.dt)
                          if math.isfinite(self.crossing) else MIN_WINDOW)
        per_step = min(sim.dt / self.crossing, 1.0) if self.crossing > 0 else 1.0
        #: the joints one fracture can break within the window: a line across the pack at once
        #: (a uniformly loaded section: the joints along a coast, a shear band) and its tip's
        #: run
        across = math.sqrt(max(int(free.sum()), 1))
        self.one_crack = JOINTS_PER_CROSSING * (across + per_step * self.window + 1.0)
        self._breaks: deque[tuple[int, int]] = deque()  # (step, joints broken) in the window
        self._in_window = 0
        self._warned = False

    def record(self, broke: int) -> None:
        """Count the joints that broke in the step just taken and judge the window."""
        step = self.sim.step_index
        if broke:
            self._breaks.append((step, broke))
            self._in_window += broke
        while self._breaks and self._breaks[0][0] <= step - self.window:
            self._in_window -= self._breaks.popleft()[1]
        if self._in_window <= self.one_crack or self._warned:
            return
        intact = self.sim.contacts.n_intact + self._in_window  # (at the window's start)
        share = self._in_window / max(intact, 1)
        if share <= BREAK_SHARE:
            return
        sim = self.sim
        what = (f"{self._in_window} of {intact} intact joints ({share:.0%}) broke within "
                f"{self.window} steps ({self.window * sim.dt:.3g} s, "
                f"{self.window * sim.dt / self.crossing:.2g} elastic crossing times of an "
                f"element), faster than cracks can run (above "
                f"{BREAK_SHARE:.0%}): the run is unstable")
        hint = (f"shorten dt (now {sim.dt:g} s; the estimated critical step is "
                f"{sim.critical_dt:.4g} s)")
        if sim.scene.cfg.run.break_guard == "warn":
            self._warned = True
            warnings.warn(f"{what} at step {sim.step_index} (t = {sim.time:g} s); {hint}; "
                          "continuing because [run] break_guard = \"warn\"", stacklevel=2)
            return
        self.guard.fail(what, StabilityError, hint + " or set [run] break_guard = \"warn\"")


def check_initial_state(sim: "Run") -> None:
    """Refuse a run whose state is not finite before step 1 (a NaN velocity or spin in the
    scene, or in a restart file)."""
    st = sim.state
    for name, what in (("q", "position"), ("V", "velocity"), ("w", "spin")):
        arr = getattr(st, name).reshape(st.n, -1)
        bad = ~np.isfinite(arr).all(axis=1)
        if bad.any():
            i = int(np.argmax(bad))
            src = (f"restart file {sim.restart_path}" if sim.restart_path is not None
                   else sim.scene.where("elements"))
            raise SceneError(f"{src}: element {i} starts with a non-finite {what} "
                             f"{arr[i].tolist()}; the run needs finite numbers")
    vmax = sim.scene.cfg.run.max_speed
    speed = np.hypot(st.V[:, 0], st.V[:, 1]) if st.n else np.zeros(0)
    if speed.size and speed.max() > vmax:
        i = int(np.argmax(speed))
        src = (f"restart file {sim.restart_path}" if sim.restart_path is not None
               else sim.scene.where("elements"))
        raise SceneError(f"{src}: element {i} starts with a speed of {speed[i]:.3g} m/s, above "
                         f"[run] max_speed = {vmax:g} m/s; give a smaller velocity (or raise "
                         "max_speed)")


def check_time_step(sim: "Run", after: str = "") -> None:
    """Refuse (or warn on) a dt above ``dt_safety`` times the smallest component limit.

    Every component may declare ``stability_limit(ctx) -> (dt_max [s], reason) | None``
    (:meth:`~siku_core.interfaces.Component.stability_limit`; the default is no limit).
    Checked before the run and again whenever a process has changed the ice or the joints
    have changed (``after`` says what, siku_core.ice and :class:`Guard`). Sets
    ``sim.critical_dt`` [s] and ``sim.critical_by`` (the component and its reason).
    """
    run = sim.scene.cfg.run
    limits = []
    for comp in [*sim.components(), *([sim.contacts] if sim.contacts else [])]:
        lim = comp.stability_limit(sim.context)
        if lim is not None:
            limits.append((lim[0], comp.name, lim[1]))
    if not limits:
        sim.critical_dt = math.inf
        return
    dt_c, who, why = min(limits, key=lambda x: x[0])
    sim.critical_dt, sim.critical_by = dt_c, (who, why)
    safe = run.dt_safety * dt_c
    if sim.dt > safe:
        when = f" after {after} at t = {sim.time:g} s" if after else ""
        msg = (
            f"{sim.scene.where('time')}: dt = {sim.dt:g} s is above the safe step "
            f"{safe:.4g} s{when} ({run.dt_safety:g} × critical {dt_c:.4g} s set by "
            f"'{who}': {why})")
        if run.allow_unstable_dt:
            warnings.warn(msg + "; continuing because [run] allow_unstable_dt = true",
                          stacklevel=3)
        else:
            raise StabilityError(msg + "; lower dt or set [run] allow_unstable_dt = true")
