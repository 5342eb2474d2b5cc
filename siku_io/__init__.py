"""Input/output, one subpackage per concern (output, analysis, mesh, coupling, ensemble, plot),
each imported lazily and registering its own commands."""
