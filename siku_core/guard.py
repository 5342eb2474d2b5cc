"""The run's NaN guard: a diverging run stops at the last good snapshot, never with bad data.

:class:`Guard` checks the state on the scene's schedule (``[run] nan_check_every``) and before
every snapshot: a non-finite force, torque, velocity, spin or orientation, or a speed above
``[run] max_speed``, puts the state and every component's history back to the last good
snapshot (the last one written, or due to be written when the run writes nothing) and raises
:class:`~siku_core.errors.NonFiniteError` naming the quantity, the element and the step.
:func:`check_initial_state` refuses a run that starts from non-finite numbers.
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from . import parallel
from .diagnostics import all_finite, fastest, state_sound
from .errors import NonFiniteError, SceneError
from .state import DYNAMIC

if TYPE_CHECKING:  # pragma: no cover
    from .simulation import Simulation

#: quantities checked by the NaN guard, in the order their failure is reported
GUARDED = ("F", "T", "V", "w", "q")


class Guard:
    """The NaN guard of one run and the last good snapshot it returns to."""

    def __init__(self, sim: "Simulation"):
        self.sim = sim
        #: the step the state was last checked at (``-1``: not yet)
        self.checked_step = -1
        self.save()

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
            return
        for name in GUARDED:
            arr = getattr(st, name)
            if not all_finite(arr.reshape(-1)):
                bad = np.argwhere(~np.isfinite(arr.reshape(st.n, -1)))[0]
                self._fail(f"non-finite {name} of element {int(bad[0])}")
        i, speed2 = fastest(st.V)
        if st.n and speed2 > vmax * vmax:
            self._fail(
                f"speed of element {i} is {np.sqrt(speed2):.3g} m/s, above [run] max_speed = "
                f"{vmax:g} m/s: the run is diverging (is dt above the stable step?)"
            )

    def save(self) -> None:
        """Remember the current state and history as the last good snapshot."""
        sim = self.sim
        self._good = {k: getattr(sim.state, k).copy() for k in DYNAMIC}
        self._good_hist = sim.history_arrays()
        self._good_step = sim.step_index

    def _fail(self, what: str) -> None:
        """Go back to the last good snapshot and raise, saying where the good state is kept."""
        sim = self.sim
        st = sim.state
        step = sim.step_index
        for k in DYNAMIC:
            getattr(st, k)[:] = self._good[k]
        sim.set_history_arrays(self._good_hist)
        sim.step_index = self._good_step
        saved = ""
        if sim._opened and sim.writers:
            if all(getattr(w, "published", True) for w in sim.writers):
                saved = (f"; {sim.output_path} holds the snapshots to the last good state "
                         f"(step {self._good_step}, t = {sim.time:g} s)")
            else:  # stopped before its first snapshot: the writer left nothing
                saved = f"; nothing was written to {sim.output_path}"
        raise NonFiniteError(f"{what} at step {step} (t = {step * sim.dt:g} s){saved}")


def check_initial_state(sim: "Simulation") -> None:
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
