"""Meshes reused from a file whose parameter hash matches (stage 4), and the mesh of a scene."""
from __future__ import annotations

import sys
import warnings
from pathlib import Path

from siku_core.errors import DataError
from siku_core.contact.kernel_cache import user_cache_dir

from .build import build_mesh
from .contours import read_contour
from .mesh_file import Mesh
from .params import MeshParams


# ---------------------------------------------------------------------------- cache
def load_or_build(params: MeshParams, path: str | Path | None, **build_kw) -> tuple[Mesh, bool]:
    """The mesh of ``params``: loaded from ``path`` when it holds the same parameter hash,
    else built (and saved to ``path``). Returns ``(mesh, built)``."""
    from siku_core.run.outputs import check_target, is_disk_full
    from siku_io.output.marks import is_mesh_cache

    digest = params.digest()
    if path is not None and not build_kw:
        # a file that is not a mesh cache siku wrote (a scene, a wind file, a damaged cache)
        # is never replaced: ValueError, which the scene's loader names with its key
        try:
            check_target(path, what="mesh cache", ours=is_mesh_cache, overwrite=True,
                         option="mesh_file")
        except DataError as exc:
            raise ValueError(f"mesh_file: {exc}") from None
    if path is not None and Path(path).is_file() and not build_kw:
        try:
            m = Mesh.load(path)
        except Exception as exc:  # noqa: BLE001 - an older siku's cache is rebuilt
            warnings.warn(f"{path}: unreadable mesh cache ({exc}); rebuilding it", stacklevel=2)
        else:
            if m.digest == digest:
                return m, False
    m = build_mesh(params, **build_kw)
    if path is not None and not build_kw:
        try:
            m.save(path)
        except OSError as exc:  # a read-only folder: run on, rebuild next time
            if is_disk_full(exc):
                raise DataError(f"{path}: disk full while writing the mesh cache; nothing "
                                "written (an existing file is untouched)") from None
            warnings.warn(f"{path}: cannot write the mesh cache ({exc})", stacklevel=2)
    return m, True


def shipped(path: str | Path) -> bool:
    """Whether a file lies inside one of siku's installed packages (a shipped scene)."""
    import siku_core
    import siku_forcing
    import siku_io
    import siku_plugins

    p = Path(path).resolve()
    return any(p.is_relative_to(Path(m.__file__).resolve().parent)
               for m in (siku_core, siku_forcing, siku_io, siku_plugins))


def mesh_for_scene(scene, mc=None, where: str | None = None) -> tuple[Mesh, bool]:
    """The mesh of a scene's ``[elements.mesh]`` table (or of the table ``mc``, a
    :class:`~siku_core.scene.scene_file.MeshCfg`, named ``where``), from its cache file when
    unchanged.

    The cache is ``mesh_file`` (relative to the scene's folder), by default
    ``<scene name>.mesh.npz`` beside the scene file; a scene without a file (built from text)
    and no ``mesh_file`` is not cached. A scene shipped inside siku's packages (the default
    scene) keeps its mesh in the user cache (``siku_core.contact.kernel_cache.user_cache_dir``),
    named
    by the parameters' hash, never in the installed package. Errors become
    :class:`~siku_core.errors.SceneError` naming the table.
    """
    from siku_core.errors import SceneError

    cfg = scene.cfg
    mc = cfg.elements.mesh if mc is None else mc
    where = scene.where("elements.mesh") if where is None else where
    landfast = None
    try:
        if isinstance(mc.landfast, str):
            landfast = [q.tolist() for q in read_contour(scene.base_dir / mc.landfast)]
        elif mc.landfast:
            landfast = [mc.landfast]
        params = MeshParams(
            lon=mc.lon, lat=mc.lat, spacing=mc.spacing, coast_spacing=mc.coast_spacing,
            coast_distance=mc.coast_distance,
            seed=cfg.run.seed if mc.seed is None else mc.seed, radius=cfg.planet.radius,
            land=mc.land, land_removal=mc.land_removal, landfast=landfast,
            min_area_share=mc.min_area_share,
        )
        params.check()
        if not mc.cache:
            path = None
        elif scene.path is not None and shipped(scene.path):  # never write into the package
            name = Path(mc.mesh_file).name if mc.mesh_file else Path(scene.path).stem
            name = name.removesuffix(".npz").removesuffix(".mesh")
            path = user_cache_dir("meshes") / f"{name}-{params.digest()[:16]}.mesh.npz"
        elif mc.mesh_file is not None:
            path = scene.base_dir / mc.mesh_file
        elif scene.path is not None:
            path = Path(scene.path).with_suffix(".mesh.npz")
        else:
            path = None
        existed = path is not None and Path(path).is_file()
        mesh, built = load_or_build(params, path)
    except (ValueError, ImportError, FileNotFoundError, OSError) as exc:
        raise SceneError(f"{where}: {exc}") from None
    except RuntimeError as exc:  # scipy's QhullError: seeds too few or too close for a mesh
        raise SceneError(f"{where}: no mesh can be built from these keys (spacing too large or "
                         f"too small for the region: {' '.join(str(exc).split())[:200]})"
                         ) from None
    if mesh.n == 0:
        raise SceneError(f"{where}: the mesh has no cells (region too small for the spacing, "
                         "or all land)")
    if built:  # say so: a build takes seconds, and a rebuilt cache means changed parameters
        how = ("rebuilt (the cache held a mesh of other parameters)" if existed else "built")
        saved = f", saved to {path}" if path is not None else ""
        secs = (mesh.stats.get("seconds") or {}).get("total", float("nan"))
        print(f"{where}: mesh {how}: {mesh.n} cells in {secs:.1f} s{saved}", file=sys.stderr)
    else:
        print(f"{where}: mesh of {mesh.n} cells read from {path}", file=sys.stderr)
    print(f"{where}: {small_cells(mesh)}", file=sys.stderr)
    return mesh, built


def small_cells(mesh: Mesh) -> str:
    """What the mesh's smallest free (ice) cells cost in step
    (:func:`siku_core.scene.cells.small_cell_report`), and what ``min_area_share`` did."""
    import numpy as np

    from siku_core.scene.cells import small_cell_report
    from siku_core.state import FREE, STATIC

    from .mesh_file import ICE

    r = small_cell_report(mesh.spherical_areas(), np.where(mesh.kind == ICE, FREE, STATIC))
    text = "no free cells" if r is None else r.line()
    x = mesh.stats.get("relaxed")
    if x:
        text += (f"; min_area_share {x['share']:g}: {x['moved']} seeds moved, {x['merged']} "
                 f"pairs merged in {x['rounds']} rounds, smallest {x['before']:.2f} -> "
                 f"{x['after']:.2f} x median"
                 + ("" if x["reached"] else f" ({x['below']} cells below the share)"))
    return text
