"""The report's six case studies as shipped scenes (``examples/case_studies``), run here on
stand-in wind files of the NCEP/NCAR layout (the reanalysis itself is the user's download)."""
from __future__ import annotations

import importlib.util
import shutil
from pathlib import Path

import numpy as np
import pytest

from siku_core.run.cli import default_scene_path
from siku_core.scene.scene_file import load_scene
from siku_core.run.simulation import Simulation

HERE = Path(__file__).resolve().parent.parent / "examples" / "case_studies"
SMALL = {"elements.mesh.spacing": "30e3", "elements.mesh.coast_spacing": "20e3",
         "elements.mesh.cache": "false", "time.dt": "3", "time.duration": "3h"}


def _cases():
    spec = importlib.util.spec_from_file_location("siku_case_studies", HERE / "cases.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


CASES = _cases()


def test_six_case_scenes_with_the_report_dates_and_the_default_pack():
    assert sorted(CASES.CASES) == ["1994-02-17", "1996-03-17", "2000-02-08", "2000-03-06",
                                   "2001-04-06", "2003-04-02"]
    default = load_scene(default_scene_path()).cfg.elements.mesh
    for case, c in CASES.CASES.items():
        cfg = load_scene(CASES.scene_path(case)).cfg
        assert cfg.time.start.replace(tzinfo=None) == c["start"]
        assert cfg.time.total == c["hours"] * 3600.0
        u, v = CASES.wind_files(case)
        params = cfg.forcing[0].field.params
        assert params["u_file"] == f"ncep/{u.name}" and params["v_file"] == f"ncep/{v.name}"
        assert u.name == f"uwnd.sig995.{c['start'].year}.nc"
        # the wind spins up as the default scene's does (no impulsive start at the coast)
        assert cfg.forcing[0].ramp == load_scene(default_scene_path()).cfg.forcing[0].ramp
        mesh = cfg.elements.mesh
        for key in ("lon", "lat", "spacing", "coast_spacing", "land", "landfast", "seed"):
            assert getattr(mesh, key) == getattr(default, key), (case, key)


def test_a_case_runs_on_files_of_the_ncep_layout(tmp_path):
    """Case 2001-04-06 at reduced size (30 km floes, 3 h) on stand-in files: the wind is read
    from the year files at the case's dates, and the pack drifts with it (the mean ice
    velocity has a positive component along the mean wind over the moving ice)."""
    case = "2001-04-06"
    shutil.copy(CASES.scene_path(case), tmp_path)
    u, v = CASES.write_standin(case, tmp_path / "ncep")
    assert u.name == "uwnd.sig995.2001.nc"
    with pytest.raises(FileExistsError):
        CASES.write_standin(case, tmp_path / "ncep")
    sim = Simulation(load_scene(tmp_path / CASES.scene_path(case).name, SMALL), out=False,
                     progress=False)
    sim.run()
    field = sim.forcing[0].field
    # records every 6 h from 6 h before the start: the run's 0-3 h lies between records 1, 2
    assert sorted(set(field.records_read)) == [1, 2]
    from siku_core.geometry.quat import centers, east_north_local
    from siku_core.state import FREE
    from siku_core.geometry.sphere import xyz_to_lonlat

    st = sim.state
    free = st.flags == FREE
    lon, lat = xyz_to_lonlat(centers(st.q[free]))
    wu, wv = field.sample(sim.time, np.radians(lat), np.radians(lon))
    ve = np.empty(free.sum())
    vn = np.empty(free.sum())
    for k, i in enumerate(np.flatnonzero(free)):
        ex, ey, nx, ny = east_north_local(st.q[i])
        ve[k] = st.V[i, 0] * ex + st.V[i, 1] * ey
        vn[k] = st.V[i, 0] * nx + st.V[i, 1] * ny
    along = (ve.mean() * wu.mean() + vn.mean() * wv.mean()) / np.hypot(wu.mean(), wv.mean())
    assert along > 0.0
