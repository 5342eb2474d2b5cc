"""Analytic winds written in the NCEP/NCAR layout read back through the gridded field."""
from __future__ import annotations

import datetime as dt

import numpy as np
import xarray as xr

from siku_forcing.fields import Cyclone
from siku_forcing.synthetic import DEFAULT_ANTICYCLONE, FILL, NCEP_LAT, NCEP_LON, write_ncep_pair


def test_written_files_have_the_reanalysis_layout_and_values(tmp_path):
    start = dt.datetime(2001, 4, 6)
    pu, pv = write_ncep_pair(tmp_path, DEFAULT_ANTICYCLONE, start, 12.0, step_hours=6.0)
    raw = xr.open_dataset(pu, decode_cf=False)
    assert raw["uwnd"].dtype == np.int16
    assert raw["uwnd"].attrs["scale_factor"] == 0.01
    assert raw["time"].attrs["units"].startswith("hours since 1800-01-01")
    assert raw["lat"].values[0] == 90.0 and raw["lat"].values[-1] == -90.0
    assert raw["lon"].values[-1] == 357.5
    # the first record is 2001-04-06 00:00: hours since 1800-01-01
    assert raw["time"].values[0] == (start - dt.datetime(1800, 1, 1)).total_seconds() / 3600
    ds_u, ds_v = xr.open_dataset(pu), xr.open_dataset(pv)
    field = Cyclone({**{k: p.default for k, p in Cyclone.params.items()}, **DEFAULT_ANTICYCLONE})
    field.radius = 6_371_000.0
    LON, LAT = np.meshgrid(np.radians(NCEP_LON), np.radians(NCEP_LAT))
    for k in range(3):
        u, v = field.sample(k * 6 * 3600.0, LAT.ravel(), LON.ravel())
        # packing resolution: scale_factor / 2 = 0.005 m/s (plus round-off of the offset)
        np.testing.assert_allclose(ds_u["uwnd"].values[k].ravel(), u, atol=0.005 + 1e-9)
        np.testing.assert_allclose(ds_v["vwnd"].values[k].ravel(), v, atol=0.005 + 1e-9)
    assert not np.any(raw["uwnd"].values == FILL)
