"""Driving forces: velocity fields (uniform, analytic, gridded) and the stresses they exert."""
