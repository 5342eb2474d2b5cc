"""Make the plugin available to siku when it is not pip-installed (a source checkout).

Installed (``pip install -e .``), siku finds it through its entry point and this does nothing.
"""
from siku_core.plugins import get_registry, register_module

if "brittle_bond" not in get_registry().names("contact_law"):
    import siku_example_plugin.plugin

    register_module(siku_example_plugin.plugin)
