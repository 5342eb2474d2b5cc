"""Built-in broad phases: brute force (reference), sweep-and-prune (the report's) and a cell grid.

All three return identical, lexicographically sorted candidate pairs (see
:mod:`siku_plugins.broad_phase.kernels`); the engine inflates the radii by half the skin.
"""
from __future__ import annotations

from siku_core import hookimpl
from siku_core.interfaces import BroadPhase

from .broad_phase.kernels import brute_force_pairs, cell_grid_pairs, sweep_and_prune_pairs


class BruteForce(BroadPhase):
    """Every pair checked, O(N²): the reference for tests."""

    name = "brute_force"

    def pairs(self, centers, radii, skip):
        return brute_force_pairs(centers, radii, 0.0, skip)


class SweepAndPrune(BroadPhase):
    """Sort bounding circles' projections on one axis and sweep (Kulchitsky et al. 2017).

    The Siku report sweeps along x (the method: Ericson 2004); here the axis is the one along
    which the centres spread most (the same pairs, found faster: a pack near 0° longitude has
    nearly equal x everywhere, and
    the sweep along x then degenerates towards O(N²))."""

    name = "sweep_and_prune"

    def pairs(self, centers, radii, skip):
        return sweep_and_prune_pairs(centers, radii, 0.0, skip, -1)


class CellGrid(BroadPhase):
    """Uniform 3D cell grid over unit-vector coordinates: no pole or antimeridian special case."""

    name = "cell_grid"

    def pairs(self, centers, radii, skip):
        return cell_grid_pairs(centers, radii, 0.0, skip)


@hookimpl
def siku_register_broad_phases():
    return [BruteForce, SweepAndPrune, CellGrid]
