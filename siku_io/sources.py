"""Element source ``mesh``: Voronoi cells of blue-noise seeds with land removed, coast and
landfast cells static (``[elements.mesh]``; built by :mod:`siku_io.mesh`, imported only when a
scene has a mesh)."""
from __future__ import annotations

from siku_core import hookimpl
from siku_core.interfaces import ElementSource, ElementSpec
from siku_core.scene import MeshCfg


class MeshSource(ElementSource):
    """Voronoi cells over a lon/lat box, land removed, coast and landfast cells static."""

    name = "mesh"
    table_model = MeshCfg

    def build(self, scene, seed, where):
        from siku_io.mesh import ICE, KIND_NAMES, mesh_for_scene

        mc = MeshCfg.model_validate({**self.p, "seed": seed})
        mesh, _ = mesh_for_scene(scene, mc, where)
        out = []
        for k in range(mesh.n):
            ice = mesh.kind[k] == ICE
            out.append(ElementSpec(
                mesh.cell(k), mc.flag if ice else "static",
                mc.velocity if ice else [0.0, 0.0], mc.spin if ice else 0.0, mc.thickness,
                mc.material,
                f"cell {k} ({KIND_NAMES[mesh.kind[k]]}, seed {mesh.seeds[k, 0]:.4f}, "
                f"{mesh.seeds[k, 1]:.4f})"))
        return out


@hookimpl
def siku_register_element_sources():
    return [MeshSource]
