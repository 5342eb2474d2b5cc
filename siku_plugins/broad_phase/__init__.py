"""Broad-phase plugins: contact candidate pairs from bounding circles on the sphere."""
