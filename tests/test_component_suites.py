"""The writer and element-source conformance suites (``siku_core.testing.writer_checks``,
``siku_core.testing.element_source_checks``): every writer and element source siku ships passes
them, and a deliberately broken one of each kind fails the check that is about its fault."""
from __future__ import annotations

import numpy as np
import pytest

from siku_core.interfaces import ElementSpec
from siku_core.plugins import get_registry
from siku_core.testing.contact_cases import registry_with
from siku_core.testing.element_source_checks import (
    check_element_source,
    check_element_source_reproducible,
    check_element_source_specs,
)
from siku_core.testing.writer_checks import (
    check_writer,
    check_writer_owns,
    check_writer_publish,
    shipped_writers,
)
from siku_io.output.hdf5 import HDF5Writer
from siku_io.output.netcdf import NetCDFWriter
from siku_plugins.sources import PolygonSource


@pytest.mark.parametrize("name", shipped_writers())
def test_every_shipped_writer_passes_the_writer_suite(name, tmp_path):
    check_writer(name, tmp_path)


class OwnsEverything(HDF5Writer):
    """Claims every file: ``--overwrite`` would replace a file siku did not write."""

    name = "hdf5_owns_everything"

    @classmethod
    def owns(cls, path):
        return True


class WritesTwice(NetCDFWriter):
    """Writes every snapshot twice."""

    name = "netcdf_twice"

    def write_state(self, ctx):
        super().write_state(ctx)
        self._last = None
        super().write_state(ctx)


def test_a_writer_that_owns_every_file_fails_the_owns_check(tmp_path):
    reg = registry_with("writer", OwnsEverything)
    with pytest.raises(AssertionError, match="owns.. claims a file it did not write"):
        check_writer_owns(OwnsEverything.name, tmp_path, reg)


def test_a_writer_that_writes_a_snapshot_twice_fails_the_publish_check(tmp_path):
    reg = registry_with("writer", WritesTwice)
    with pytest.raises(AssertionError, match=r"steps \[0, 0, 2, 2.*a row written twice"):
        check_writer_publish(WritesTwice.name, tmp_path, reg)


#: parameters of siku's own element sources for the suite (small: a few elements each)
SOURCES = {
    "polygon": {"vertices": [[-150.0, 75.0], [-149.9, 75.0], [-149.9, 75.05],
                             [-150.0, 75.05]]},
    "pack": {"lon": [-150.0, -149.0], "lat": [75.0, 75.3], "nx": 3, "ny": 2},
    "floe": {"element_size": 200.0, "length": 1000.0, "width": 600.0, "seed": 2},
    "floe_field": {"lon": [-150.0, -149.9], "lat": [75.0, 75.05], "size_min": 500.0,
                   "size_max": 1000.0, "max_floes": 3, "element_size": 250.0},
    "lab_block": {"length": 24.0, "width": 12.0, "element_size": 4.0, "seed": 1},
    "mesh": {"lon": [-150.0, -149.0], "lat": [75.0, 75.3], "spacing": 8000.0, "land": "none",
             "cache": False},
}


def test_the_suite_covers_every_element_source_siku_ships():
    ours = {n for n, e in get_registry().entries["element_source"].items()
            if e.package == "siku"}
    assert ours == set(SOURCES)


@pytest.mark.parametrize("name", sorted(SOURCES))
def test_every_shipped_element_source_passes_the_element_source_suite(name):
    check_element_source(name, SOURCES[name])


class Unseeded(PolygonSource):
    """The polygon, shifted by a random amount drawn without the seed it is given."""

    name = "unseeded_polygon"

    def build(self, scene, seed, where):
        out = super().build(scene, seed, where)
        shift = np.random.default_rng().uniform(0.0, 0.01)
        for s in out:
            s.lonlat = np.asarray(s.lonlat) + shift
        return out


class PastThePole(PolygonSource):
    """Vertices given as [lat, lon]: latitudes of -150 deg."""

    name = "lat_lon_polygon"

    def build(self, scene, seed, where):
        return [ElementSpec(lonlat=np.asarray(s.lonlat)[:, ::-1])
                for s in super().build(scene, seed, where)]


def test_an_unseeded_element_source_fails_the_reproducibility_check():
    reg = registry_with("element_source", Unseeded)
    with pytest.raises(AssertionError, match="two builds of one scene differ"):
        check_element_source_reproducible(Unseeded.name, SOURCES["polygon"], reg)


def test_an_element_source_past_the_pole_fails_the_specs_check():
    reg = registry_with("element_source", PastThePole)
    with pytest.raises(AssertionError, match=r"latitude outside \[-90, 90\]"):
        check_element_source_specs(PastThePole.name, SOURCES["polygon"], reg)
