"""Shared numba geometry: quaternions, geographic conversions, polygons."""
