"""siku-example-plugin: a sea-surface tilt force and a forward Euler integrator for siku.

The components live in :mod:`siku_example_plugin.tilt` and :mod:`siku_example_plugin.euler`; the
hooks that register them with siku in :mod:`siku_example_plugin.plugin` (named by the package's
``siku`` entry point). Importing this package does not import siku's plugins.
"""

__version__ = "0.1"
