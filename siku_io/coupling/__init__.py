"""Coupling to other models: the Basic Model Interface (bmi) and its exchange grid (exchange)."""
