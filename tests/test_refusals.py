"""Bad input ends in one ``siku: error:`` line naming the file and key, exit status 2: never a
traceback, never a hang, never memory without bound (the cases a second round of fuzzing and
fault injection found: mesh spacings, nesting, folders named by files, schedulers that are not
Dask's, sweeps and packs past the memory, messages that named the wrong thing)."""
from __future__ import annotations

import contextlib
import socket
import threading
import time

import pytest

from siku_core.run.cli import main
from siku_core.testing.scenes import scene_text


def one_error(capsys) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("siku: error:")]
    assert len(lines) == 1, err
    return lines[0]


@pytest.fixture
def here(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    return tmp_path


def small() -> str:
    return scene_text([(-150.0, 75.0)], forcing=[{"source": "water_drag"}], duration=600, dt=60,
                      output={"file": "out.h5", "every": 120})


MESH = ('[time]\nduration = "10min"\ndt = 60\n[elements.mesh]\nlon = [-150.0, -149.0]\n'
        'lat = [72.0, 72.3]\nspacing = {}\nland = "none"\ncache = false\n')


# ------------------------------------------------------------------ 13
@pytest.mark.parametrize("spacing, says", [
    ("1e-200", "[elements]: the scene would build about inf elements"),
    ("1e300", "[elements.mesh]: spacing = 1e+300 m: the region is only about"),
    ("3e4", "[elements.mesh]: spacing = 30000 m: the region is only about")])
def test_13_mesh_spacings_the_region_cannot_hold(here, capsys, spacing, says):
    (here / "m.toml").write_text(MESH.format(spacing), encoding="utf-8")
    assert main(["run", "m.toml", "--no-progress", "--out", "o.h5"]) == 2
    assert f"m.toml {says}" in one_error(capsys)


def test_13_a_mesh_box_wider_than_the_full_circle(here, capsys):
    text = MESH.format("6e3").replace("[-150.0, -149.0]", "[-1500.0, -149.5]")
    (here / "m.toml").write_text(text, encoding="utf-8")
    assert main(["run", "m.toml", "--no-progress", "--out", "o.h5"]) == 2
    assert "m.toml [elements.mesh]: lon = [-1500, -149.5]: need east - west <= 360" in \
        one_error(capsys)
    assert not (here / "o.h5").exists()


@pytest.mark.parametrize("text", ["a = " + "[" * 3000 + "]" * 3000,
                                  "x = " + "{a = " * 2000 + "1" + "}" * 2000,
                                  '[integrator]\nparams = {x = ' + "[" * 600 + "]" * 600 + "}"])
def test_13_deeply_nested_toml(here, capsys, text):
    (here / "deep.toml").write_text(text, encoding="utf-8")
    assert main(["run", "deep.toml", "--no-progress"]) == 2
    assert "deep.toml: arrays or tables nested more than 32 levels deep" in one_error(capsys)
    (here / "sweep.toml").write_text(text, encoding="utf-8")
    assert main(["ensemble", "sweep.toml", "--no-progress"]) == 2
    assert "sweep.toml: arrays or tables nested" in one_error(capsys)


# ------------------------------------------------------------------ 15
def test_15_a_folder_argument_naming_a_file(here, capsys):
    (here / "scene.toml").write_text(small(), encoding="utf-8")
    assert main(["run", "scene.toml", "--no-progress", "--no-plots"]) == 0
    capsys.readouterr()
    (here / "afile").write_text("mine", encoding="utf-8")
    assert main(["plot", "out.h5", "--out-dir", "afile", "--no-animation"]) == 2
    assert "afile: cannot be made a folder for the pictures" in one_error(capsys)
    (here / "sweep.toml").write_text('scene = "scene.toml"\nout_dir = "afile"\n[cluster]\n'
                                     'scheduler = "serial"\n[[axis]]\nkey = "run.max_speed"\n'
                                     'values = [100.0]\n', encoding="utf-8")
    assert main(["ensemble", "sweep.toml", "--no-progress"]) == 2
    msg = one_error(capsys)
    assert "sweep.toml" in msg and "afile" in msg, msg
    assert (here / "afile").read_text(encoding="utf-8") == "mine"


# ------------------------------------------------------------------ 16
@contextlib.contextmanager
def _server(greeting: bytes = b""):
    """A local TCP server that accepts every connection and sends it ``greeting`` (nothing:
    it never says a word); yields its address."""
    srv = socket.socket()
    srv.bind(("127.0.0.1", 0))
    srv.listen(8)
    held = []
    stop = threading.Event()

    def serve():
        srv.settimeout(0.2)
        while not stop.is_set():
            try:
                held.append(srv.accept()[0])
            except OSError:
                continue
            if greeting:
                held[-1].sendall(greeting)

    t = threading.Thread(target=serve, daemon=True)
    t.start()
    try:
        yield f"tcp://127.0.0.1:{srv.getsockname()[1]}"
    finally:
        stop.set()
        t.join()
        for c in held:
            c.close()
        srv.close()


SWEEP_TO = ('scene = "scene.toml"\n[cluster]\ntimeout = 2\n[[axis]]\nkey = "run.max_speed"\n'
            'values = [100.0]\n')


def test_16_a_scheduler_that_is_not_dask_is_given_up_after_the_timeout(here, capsys):
    """A server that accepts and never speaks Dask's protocol."""
    pytest.importorskip("distributed")
    (here / "scene.toml").write_text(small(), encoding="utf-8")
    (here / "sweep.toml").write_text(SWEEP_TO, encoding="utf-8")
    t0 = time.monotonic()
    with _server() as address:
        assert main(["ensemble", "sweep.toml", "--scheduler", address, "--no-progress"]) == 2
    assert time.monotonic() - t0 < 30
    assert "cannot reach the Dask scheduler" in one_error(capsys)


def test_16_a_server_answering_in_another_protocol_is_refused_in_one_line(here, capsys):
    """A server that answers with text (an HTTP error page): Dask reads its first eight bytes
    as a message length of about 3e18 bytes. One line saying so, no allocation."""
    pytest.importorskip("distributed")
    (here / "scene.toml").write_text(small(), encoding="utf-8")
    (here / "sweep.toml").write_text(SWEEP_TO, encoding="utf-8")
    page = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 11\r\n\r\nBad Request"
    with _server(page) as address:
        assert main(["ensemble", "sweep.toml", "--scheduler", address, "--no-progress"]) == 2
    msg = one_error(capsys)
    assert "the reply is not Dask's protocol" in msg and "EiB" not in msg, msg


def test_16_a_sweep_of_too_many_members_is_refused_before_it_makes_them(here, capsys):
    (here / "scene.toml").write_text(small(), encoding="utf-8")
    draw = ('[[axis]]\nn = 1000000\ndraw = {{ "{}" = {{ distribution = "uniform", low = 1.0, '
            'high = 2.0 }} }}\n')
    (here / "sweep.toml").write_text('scene = "scene.toml"\n' + draw.format("run.max_speed")
                                     + draw.format("planet.rotation_rate"), encoding="utf-8")
    assert main(["ensemble", "sweep.toml", "--no-progress"]) == 2
    assert "sweep.toml: the axes make 1e+12 members" in one_error(capsys)


def test_16_long_thin_pack_cells_count_in_the_memory_estimate(monkeypatch):
    from siku_core import SceneError
    from siku_core.run import limits
    from siku_core.testing.scenes import make_scene

    def pack(lon_width: float, lat_width: float):
        return make_scene([], packs=[{"lon": [0.0, lon_width], "lat": [0.0, lat_width],
                                      "nx": 400, "ny": 400}])

    monkeypatch.setattr(limits, "physical_memory", lambda: 4 * 2**30)
    limits.check_limits(pack(4.0, 4.0))  # 160 000 square cells: about 0.66 GB
    with pytest.raises(SceneError, match=r"about 1.6e\+05 elements need about 9.\d+ GiB"):
        limits.check_limits(pack(40.0, 0.04))  # 1000:1


# ------------------------------------------------------------------ 18
def test_18_messages_name_the_file_key_and_what_happened(here, capsys):
    from siku_core.testing.contact_conformance import contact_scene_text, square_pack

    text = contact_scene_text("distributed_spring", {"tensile_strain": float("inf")},
                              packs=[square_pack(30.0, 72.0, 3, 2, 2000.0, seed=7)], dt=0.1,
                              steps=10, output={"file": "out.h5"})
    (here / "ts.toml").write_text(text, encoding="utf-8")
    assert main(["run", "ts.toml", "--no-progress"]) == 2
    msg = one_error(capsys)
    assert "ts.toml [contact] (distributed_spring): key 'tensile_strain' = inf" in msg, msg
    (here / "v.toml").write_text(small().replace('[integrator]', '[integrator]').replace(
        "vertices", "velocity = [1e300, 0.0]\nvertices"), encoding="utf-8")
    assert main(["run", "v.toml", "--no-progress"]) == 2
    msg = one_error(capsys)
    assert "v.toml [elements]: element 0 starts with a speed of 1e+300 m/s" in msg, msg
    assert "holds the snapshots" not in msg and not (here / "out.h5").exists()
    # a UTF-8 byte-order mark is not a syntax error
    (here / "bom.toml").write_bytes(b"\xef\xbb\xbf" + small().encode())
    assert main(["run", "bom.toml", "--no-progress", "--no-plots"]) == 0
    capsys.readouterr()
    # siku export of a NetCDF file says what the file is
    (here / "w.toml").write_text(small().replace('file = "out.h5"', 'file = "w.nc"\n'
                                                 'writer = "netcdf"'), encoding="utf-8")
    assert main(["run", "w.toml", "--no-progress", "--no-plots"]) == 0
    capsys.readouterr()
    assert main(["export", "w.nc"]) == 2
    msg = one_error(capsys)
    assert "w.nc: is a netcdf output file of siku, already NetCDF" in msg, msg


# ------------------------------------------------------------------ 14
def test_14_an_output_with_no_snapshot_is_refused_before_any_work(here, capsys):
    """An output whose runs left no complete snapshot (every state dataset cut to length 0):
    plot, export and grid say so in one line and write nothing (they drew, exported or
    gridded an empty or failing file before)."""
    import h5py

    (here / "scene.toml").write_text(small(), encoding="utf-8")
    assert main(["run", "scene.toml", "--no-progress", "--no-plots"]) == 0
    capsys.readouterr()
    with h5py.File(here / "out.h5", "r+") as f:
        f["states"].visititems(lambda name, d: d.resize(0, axis=0) if isinstance(
            d, h5py.Dataset) and d.maxshape and d.maxshape[0] is None else None)
    grid = ["--lon", "-151", "-149", "--lat", "74.5", "75.5", "--resolution", "0.25",
            "--no-progress"]
    for args, doing in ((["plot", "out.h5", "--no-animation", "--out-dir", "pics"], "draw"),
                        (["export", "out.h5", "--out", "e.nc"], "export"),
                        (["grid", "out.h5", "--out", "g.nc", *grid], "grid")):
        assert main(args) == 2, args
        assert f"out.h5: holds no complete snapshot yet, nothing to {doing}" in one_error(capsys)
    assert not {"e.nc", "g.nc"} & {p.name for p in here.iterdir()}
    assert not any((here / "pics").glob("*.png"))
