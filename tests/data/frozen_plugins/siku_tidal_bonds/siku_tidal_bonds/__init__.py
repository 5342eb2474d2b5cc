"""Bonded-beam joints and a tidal current for siku."""

__version__ = "0.3"
