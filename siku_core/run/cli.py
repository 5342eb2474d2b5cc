"""Command line: ``siku run``, ``siku plugins``, and the commands plugins add.

The engine's own commands are ``run``, ``warm`` and ``plugins``; every other command (``plot``,
``ensemble``, ``grid``, ``lab``, a third party's) is
added by the package that owns it through the ``siku_register_commands`` hook, as datasette
plugins add commands. A command whose parser sets the default ``raw_args=True`` gets the rest
of the command line as it is (``func(argv)``: a runner with its own options). Bad input exits
with status 2 and a one-line message (no traceback).
"""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import sys
import time
import warnings
from importlib import resources
from pathlib import Path

from ..versions import __version__
from ..errors import SceneError, SikuError, shown
from .outputs import command_line

DEFAULT_SCENE = "default_scene.toml"
_KIND_TITLES = {
    "integrator": "integrators", "forcing": "forcing sources", "field": "velocity fields",
    "broad_phase": "broad phases", "contact_law": "contact laws", "writer": "writers",
    "element_source": "element sources", "process": "processes (change the ice)",
    "attenuation_law": "attenuation laws (how ice damps waves)",
}


def default_scene_path() -> Path:
    """The scene shipped with the package, run by ``siku run`` with no argument."""
    return Path(str(resources.files("siku_core") / "data" / DEFAULT_SCENE))


def _cmd_run(args: argparse.Namespace) -> int:
    path = Path(args.scene) if args.scene else default_scene_path()
    overrides = {}
    for item in args.set or []:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise SceneError(f"--set {item!r}: write KEY=VALUE, e.g. --set time.duration=6h")
        overrides[key.strip()] = value.strip()
    if args.ranks is not None:
        return _relaunch(args.ranks, args.argv)
    if args.threads is not None:
        import numba

        before = numba.get_num_threads()
        _set_threads(args.threads)
        try:
            return _run(args, path, overrides)
        finally:
            numba.set_num_threads(before)
    return _run(args, path, overrides)


def _run(args: argparse.Namespace, path: Path, overrides: dict) -> int:
    from .progress import CompileProgress
    from ..scene.scene_file import load_scene, refuse_unitless_durations
    from .simulation import Simulation

    refuse_unitless_durations(overrides, str(path))
    scene = load_scene(path, overrides)
    progress = False if args.no_progress else None
    extend = None
    if args.extend is not None:
        from ..scene.units import parse_duration

        try:
            extend = parse_duration(args.extend)
        except ValueError as exc:
            raise SceneError(f"--extend {args.extend!r}: {exc}") from None
    from ..ranks import launched_ranks

    ranks = launched_ranks()
    comm = None
    out = args.out
    if ranks > 1:  # under mpiexec: rank 0 writes, every rank steps (siku_core.ranks)
        from ..ranks import launched_rank
        from ..ranks.comm import Comm

        if launched_rank():
            sys.stderr = open(os.devnull, "w")  # rank 0 speaks for the run
        comm = Comm()
        if comm.rank:
            out, progress = False, False
            sys.stderr = open(os.devnull, "w")  # rank 0 speaks for the run
    with CompileProgress(enabled=progress is None), _together(comm):
        sim = Simulation(scene, out=out, progress=progress, restart=args.restart,
                         overwrite=args.overwrite, force=args.force, extend=extend)
    first = sim.step_index
    sim.auto_threads = auto_threads(args.threads)
    if args.profile:
        from .phase_log import PhaseLog

        sim.phase_log = PhaseLog(sim)
    t0 = time.perf_counter()
    fitted = ("" if sim.dt == sim.dt_requested else
              f" ({sim.dt_requested:g} s in the scene, shortened so that outputs fall on steps)")
    print(f"siku {__version__}: {scene.cfg.title or path.name}: "
          f"{plural(sim.state.n, 'element')}, {plural(sim.n_steps - sim.step_index, 'step')} "
          f"of {sim.dt:.6g} s{fitted}", file=sys.stderr)
    if math.isfinite(sim.critical_dt):
        who, why = sim.critical_by
        print(f"stable step: critical {sim.critical_dt:.4g} s, the step is "
              f"{sim.dt / sim.critical_dt:.2f} of it (accepted up to "
              f"{scene.cfg.run.dt_safety:g}); set by '{who}': {why}", file=sys.stderr)
    try:
        if comm is not None:
            from ..ranks.driver import RankRun

            on_ranks = RankRun(sim, comm)  # (refuses what cannot run on ranks)
            print(f"on {ranks} MPI ranks", file=sys.stderr)
            on_ranks.run()
        else:
            sim.run()
    except KeyboardInterrupt:
        out = sim.output_path
        if out is not None and out.exists():
            print(f"siku: interrupted at step {sim.step_index}; {shown(out)} holds the run to "
                  f"its last snapshot: continue it with `siku run {shown(path)} --restart "
                  f"{shown(out)}`", file=sys.stderr)
            return 130
        raise
    wall = time.perf_counter() - t0
    out = shown(sim.output_path) if sim.output_path is not None else "none"
    print(f"done in {wall:.1f} s; output: {out}", file=sys.stderr)
    from .summary import format_summary, summary_of

    print(format_summary(summary_of(sim, wall, out, sim.step_index - first)), file=sys.stderr)
    if args.profile:
        from .simulation import PHASES

        sim.phase_log.finish(sim)
        held, stepping = None, wall - sim.compile_seconds
        if comm is not None:  # rank 0's phases over its steps (not the ranks' start)
            held, stepping = int(on_ranks.report()["held"]), on_ranks.stepping
        print(profile_table(sim, stepping, held), file=sys.stderr)
        print(sim.phase_log.table(held or sim.state.n, PHASES), file=sys.stderr)
        if comm is not None:
            print(on_ranks.profile_table(), file=sys.stderr)
    if sim.output_path is not None and sim.step_index == sim.n_steps:
        from ..plugins import get_plugin_manager

        made = get_plugin_manager().hook.siku_postprocess(path=sim.output_path, scene=scene,
                                                         overwrite=args.overwrite)
        for f in [f for files in made for f in files or ()]:
            print(f"derived: {shown(f)}", file=sys.stderr)
    if scene.cfg.output.plots and sim.output_path is not None and not args.no_plots:
        from ..plugins import get_plugin_manager

        drawn = get_plugin_manager().hook.siku_draw(path=sim.output_path,
                                                    field=scene.cfg.output.plot_field)
        for f in [f for files in drawn for f in files or ()]:
            print(f"picture: {shown(f)}", file=sys.stderr)
    return 0


@contextlib.contextmanager
def _together(comm):
    """On ranks (``comm``), a block that fails on one rank fails on all, after it ended on
    each: the first failing rank's message is the run's (no rank waits for one that left)."""
    if comm is None:
        yield
        return
    failed = None
    try:
        yield
    except Exception as exc:  # noqa: BLE001 - told to every rank, then raised here
        failed = exc
    said = comm.allgather(None if failed is None else " | ".join(str(failed).splitlines()))
    if failed is not None:
        raise failed
    bad = next(((r, m) for r, m in enumerate(said) if m is not None), None)
    if bad is not None:
        raise SikuError(f"rank {bad[0]}: {bad[1]}")


def _relaunch(ranks: int, argv: list[str]) -> int:
    """``siku run --ranks N``: this command again under the ``mpiexec`` of the ``mpich``
    wheel, on ``N`` ranks (the other options as given)."""
    from ..ranks import launched_ranks, mpiexec

    if ranks < 1:
        raise SikuError(f"--ranks {ranks}: give 1 or more")
    argv = list(argv)
    at = next(k for k, a in enumerate(argv) if a == "--ranks" or a.startswith("--ranks="))
    del argv[at:at + (1 if "=" in argv[at] else 2)]
    if ranks == 1 or launched_ranks() > 1:
        return main(argv)
    exe = mpiexec()
    if exe is None:
        raise SikuError("--ranks needs mpiexec: pip install 'siku[mpi]'")
    from ..ranks.launch import launch

    return launch([exe, "-n", str(ranks), sys.executable, "-m", "siku_core.run.cli", *argv])


def _cmd_warm(args: argparse.Namespace) -> int:
    """Build a scene (its mesh cache included) and take two steps without output: every kernel
    the scene uses is compiled and cached, so that its first real run starts at full speed."""
    from .progress import CompileProgress
    from ..scene.scene_file import load_scene
    from .simulation import Simulation

    path = Path(args.scene) if args.scene else default_scene_path()
    t0 = time.perf_counter()
    scene = load_scene(path)
    with CompileProgress() as clock:
        sim = Simulation(scene, out=False, progress=False)
        sim.run(steps=min(2, sim.n_steps))
    t2 = time.perf_counter()
    compiled = (f"{clock.seconds:.1f} s compiling {plural(clock.count, 'kernel')} (the "
                "others loaded from the caches)" if clock.count
                else "kernels loaded from the caches")
    print(f"siku warm: {scene.cfg.title or path.name}: built {plural(sim.state.n, 'element')} "
          f"and took {plural(sim.step_index, 'step')} in {t2 - t0:.1f} s: {compiled}",
          file=sys.stderr)
    return 0


def auto_threads(threads: int | None, environ=None) -> bool:
    """Whether a run chooses its threads as it goes (one or all, ``Simulation.auto_threads``):
    when neither ``--threads`` (``threads``) nor ``NUMBA_NUM_THREADS`` says how many."""
    return threads is None and "NUMBA_NUM_THREADS" not in (os.environ if environ is None
                                                            else environ)


def plural(n: int, noun: str) -> str:
    """``"1 element"``, ``"2 elements"``."""
    return f"{n} {noun}" if n == 1 else f"{n} {noun}s"


def _set_threads(n: int) -> None:
    import numba

    most = numba.config.NUMBA_NUM_THREADS
    if not 1 <= n <= most:
        raise SikuError(f"--threads {n}: choose 1 to {most} (NUMBA_NUM_THREADS)")
    numba.set_num_threads(n)


def profile_table(sim, wall: float, held: int | None = None) -> str:
    """The time of each phase of the step (``Simulation.timings``) as a table: seconds, share
    of the run's wall time ``wall`` [s] (without the compilation: ``Simulation.timings`` leave
    it out too), and per step and per element-step. On MPI ranks, ``held``: the elements rank
    0 steps (its own and its ghosts), whose phases these are (per element-step of those)."""
    import numba

    from .. import parallel

    steps = max(sim.timed_steps, 1)
    n = max(sim.state.n if held is None else held, 1)
    rows = [(k, v) for k, v in sim.profile()]
    other = wall - sum(v for _, v in rows)
    rows.append(("other", max(other, 0.0)))
    on = f"{numba.get_num_threads()} thread(s)"
    if sim.auto_threads and parallel.LAST_TUNED:
        on = ", ".join(f"{t} thread(s) for {k} steps"
                       for t, k in sorted(parallel.LAST_TUNED.items())) + " (timed as it ran)"
    what = (f"{sim.state.n} elements" if held is None else
            f"rank 0's {held} elements (its own and its ghosts, of {sim.state.n})")
    lines = [f"profile: {sim.timed_steps} steps of {what} in {wall:.3g} s on "
             f"{on}: {n * steps / wall:.3g} element-steps/s",
             f"  {'phase':<12} {'seconds':>9} {'share':>7} {'per step':>11} "
             f"{'per element-step':>17}"]
    for k, v in rows:
        share = 100.0 * v / wall if wall > 0 else 0.0
        lines.append(f"  {k:<12} {v:9.3f} {share:6.1f}% {v / steps * 1e6:9.1f} us "
                     f"{v / steps / n * 1e9:14.1f} ns")
    lines.append("  (other: the Python loop, progress bar, opening files and loading the "
                 "compiled code of the step and the output from the caches"
                 + (f"; compiling kernels, {sim.compile_seconds:.1f} s, left out)"
                    if sim.compile_seconds >= 0.05 else ")"))
    return "\n".join(lines)


def plain(text: str) -> str:
    """Docstring text for a terminal: RST literals (``x``) and roles (:func:`~a.b`) as plain
    words."""
    import re

    text = re.sub(r":[a-z]+:`~?([^`]+)`", lambda m: m.group(1).split(".")[-1], text)
    return re.sub(r"``(.+?)``", r"\1", text)


def _cmd_plugins(args: argparse.Namespace) -> int:
    from ..plugins import get_registry

    reg = get_registry()
    want = args.which
    kinds = {k: k for k in reg.entries} | {t: k for k, t in _KIND_TITLES.items()}
    kind_wanted = kinds.get(want.replace("-", "_") if want else None) or kinds.get(
        want.replace("-", " ") if want else None)
    if want and not kind_wanted and not any(want in t for t in reg.entries.values()):
        known = sorted({n for t in reg.entries.values() for n in t})
        raise SceneError(f"siku plugins {want}: no component or kind of that name; kinds: "
                         f"{', '.join(sorted(reg.entries))}; components: {', '.join(known)}")
    for kind, table in reg.entries.items():
        names = sorted(n for n in table if not want or kind == kind_wanted or n == want)
        if not names:
            continue
        print(f"{_KIND_TITLES.get(kind, kind)}:")
        for name in names:
            e = table[name]
            print(f"  {name}  ({e.package} {e.version}) - {plain(e.cls.summary())}")
            for pname, p in e.cls.params.items():
                print(f"      {pname} = {p.default!r}  [{p.unit or '-'}]  {plain(p.doc)}; "
                      f"allowed: {plain(str(p.allowed()))}")
            for f in e.cls.owned_fields:
                print(f"      per-element field {f.name}  [{f.units}]  {plain(f.long_name)} "
                      f"(on grids: {f.grid})")
            for f in e.cls.optional_fields:  # declared when a parameter asks for them
                print(f"      per-element field {f.name}  [{f.units}]  {plain(f.long_name)} "
                      f"(on grids: {f.grid}; declared when a parameter asks for it)")
            model = e.cls.table_model if kind == "element_source" else None
            if model is not None:
                keys = ", ".join(model.model_fields)
                print(f"      keys of the scene table: {keys} (docs/reference/scene.md)")
    if want:
        return 0
    for pkg, err in reg.broken.items():
        print(f"failed to load: {pkg}: {err}")
    for msg in reg.refused.values():
        print(f"refused: {msg}")
    for msg in reg.ambiguous.values():
        print(f"ambiguous: {msg}")
    return 0


class _UsageError(Exception):
    """Bad command-line arguments (reported on one line like every other input error)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message: str):  # type: ignore[override]
        raise _UsageError(f"{message} (see '{self.prog} --help')")


def _warn_one_line(message, category, filename, lineno, file=None, line=None) -> None:
    print(f"siku: warning: {' | '.join(str(message).splitlines())}", file=sys.stderr)


def build_parser() -> argparse.ArgumentParser:
    ap = _Parser(prog="siku", description="Discrete-element sea-ice model.")
    ap.add_argument("--version", action="version", version=f"siku {__version__}")
    sub = ap.add_subparsers(dest="command", required=True)
    r = sub.add_parser("run", help="run a scene (no argument: the shipped default scene)")
    r.add_argument("scene", nargs="?", help="scene file (TOML)")
    r.add_argument("--out", help="output file (overrides [output] file)")
    r.add_argument("--restart", help="continue from the last complete snapshot of this output "
                   "file (written to the same file unless --out names another)")
    r.add_argument("--extend", metavar="DURATION",
                   help="with --restart: run a finished run longer, e.g. --extend 6h")
    r.add_argument("--force", action="store_true",
                   help="with --restart: continue even though the scene differs from the file's")
    r.add_argument("--overwrite", action="store_true",
                   help="replace an existing output file (kept until the new one has a snapshot)")
    r.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    r.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a scene key, e.g. --set time.duration=6h (repeatable)")
    r.add_argument("--no-plots", action="store_true", help="skip the pictures [output] asks for")
    r.add_argument("--profile", action="store_true",
                   help="print the time spent in each phase of the step, in all and "
                   "hour by hour of model time")
    r.add_argument("--threads", type=int, help="numba threads (default: one or all cores, "
                   "whichever runs the steps faster, timed as the run goes)")
    r.add_argument("--ranks", type=int, help="run on this many MPI ranks (started with "
                   "mpiexec; needs siku[mpi]); same results as one")
    r.set_defaults(func=_cmd_run)
    w = sub.add_parser("warm", help="compile and cache the kernels (and mesh) a scene uses, "
                       "so that its first run starts at full speed (no argument: the default)")
    w.add_argument("scene", nargs="?", help="scene file (TOML)")
    w.set_defaults(func=_cmd_warm)
    p = sub.add_parser("plugins", help="list registered components with their parameters "
                       "(all, one kind, or one component)")
    p.add_argument("which", nargs="?", metavar="NAME|KIND",
                   help="a component (air_drag) or a kind (contact_law, 'forcing sources')")
    p.set_defaults(func=_cmd_plugins)
    _plugin_commands(sub)
    ap.set_defaults(commands=sub)
    return ap


def _plugin_commands(sub) -> None:
    """Commands added by plugins (``siku_register_commands``); a command whose name is taken
    is refused with a warning naming its package, the others still load."""
    from ..plugins import get_plugin_manager

    try:
        pm = get_plugin_manager()
    except SikuError as exc:  # a broken plugin set: the engine's commands still work
        warnings.warn(f"plugin commands unavailable: {exc}", stacklevel=2)
        return
    for impl in pm.hook.siku_register_commands.get_hookimpls():
        taken = set(sub.choices)
        try:
            impl.function(subparsers=sub)
        except argparse.ArgumentError as exc:
            warnings.warn(f"plugin '{impl.plugin_name}': command not added: {exc}", stacklevel=2)
        for name in set(sub.choices) - taken:
            if sub.choices[name].get_default("func") is None:
                warnings.warn(f"plugin '{impl.plugin_name}': command '{name}' sets no func",
                              stacklevel=2)


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("default")
            warnings.showwarning = _warn_one_line
            try:
                ap = build_parser()
                cmd = ap.get_default("commands").choices.get(argv[0]) if argv else None
                if cmd is not None and cmd.get_default("raw_args"):
                    return cmd.get_default("func")(argv[1:])
                args = ap.parse_args(argv)
            except _UsageError as exc:
                print(f"siku: error: {exc}", file=sys.stderr)
                return 2
            except SystemExit as exc:  # --help, --version
                return int(exc.code or 0)
            args.argv = argv
            with command_line():  # refusals name the flags, not the Python arguments
                return args.func(args)
    except SikuError as exc:
        msg = " | ".join(str(exc).splitlines())
        here = str(Path.cwd()).rstrip("/\\") + "/"
        msg = msg.replace(here, "") if here != "/" else msg  # files named as shown() does
        print(f"siku: error: {msg}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("siku: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
