"""Element source ``mesh``: Voronoi cells of blue-noise seeds with land removed, coast and
landfast cells static (``[elements.mesh]``; built by :mod:`siku_io.mesh`, imported only when a
scene has a mesh)."""
from __future__ import annotations

import numpy as np

from siku_core import hookimpl
from siku_core.errors import SceneError
from siku_core.interfaces import ElementSource, ElementSpec
from siku_core.scene.scene_file import MeshCfg


class MeshSource(ElementSource):
    """Voronoi cells over a lon/lat box, land removed, coast and landfast cells static."""

    name = "mesh"
    table_model = MeshCfg

    def build(self, scene, seed, where):
        from siku_io.mesh.cache import mesh_for_scene
        from siku_io.mesh.mesh_file import ICE, KIND_NAMES

        mc = MeshCfg.model_validate({**self.p, "seed": seed})
        mesh, _ = mesh_for_scene(scene, mc, where)
        keep, thick = np.ones(mesh.n, dtype=bool), np.full(mesh.n, np.nan)
        cats = None
        if mc.cover is not None:
            keep, thick, cats = self._cover(scene, mesh, mc, where)
        out = []
        for k in np.flatnonzero(keep):
            ice = mesh.kind[k] == ICE
            h = float(thick[k]) if np.isfinite(thick[k]) else mc.thickness
            out.append(ElementSpec(
                mesh.cell(k), mc.flag if ice else "static",
                mc.velocity if ice else [0.0, 0.0], mc.spin if ice else 0.0, h,
                mc.material,
                f"cell {k} ({KIND_NAMES[mesh.kind[k]]}, seed {mesh.seeds[k, 0]:.4f}, "
                f"{mesh.seeds[k, 1]:.4f})",
                categories=(cats[0][k], cats[1][k]) if cats is not None and ice else None))
        return out

    @staticmethod
    def _cover(scene, mesh, mc, where):
        """Which cells stay (static cells always; ice cells where the concentration reaches
        the threshold), the thickness of each ice cell from the cover file [m] and, with
        thickness categories, their fractions and thicknesses ``(n, K)`` (else ``None``)."""
        from siku_io.mesh.icecover import read_cover
        from siku_io.mesh.mesh_file import ICE

        where = where[:-1] + ".cover]" if where.endswith("]") else f"{where}.cover"
        ice = mesh.kind == ICE
        cov = read_cover(mc.cover, scene.base_dir, scene.cfg.time.start, mesh.seeds[:, 0],
                         mesh.seeds[:, 1], where)
        keep = ~ice | (cov.concentration >= mc.cover.threshold)
        thick = np.where(ice, cov.thickness, np.nan)
        if cov.h is not None:  # a category with ice needs its thickness (icecover: one rule)
            cells, cat = np.nonzero((keep & ice)[:, None] & np.isnan(cov.h))
            if len(cells):
                k = int(cells[0])
                raise SceneError(
                    f"{where}: {mc.cover.file}: '{mc.cover.thickness}' is missing (NaN or "
                    f"fill value) at ice cell {k} (seed {mesh.seeds[k, 0]:.4f}, "
                    f"{mesh.seeds[k, 1]:.4f}), category {int(cat[0])}, where "
                    f"'{mc.cover.concentration}' has ice ({len(cells)} such values); give a "
                    "thickness there, or a fraction of 0 for no ice")
        bad = np.flatnonzero(keep & ice & ~(thick > 0)) if mc.cover.thickness else []
        if len(bad):
            k = int(bad[0])
            raise SceneError(f"{where}: ice cell {k} (seed {mesh.seeds[k, 0]:.4f}, "
                             f"{mesh.seeds[k, 1]:.4f}) has concentration "
                             f"{cov.concentration[k]:.3g} but no positive thickness in "
                             f"{mc.cover.file} ({len(bad)} such cells)")
        if cov.a is None:
            return keep, thick, None
        from siku_core.categories import category_problem

        rows = np.flatnonzero(keep & ice)
        found = category_problem(cov.a[rows], cov.h[rows])
        if found is not None:
            k = int(rows[found[0]])
            raise SceneError(f"{where}: ice cell {k} (seed {mesh.seeds[k, 0]:.4f}, "
                             f"{mesh.seeds[k, 1]:.4f}) in {mc.cover.file}: {found[1]}")
        return keep, thick, (cov.a, cov.h)


@hookimpl
def siku_register_element_sources():
    return [MeshSource]
