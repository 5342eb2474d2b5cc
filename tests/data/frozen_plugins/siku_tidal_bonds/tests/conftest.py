from siku_core.plugins import get_registry, register_module

if "bonded_beam" not in get_registry().names("contact_law"):
    import siku_tidal_bonds.plugin

    register_module(siku_tidal_bonds.plugin)
