"""Built-in physics plugins: integrators, broad phases, contact laws."""
