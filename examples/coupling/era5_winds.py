"""Ice driven through the BMI by a component no one here wrote: CSDMS ``bmi-era5``.

``BmiEra5`` (package ``bmi-era5``) serves the fields of an ERA5 NetCDF file record by record
behind the Basic Model Interface; siku (``siku_io.coupling.bmi.SikuBmi``) takes winds on its
exchange grid. The driver below is all the glue there is: at each ERA5 record it reads the 10 m
wind, interpolates it bilinearly from the ERA5 grid to the centres of siku's exchange cells, hands
it to siku and advances the ice to the next record (the wind held over the record's hour).

``bmi-era5`` downloads from the Copernicus data store only when its file is missing; here the
file exists, written by :func:`write_era5` in ERA5's layout (``valid_time``, ``latitude`` from
north to south, ``longitude``, ``u10``/``v10`` named by their ERA5 long names).

Run ``python examples/coupling/era5_winds.py`` (writes ``era5_demo.nc`` beside the scene and
prints the ice drift).
"""
from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
U10 = "10 metre U wind component"
V10 = "10 metre V wind component"


def write_era5(path, lon, lat, hours, u, v, start="2001-04-06T00:00:00"):
    """An ERA5-layout file of 10 m winds ``u``, ``v`` [m/s] ``(time, lat, lon)`` on
    ``lat`` (north to south) × ``lon`` [deg] at ``hours`` after ``start``."""
    import xarray as xr

    t0 = np.datetime64(start, "s").astype("int64")
    times = (t0 + np.asarray(hours, dtype=np.int64) * 3600).astype("int64")
    ds = xr.Dataset(
        {"u10": (("valid_time", "latitude", "longitude"), np.asarray(u, np.float32),
                 {"long_name": U10, "units": "m s**-1"}),
         "v10": (("valid_time", "latitude", "longitude"), np.asarray(v, np.float32),
                 {"long_name": V10, "units": "m s**-1"})},
        coords={"valid_time": ("valid_time", times, {
                    "units": "seconds since 1970-01-01", "calendar": "proleptic_gregorian",
                    "standard_name": "time"}),
                "latitude": ("latitude", np.asarray(lat, float), {"units": "degrees_north"}),
                "longitude": ("longitude", np.asarray(lon, float), {"units": "degrees_east"})},
        attrs={"Conventions": "CF-1.7", "title": "ERA5-layout winds (siku example)"})
    ds.to_netcdf(path)
    return Path(path)


def _era5_grid(era5):
    """ERA5 grid axes (latitude ascending, longitude) from the BMI grid description."""
    shape = era5.get_grid_shape(0, np.zeros(2, dtype=int))
    spacing = era5.get_grid_spacing(0, np.zeros(2))
    origin = era5.get_grid_origin(0, np.zeros(2))
    lat = origin[0] + spacing[0] * np.arange(shape[0])
    lon = origin[1] + spacing[1] * np.arange(shape[1])
    return shape, lat, lon


def run(scene, era5_file, records: int | None = None):
    """Drive ``scene`` with the winds of ``era5_file``; returns the siku BMI (not finalized:
    call ``finalize()``)."""
    from bmi_era5 import BmiEra5
    from scipy.interpolate import RegularGridInterpolator

    from siku_io.coupling.bmi import SikuBmi

    cfg = Path(tempfile.mkdtemp()) / "era5.yaml"
    cfg.write_text(f"bmi-era5:\n  name: reanalysis-era5-single-levels\n  path: {era5_file}\n"
                   "  request: {}\n")
    era5 = BmiEra5()
    era5.initialize(str(cfg))
    ice = SikuBmi()
    ice.initialize(str(scene))
    shape, lat, lon = _era5_grid(era5)
    ny, nx = ice.get_grid_shape(0, np.zeros(2, dtype=int))
    cy = ice.get_grid_y(0, np.zeros(ny))
    cx = ice.get_grid_x(0, np.zeros(nx))
    CY, CX = np.meshgrid(cy, cx % 360.0 if lon.min() >= 0 else cx, indexing="ij")
    pts = np.column_stack([CY.ravel(), CX.ravel()])
    t0 = era5.get_current_time()
    n = int(round((era5.get_end_time() - t0) / era5.get_time_step())) if records is None \
        else records
    for _ in range(n):
        for name, target in ((U10, "atmosphere_bottom_air_flow__x_component_of_velocity"),
                             (V10, "atmosphere_bottom_air_flow__y_component_of_velocity")):
            vals = era5.get_value(name, np.empty(era5.get_grid_size(0), dtype=np.float64))
            # ERA5 stores latitude from north to south: flip to the ascending axis
            field = vals.reshape(shape)[::-1]
            ice.set_value(target, RegularGridInterpolator((lat, lon), field)(pts))
        era5.update()
        ice.update_until(era5.get_current_time() - t0)
    era5.finalize()
    return ice


def main():  # pragma: no cover - a demonstration
    from siku_core.geometry.quat import latlon_of

    lon = np.arange(-152.0, -147.99, 0.25)
    lat = np.arange(76.0, 73.99, -0.25)
    hours = np.arange(4)
    u = np.full((4, len(lat), len(lon)), 8.0)
    v = np.full_like(u, -4.0)
    path = write_era5(Path("era5_demo.nc"), lon, lat, hours, u, v)  # the working directory
    ice = run(HERE / "era5_ice.toml", path)
    la, lo = latlon_of(ice.sim.state.q)
    print(f"after {ice.get_current_time() / 3600:g} h: mean ice position "
          f"{np.degrees(lo).mean():.4f}°E {np.degrees(la).mean():.4f}°N")
    ice.finalize()


if __name__ == "__main__":  # pragma: no cover
    main()
