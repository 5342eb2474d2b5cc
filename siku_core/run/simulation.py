"""The run loop: builds components from a scene and advances the time step.

One step (``docs/explanation/design.md``)::

    forcing sources  -> add F, T per element
    (contacts: broad phase, narrow phase, contact laws -> add F, T per pair)
    integrator       -> moves free elements; static never, steady on rails
    processes        -> change the ice on their schedules (siku_core.ice)
    guards (joints every step; NaN on a schedule), diagnostics and writers on schedules
Restarting: siku_core.run.restart; guards: siku_core.run.guard; components see siku_core.context.
"""
from __future__ import annotations

import datetime as _dt
import math
from pathlib import Path
from typing import Any

import numpy as np

from .. import parallel
from ..diagnostics import element_diagnostics, held_forces
from ..contact.contacts_view import ContactsView
from ..context import Context
from ..categories import one_category
from .elements import build_elements_and_categories
from .guard import Guard, check_initial_state, check_time_step
from ..versions import __version__
from ..errors import SceneError, check_argument, is_path
from ..ice import IceBook, apply_processes, process_schedule
from ..interfaces import Component, Field, ForcingSource, Integrator, Process, Writer
from .limits import check_limits
from .outputs import check_output_path, extra_output_paths, input_paths, options
from ..params import validate_params
from ..plugins import Registry, get_plugin_manager, get_registry, package_of
from ..scene.scene_file import Scene, load_scene
from .progress import CompileProgress, clock, compile_time
from .ramp import ForcingRamps
from .restart import history as history_of
from .restart import restart, set_history
from .schedule import StepInterval, fit_time_step

#: phases of a step timed in ``Simulation.timings`` [s], in step order: forcing sources; the
#: contact joints; the broad phase (candidate-list rebuilds); narrow phase and collision law;
#: the per-element sums of contact forces (with the rotation matrices they use, and the check
#: whether the candidate list is due for a rebuild, done in the same pass);
#: the integrator (its own work, without the force evaluations); the processes that change the
#: ice (with what they make the engine recompute); the NaN guard; writers; on MPI ranks
#: (``siku_core.ranks``), the exchanges with the other ranks and the redistributions
PHASES = ("forcing", "joints", "broad_phase", "collisions", "contact_sum", "integrator",
          "processes", "guard", "output", "exchange", "redistribute")


class Simulation:
    """A run of one scene.

    Parameters
    ----------
    scene : a :class:`~siku_core.scene.scene_file.Scene` or a path to a scene file.
    out : output file, overriding ``[output] file``; ``False`` writes nothing; ``"memory"``
        writes nothing and keeps the snapshots of ``[output] every`` in memory, in the output
        file's layout, for :meth:`to_xarray`.
    progress : show a progress bar (``None``: as the scene says, else only on long runs).
    restart : continue from the last complete snapshot in this output file; refused when the
        scene differs from the run that wrote it (``force=True`` restarts anyway) or when that
        run is complete (``extend`` [s] runs longer).
    overwrite : replace an existing output file (kept whole until the new one holds a snapshot).
    registry : component registry (default: the process-wide one).
    """

    def __init__(
        self,
        scene: Scene | str | Path,
        *,
        out: str | Path | bool | None = None,
        progress: bool | None = None,
        restart: str | Path | None = None,
        registry: Registry | None = None,
        overwrite: bool = False,
        force: bool = False,
        extend: float | None = None,
    ):
        check_argument("Simulation", "scene", scene, isinstance(scene, Scene) or is_path(scene),
                       "a Scene (siku_core.scene.scene_file.load_scene) or the path of a scene "
                       "file")
        check_argument("Simulation", "out", out, out is None or isinstance(out, bool)
                       or is_path(out), "the path of the output file, or False to write none")
        check_argument("Simulation", "restart", restart, restart is None or is_path(restart),
                       "the path of the output file to continue")
        check_argument("Simulation", "extend", extend, extend is None or (
            isinstance(extend, (int, float)) and not isinstance(extend, bool)
            and math.isfinite(extend) and extend > 0), "a positive duration in seconds")
        if not isinstance(scene, Scene):
            scene = load_scene(scene)
        self.scene = scene
        cfg = scene.cfg
        check_limits(scene)
        if extend is not None and restart is None:
            said = options()
            raise SceneError(f"{said.extend.rstrip(' =')} continues a finished run: give the "
                             f"file with {said.restart.rstrip(' =')}")
        self.registry = registry or get_registry()
        self.output_path: Path | None = None
        #: the snapshots are kept in memory (``out="memory"``), not written
        self.in_memory = isinstance(out, str) and out == "memory"
        if out is not False and not self.in_memory:
            # a restart continues its file unless --out names another
            writer_cls = self.registry.get("writer", cfg.output.writer,
                                           where=f"{scene.where('output')}: ")
            self.output_path = (Path(out) if out not in (None, True) else Path(restart)
                                if restart is not None else Path(cfg.output.file))
            check_output_path(self.output_path, input_paths(scene), overwrite=overwrite,
                              appending_to=Path(restart) if restart is not None else None,
                              ours=writer_cls.owns, folder=writer_cls.folder)
        #: the files of the scene's further writers ([[output.extra]]), in order
        self.extra_paths = extra_output_paths(
            scene, self.output_path, overwrite, restart is not None,
            lambda name, where: self.registry.get("writer", name, where=where))
        self.pm = get_plugin_manager() if registry is None else None
        if self.pm is not None:
            self.pm.hook.siku_configured(scene=scene)
        self.radius = cfg.planet.radius
        self.rotation_rate = cfg.planet.rotation_rate
        self.dt_requested = float(cfg.time.dt)
        # the step is fitted (never lengthened) so that the end and every output time fall on
        # steps exactly (schedule.fit_time_step); `exact_times` is False where that is impossible
        self.dt, self.exact_times = fit_time_step(
            self.dt_requested, cfg.time.total,
            (cfg.output.every, cfg.output.diagnostics_every, *(p.every for p in cfg.process)))
        self.n_steps = max(1, math.ceil(cfg.time.total / self.dt - 1e-9))
        self.start: _dt.datetime | None = cfg.time.start
        self.seed = cfg.run.seed
        self.rng = np.random.default_rng(self.seed)
        self.state, categories = build_elements_and_categories(scene, self.registry)
        self.step_index = 0
        #: the time origin ``(k0, t0)``: model time is ``t0 + (step_index - k0) * dt`` [s];
        #: (0, 0.0) unless a restart changed the step (siku_core.run.restart.restore)
        self.time_origin: tuple[int, float] = (0, 0.0)
        #: what components see of the run (siku_core.context): handed to their setup and hooks
        self.context = Context(self, ContactsView)
        self.progress = cfg.run.progress if progress is None else progress

        self.integrator: Integrator = self._component(  # type: ignore[assignment]
            "integrator", cfg.integrator.name, cfg.integrator.params, "integrator")
        self.forcing: list[ForcingSource] = [
            self._forcing_source(k, f) for k, f in enumerate(cfg.forcing)]
        #: the forcing sources' spin-ups (``[[forcing]] ramp``, siku_core.run.ramp)
        self._ramps = ForcingRamps(cfg.forcing)

        self.timings: dict[str, float] = dict.fromkeys(PHASES, 0.0)
        self.contacts = self._contact_model() if cfg.contact is not None else None
        self._commit = True
        #: the scene's processes (``[[process]]``) and the steps between their applications
        self.processes: list[Process] = [
            self._component("process", p.name, p.params, f"process[{k}]")  # type: ignore
            for k, p in enumerate(cfg.process)]
        self._process_every = [process_schedule(p.every, self.dt, scene.where(f"process[{k}]"))
                               for k, p in enumerate(cfg.process)]

        self.writers: list[Writer] = [self._writer()] if self.output_path is not None else []
        if self.in_memory:
            self.writers.append(self._component("writer", "memory", {}, "output"))  # type: ignore
        for k, (x, path) in enumerate(zip(cfg.output.extra, self.extra_paths)):
            w = self._component("writer", x.writer, x.params, f"output.extra[{k}]")
            w.path = path  # type: ignore[attr-defined]
            self.writers.append(w)  # type: ignore[arg-type]
        for w in self.writers:
            w.overwrite = bool(overwrite)  # what --overwrite allows, told to every writer
        self.state_schedule = StepInterval.snapshots(cfg.output.every, self.dt, self.n_steps)
        self.diag_schedule = StepInterval.diagnostics(cfg.output.diagnostics_every, self.dt,
                                                      self.n_steps)
        if categories is None and any(p.needs_categories for p in self.processes):
            categories = one_category(self.state.thickness)  # a concentration per element
        #: declared per-element fields and the changing thickness (siku_core.ice)
        self.ice = IceBook(self, processes=bool(self.processes), categories=categories)
        if self.processes and self.contacts is not None:
            self.contacts.rest_state_is_history = True  # processes may refreeze joints
            self.contacts.reserve_joints(sum(p.joints_to_create(self.state.n)
                                             for p in self.processes))
        for comp in self.components():
            comp.setup(self.context)
        if self.contacts is not None:
            self.contacts.setup()
        self.check_time_step()
        self.restarted_from: int | None = None
        self.restart_path: Path | None = None
        if restart is not None:
            self._restart(Path(restart), force=force, extend=extend)
        check_initial_state(self)
        #: the NaN guard and the last good snapshot it returns to (siku_core.run.guard)
        self.guard = Guard(self)
        self._opened = False
        self._force_time = 0.0
        self.timed_steps = 0
        #: seconds numba spent compiling kernels during :meth:`run` and :meth:`advance` [s]
        self.compile_seconds = 0.0
        #: :meth:`run` chooses between one thread and those set, timing both as it steps
        #: (:class:`~siku_core.parallel.ThreadTuner`; ``siku run`` without ``--threads``)
        self.auto_threads = False
        #: a :class:`~siku_core.run.phase_log.PhaseLog` reading the phases by hour (``--profile``)
        self.phase_log = None
        if self.pm is not None:
            self.pm.hook.siku_ready(simulation=self)

    # ------------------------------------------------------------------ construction
    def _component(self, kind: str, name: str, params: dict, table: str) -> Component:
        where = self.scene.where(table)
        cls = self.registry.get(kind, name, where=f"{where}: ")
        full = validate_params(name, cls.params, params, where)
        comp = cls(full)
        comp.table = table
        return comp

    def _contact_model(self) -> Any:
        """The ``[contact]`` table's law and broad phase, built like every component, in a
        :class:`~siku_core.contact.contact_model.ContactModel`."""
        from ..contact.contact_model import ContactModel

        scene, cc = self.scene, self.scene.cfg.contact
        return ContactModel(
            cc, self.state, self.radius, list(scene.cfg.materials.values()),
            law=self._component("contact_law", cc.law, cc.params, "contact"),
            broad=self._component("broad_phase", cc.broad_phase, {}, "contact"),
            time_step=lambda: self.dt, where=scene.where("contact"), label=scene.label,
            timings=self.timings)

    def _writer(self) -> Writer:
        """The writer of ``[output]``, writing to :attr:`output_path`."""
        out = self.scene.cfg.output
        w: Writer = self._component("writer", out.writer, out.params, "output")  # type: ignore
        w.path = self.output_path
        return w

    def _forcing_source(self, k: int, f: Any) -> ForcingSource:
        """The source of ``[[forcing]]`` table ``k`` (``f``), with its ``field`` if any."""
        scene = self.scene
        src: ForcingSource = self._component(
            "forcing", f.source, f.params, f"forcing[{k}]"
        )  # type: ignore[assignment]
        if f.field is not None:
            if not src.uses_field:
                raise SceneError(
                    f"{scene.where(f'forcing[{k}]')}: forcing source '{f.source}' takes no "
                    "'field' table"
                )
            src.field = self._component(
                "field", f.field.type, f.field.params, f"forcing[{k}].field"
            )  # type: ignore[assignment]
            if not src.accepts_field(type(src.field)):
                raise SceneError(
                    f"{scene.where(f'forcing[{k}].field')}: forcing source '{f.source}' "
                    f"cannot use a field of type '{f.field.type}'"
                )
        elif src.uses_field and src.field_required:
            raise SceneError(
                f"{scene.where(f'forcing[{k}]')}: forcing source '{f.source}' needs a "
                "'field' table, e.g. field = {type = \"uniform\", params = {u = 10.0}}"
            )
        return src

    def components(self) -> list[Component]:
        """Every component of the run, in step order."""
        out: list[Component] = []
        for f in self.forcing:
            out.append(f)
            if f.field is not None:
                out.append(f.field)
        if self.contacts is not None:
            out.extend([self.contacts.broad, self.contacts.law])
        out.append(self.integrator)
        out.extend(self.processes)
        out.extend(self.writers)
        return out

    def check_time_step(self, after: str = "") -> None:
        """Refuse (or warn on) a dt above ``dt_safety`` times the smallest component limit
        (:func:`siku_core.run.guard.check_time_step`); ``after`` says what changed."""
        check_time_step(self, after)

    # ------------------------------------------------------------------ physics
    @property
    def time(self) -> float:
        """Model time since the start [s]: ``t0 + (step_index - k0) * dt`` from the time
        origin (:attr:`time_origin`; ``step_index * dt`` bit for bit when the step never
        changed)."""
        k0, t0 = self.time_origin
        if k0 == 0 and t0 == 0.0:
            return self.step_index * self.dt
        return t0 + (self.step_index - k0) * self.dt

    @property
    def committing(self) -> bool:
        """True during the first force evaluation of a step, the one whose joint history and
        breaks count (forcing sources that change joints act only then)."""
        return self._commit

    def datetime_at(self, t: float) -> _dt.datetime | None:
        return None if self.start is None else self.start + _dt.timedelta(seconds=t)

    def compute_forces(self, t: float, q, V, w, F, T) -> None:
        """Fill ``F`` [N] and ``T`` [N m] for the state ``q, V, w`` at time ``t`` [s]."""
        t0 = clock()
        F.fill(0.0)
        T.fill(0.0)
        self._ramps.add(self.forcing, t, q, V, w, F, T)
        t1 = clock()
        self.timings["forcing"] += t1 - t0
        if self.contacts is not None:
            self.contacts.add(t, q, V, w, F, T, self._commit)
        self._commit = False
        self._force_time += clock() - t0

    def step(self) -> None:
        """Advance one time step and run the NaN guard on its schedule.

        Every phase's wall time accumulates in :attr:`timings` (seconds, keys :data:`PHASES`;
        ``integrator`` excludes the force evaluations it calls); ``siku run --profile`` prints
        them, compilation left out (:func:`siku_core.run.progress.clock`).
        """
        if self.phase_log is not None:
            self.phase_log.before_step(self)
        t0 = clock()
        self._commit = True
        self._force_time = 0.0
        with parallel.threads_for(self.state.n):
            self.integrator.step(self.state, self.time, self.dt, self.compute_forces)
        self.step_index += 1
        t1 = clock()
        self.timings["integrator"] += t1 - t0 - self._force_time
        if self.processes:
            apply_processes(self)
            t2 = clock()
            self.timings["processes"] += t2 - t1
            t1 = t2
        self.guard.after_step()  # the joints: the step rechecked, the breaking rate
        if (self.step_index % self.scene.cfg.run.nan_check_every == 0
                or self.step_index == self.n_steps):
            self.guard.check()
        self.timings["guard"] += clock() - t1
        self.timed_steps += 1

    def profile(self) -> list[tuple[str, float]]:
        """``(phase, seconds)`` of every phase of :data:`PHASES` with time spent, in order."""
        return [(k, self.timings[k]) for k in PHASES if self.timings.get(k, 0.0) > 0.0]

    def reset_timings(self) -> None:
        for k in self.timings:
            self.timings[k] = 0.0
        self.timed_steps = 0

    def diagnostics(self) -> dict[str, Any]:
        """The diagnostics of the current state (``siku_core.diagnostics.DIAGNOSTICS`` lists
        them with units): energy, momenta, speeds, the forces on held elements (of the last
        force evaluation), the contact model's and those of components that report some."""
        st = self.state
        d = {"step": self.step_index, "time": self.time}
        d.update(element_diagnostics(st.q, st.V, st.w, st.m, st.I, self.radius))
        d.update(held_forces(st.F, st.flags))
        if self.contacts is not None:
            d.update(self.contacts.diagnostics())
        for comp in self.components():
            if comp.diagnostic_units:
                got = comp.diagnostics(self.context)
                for name in comp.diagnostic_units:
                    d[name] = float(got[name])
        return d

    def element_fields(self) -> dict[str, np.ndarray]:
        """Per-element fields: ``speed`` [m/s]; with contacts ``damage`` [1] and stresses; the
        declared ones and, with processes, thickness, mass, flags (siku_core.ice)."""
        st = self.state
        out = {"speed": np.hypot(st.V[:, 0], st.V[:, 1])}
        if self.contacts is not None:
            out.update(self.contacts.element_fields())
        out.update(self.ice.element_fields())
        return out

    # ------------------------------------------------------------------ running
    def run_record(self) -> dict[str, Any]:
        """What the run's results depend on: the effective scene (after overrides), every
        component's parameters (defaults included), the versions of the packages that provided
        them, the seed and ``dt`` [s]. Writers store it; a restart compares it with its own."""
        comps: dict[str, Any] = {}
        for k, c in enumerate(self.components()):
            if c.kind != "writer":
                comps[f"{c.kind}{k}_{c.name}"] = c.describe()
        if self.contacts is not None:
            comps["contacts"] = self.contacts.describe()
        return {"scene": self.scene.cfg.model_dump(mode="json"), "components": comps,
                "versions": {"siku": __version__, **self.plugin_versions()},
                "seed": self.seed, "dt": self.dt}

    def _restart(self, path: Path, force: bool = False, extend: float | None = None) -> None:
        """Continue from the last snapshot of ``path`` (:func:`siku_core.run.restart.restart`)."""
        restart(self, path, force=force, extend=extend)

    def open_outputs(self) -> None:
        if self._opened:
            return
        for w in self.writers:
            w.open(self.context)
        self._opened = True
        if self.writers:  # load the output's compiled kernels now (start-up, like the step's)
            self.diagnostics()
            self.element_fields()
        # the initial snapshot (a restart's first row, unless it continues the same file)
        self._write(force=True, diagnostics=self.restarted_from is None)

    def _write(self, force: bool = False, diagnostics: bool = True) -> None:
        """Write what the schedules ask for at this step. A snapshot is the last good state:
        the guard checks it first (if it has not at this step), then it is remembered."""
        t0 = clock()
        k, last = self.step_index, self.n_steps
        snapshot = force or self.state_schedule.due(k, last)
        if snapshot and self.guard.checked_step != k:
            self.guard.check()
            tg = clock()
            self.timings["guard"] += tg - t0  # the guard's time is the guard's, not output's
            t0 = tg
        if self.writers:
            if diagnostics and (force or self.diag_schedule.due(k, last)):
                d = self.diagnostics()
                for w in self.writers:
                    w.write_diagnostics(self.context, d)
            if snapshot:
                for w in self.writers:
                    w.write_state(self.context)
        if snapshot:
            self.guard.save()
        self.timings["output"] += clock() - t0

    def run(self, steps: int | None = None) -> "Simulation":
        """Run ``steps`` steps (default: to the end of the scene's time span). More steps
        than remain before the scene's end raise :class:`SceneError` saying how many remain
        (nothing is run); a finished run is lengthened by a restart with ``extend``."""
        check_argument("Simulation.run", "steps", steps, steps is None or (
            isinstance(steps, (int, np.integer)) and not isinstance(steps, bool)
            and steps >= 0), "a whole number of steps, 0 or more (None: to the scene's end)")
        left = self.n_steps - self.step_index
        if steps is not None and steps > left:
            raise SceneError(
                f"{self.scene.label}: run(steps={steps}) goes past the scene's end: "
                f"{left} of {self.n_steps} steps remain (t = {self.time:g} s, "
                f"dt = {self.dt:g} s); "
                "give steps <= the steps left, or lengthen the scene's time span")
        remaining = left if steps is None else steps
        show = self.progress
        # the whole loop on the threads the scene's size warrants (set once, not per step)
        with compile_time(self), parallel.threads_for(self.state.n), \
                parallel.tuned(self.auto_threads, clock) as tune:
            self._loop(remaining, show, tune)
        return self

    def _loop(self, remaining: int, show: bool | None, tune) -> None:
        """The steps of :meth:`run`, with their progress bar; closes the outputs at the end."""
        bar = None
        try:
            # the first step compiles the kernels: shown, and kept off the bar
            with CompileProgress(enabled=show is None or bool(show)):
                self.open_outputs()
                if remaining > 0:
                    self.step()
                    self._write()
                    remaining -= 1
            if show is None or show:
                from tqdm.auto import tqdm

                bar = tqdm(total=remaining, unit="step", desc=self.scene.cfg.title or "siku",
                           disable=show is False, delay=0.0 if show else 2.0, mininterval=0.5,
                           leave=False)
            for _ in range(remaining):
                with tune:
                    self.step()
                    self._write()
                if bar is not None:
                    bar.update(1)
        finally:
            if bar is not None:
                bar.close()
            self.close()

    def advance(self, steps: int) -> None:
        """Take ``steps`` steps, writing on the schedules, and leave the outputs open (a
        coupled run advanced by another model; :meth:`close` ends it)."""
        self.open_outputs()
        with compile_time(self), parallel.threads_for(self.state.n):
            for _ in range(steps):
                self.step()
                self._write()

    def close(self) -> None:
        if self._opened:
            for w in self.writers:
                w.close(self.context)
            self._opened = False
        for f in self.forcing:
            if isinstance(f.field, Field):
                f.field.close()
        for proc in self.processes:
            proc.close()
        if self.pm is not None:
            self.pm.hook.siku_finished(simulation=self)

    def to_xarray(self, group: str | None = None, outlines: bool = True,
                  decode_times: bool = True) -> Any:
        """The run as an ``xarray.Dataset``: the same variables, units, coordinates and values as
        ``xr.open_dataset(FILE, engine="siku", group=group, outlines=outlines)`` gives for the
        output file of the same run. A run made with ``out="memory"`` gives every snapshot it
        kept; any other (``out=False``, or one writing a file) the state now, as one snapshot
        (the file's last after :meth:`run`). ``group``: ``None`` (the elements),
        ``"diagnostics"`` or ``"breaks"``."""
        kept = next((w for w in self.writers if w.in_memory), None)
        if kept is not None and kept.holds_snapshots():
            return kept.dataset(group, outlines, decode_times)  # type: ignore[attr-defined]
        now = self._component("writer", "memory", {}, "output")
        now.open(self.context)
        now.write_diagnostics(self.context, self.diagnostics())
        now.write_state(self.context)
        return now.dataset(group, outlines, decode_times)  # type: ignore[attr-defined]

    def history_arrays(self) -> dict[str, dict[str, np.ndarray]]:
        """Every component's history for an exact restart
        (:func:`siku_core.run.restart.history`)."""
        return history_of(self)

    def set_history_arrays(self, hist: dict[str, dict[str, np.ndarray]]) -> None:
        """Put history back (:func:`siku_core.run.restart.set_history`)."""
        set_history(self, hist)

    def plugin_versions(self) -> dict[str, str]:
        """Packages that provided the components of this run, with versions."""
        out = {}
        for comp in self.components():
            e = self.registry.entry(comp.kind, comp.name)
            if e is not None and e.cls is type(comp):
                out[e.package] = e.version
            else:  # chosen by path, or built inside another component (a forcing's field)
                package, version = package_of(type(comp))
                out[package] = version
        return out
