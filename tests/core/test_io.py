"""Output layer: VTU/PVD series, PNG frames and plots, meshes."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest


from warpfree.errors import ParameterError
from warpfree.io.frames import _splat, estimate_spacing, plot_series, render_frame
from warpfree.io.vtk import VtuSeries, read_pvd


# ------------------------------------------------------------------------------------------------ VTK

def _fields(rng, n):
    return {
        "pressure": rng.standard_normal(n).astype(np.float32),
        "velocity": rng.standard_normal((n, 3)).astype(np.float32),
        "id": np.arange(n, dtype=np.int32),
        "density": (1000.0 + rng.standard_normal(n)).astype(np.float64),
    }


def test_vtu_round_trip(tmp_path):
    import meshio

    rng = np.random.default_rng(1)
    n = 257
    pts = rng.random((n, 3))
    fields = _fields(rng, n)
    series = VtuSeries(tmp_path, "fluid")
    path = series.write(3, 0.25, pts, fields)
    assert path == tmp_path / "vtk" / "fluid_0000003.vtu"
    m = meshio.read(path)
    np.testing.assert_array_equal(m.points, pts)
    assert set(m.point_data) == set(fields)
    for k, v in fields.items():
        np.testing.assert_array_equal(m.point_data[k], v)
        assert m.point_data[k].shape == v.shape
    assert m.cells[0].type == "vertex" and len(m.cells[0].data) == n


def test_vtu_2d_points_and_vectors_are_padded(tmp_path):
    import meshio

    pts = np.array([[0.0, 1.0], [2.0, 3.0]])
    vel = np.array([[1.0, 2.0], [3.0, 4.0]], dtype=np.float32)
    p = VtuSeries(tmp_path, "f2").write(0, 0.0, pts, {"velocity": vel, "wall": np.array([True, False])})
    m = meshio.read(p)
    np.testing.assert_array_equal(m.points, [[0, 1, 0], [2, 3, 0]])
    np.testing.assert_array_equal(m.point_data["velocity"], [[1, 2, 0], [3, 4, 0]])
    np.testing.assert_array_equal(m.point_data["wall"], [1, 0])


def test_vtu_rejects_bad_fields(tmp_path):
    s = VtuSeries(tmp_path, "f")
    with pytest.raises(ParameterError, match="pressure"):
        s.write(0, 0.0, np.zeros((4, 3)), {"pressure": np.zeros(5)})
    with pytest.raises(ParameterError, match="points"):
        s.write(0, 0.0, np.zeros((4, 4)), {})
    with pytest.raises(ParameterError, match="time"):
        s.write(0, float("nan"), np.zeros((4, 3)), {})


def test_pvd_index_and_resume(tmp_path):
    rng = np.random.default_rng(2)
    pts = rng.random((10, 3))
    s = VtuSeries(tmp_path, "fluid")
    times = [0.0, 0.1, 0.2, 0.30000000000000004]
    for k, t in enumerate(times):
        s.write(10 * k, t, pts, {"p": pts[:, 0]})
        # valid XML listing every step so far after every write
        assert [e[0] for e in read_pvd(tmp_path / "fluid.pvd")] == times[: k + 1]
    root = ET.parse(tmp_path / "fluid.pvd").getroot()
    assert root.get("type") == "Collection"
    ds = root.findall("./Collection/DataSet")
    assert [d.get("file") for d in ds] == [f"vtk/fluid_{10 * k:07d}.vtu" for k in range(4)]
    assert [float(d.get("timestep")) for d in ds] == times  # times read back exactly
    assert all((tmp_path / d.get("file")).exists() for d in ds)

    # resume from a checkpoint at t = 0.1: the later entries go, new ones are appended
    r = VtuSeries(tmp_path, "fluid", resume_after_time=0.1)
    assert [t for t, _ in r.entries] == [0.0, 0.1]
    assert [t for t, _ in read_pvd(tmp_path / "fluid.pvd")] == [0.0, 0.1]
    r.write(20, 0.15, pts, {"p": pts[:, 0]})
    r.write(20, 0.15, pts, {"p": pts[:, 0]})  # the same step again replaces, does not duplicate
    assert read_pvd(tmp_path / "fluid.pvd") == [
        (0.0, "vtk/fluid_0000000.vtu"), (0.1, "vtk/fluid_0000010.vtu"), (0.15, "vtk/fluid_0000020.vtu")]
    # resume without an index starts empty; a fresh series replaces an old index
    assert VtuSeries(tmp_path, "other", resume_after_time=1.0).entries == []
    VtuSeries(tmp_path, "fluid").write(0, 0.0, pts, {})
    assert len(read_pvd(tmp_path / "fluid.pvd")) == 1


# ---------------------------------------------------------------------------------------------- frames

def _image_stats(path):
    import matplotlib.image as mpimg

    assert path.exists() and path.stat().st_size > 1000
    img = mpimg.imread(str(path))
    return img, float(np.var(img[..., :3]))


def test_splat_painter_order():
    red, blue = (1.0, 0.0, 0.0, 1.0), (0.0, 0.0, 1.0, 1.0)
    # two discs at the same place: the later (nearer) one covers the earlier
    img = _splat(20, 20, (0, 1, 0, 1), [(np.array([0.5, 0.5]), np.array([0.5, 0.5]), 4.0,
                                         np.array([red, blue]))], supersample=1)
    np.testing.assert_allclose(img[10, 10], blue)
    # a disc of radius 4 px covers ~pi*16 pixels, its corners stay empty
    covered = int((img[..., 3] > 0).sum())
    assert 40 <= covered <= 60 and img[0, 0, 3] == 0.0
    # y up: a disc at the top of the extent lands in the first image rows
    img = _splat(10, 10, (0, 1, 0, 1), [(np.array([0.5]), np.array([0.95]), 0.4, np.array([red]))], 1)
    assert img[0, 5, 3] == 1.0 and img[9, 5, 3] == 0.0


def test_render_frame_2d(tmp_path):
    dx = 0.02
    g = np.mgrid[0:0.6:dx, 0:0.4:dx].reshape(2, -1).T + dx / 2
    pts = np.c_[g, np.zeros(len(g))]
    wall = np.c_[np.arange(-dx, 1.6, dx), np.full(81, -dx / 2), np.zeros(81)]
    assert estimate_spacing(pts[:, :2]) == pytest.approx(dx)
    out = render_frame(tmp_path / "f2.png", pts, pts[:, 1], 2, "y [m]", ((-0.05, 1.6), (-0.05, 0.8)),
                       boundary_points=wall, title="block", time=0.5)
    img, var = _image_stats(out)
    assert var > 1e-3
    # the fluid block covers its area: plenty of non-grey (coloured) pixels
    sat = img[..., :3].max(axis=2) - img[..., :3].min(axis=2)
    assert (sat > 0.3).mean() > 0.05
    # a long flat tank (colour bar below) and a constant field still draw
    out = render_frame(tmp_path / "flat.png", pts, np.ones(len(pts)), 2, "c", ((0, 4.0), (0, 0.5)))
    assert _image_stats(out)[1] > 1e-4
    with pytest.raises(ParameterError, match="bounds"):
        render_frame(tmp_path / "x.png", pts, pts[:, 1], 2, "y", ((1, 0), (0, 1)))
    with pytest.raises(ParameterError, match="values"):
        render_frame(tmp_path / "x.png", pts, pts[:10, 1], 2, "y", ((0, 1), (0, 1)))


def test_frames_of_a_run_reuse_their_figure_without_carrying_state(tmp_path):
    """2D frames keep their figure between frames (per layout): a frame drawn after another one of a different
    field range and title is byte for byte the frame drawn first."""
    dx = 0.02
    g = np.mgrid[0:0.6:dx, 0:0.4:dx].reshape(2, -1).T + dx / 2
    pts = np.c_[g, np.zeros(len(g))]
    bounds = ((-0.05, 1.6), (-0.05, 0.8))
    first = render_frame(tmp_path / "a.png", pts, pts[:, 1], 2, "y", bounds, title="A", time=0.1).read_bytes()
    other = render_frame(tmp_path / "b.png", pts + 0.3, 5.0 * pts[:, 0] - 2.0, 2, "y", bounds, title="B",
                         time=0.2).read_bytes()
    again = render_frame(tmp_path / "c.png", pts, pts[:, 1], 2, "y", bounds, title="A", time=0.1).read_bytes()
    assert other != first
    assert again == first


@pytest.mark.parametrize("view", ["side", "top"])
def test_render_frame_3d(tmp_path, view):
    dx = 0.05
    g = np.mgrid[0:0.5:dx, 0:0.5:dx, 0:0.4:dx].reshape(3, -1).T + dx / 2
    floor = np.mgrid[0:1.5:dx, 0:0.5:dx].reshape(2, -1).T
    floor = np.c_[floor, np.full(len(floor), -dx / 2)]
    vals = g[:, 2].copy()
    vals[0] = np.nan  # a non-finite value must not break the frame
    out = render_frame(tmp_path / "f3.png", g, vals, 3, "z [m]", ((0, 1.5), (0, 0.5), (-0.05, 0.6)),
                       boundary_points=floor, title="block", time=1.25, view=view)
    img, var = _image_stats(out)
    assert var > 1e-3
    sat = img[..., :3].max(axis=2) - img[..., :3].min(axis=2)
    assert (sat > 0.3).mean() > 0.02


def test_plot_series(tmp_path):
    x = np.linspace(0, 3, 40)
    ys = {"sim": np.sqrt(x), "coarse": (x[::2], np.sqrt(x[::2]) * 0.9)}
    out = plot_series(tmp_path / "s.png", x, ys, "t [s]", "front [m]", "surge front",
                      reference={"experiment": (x[::6], np.sqrt(x[::6]))})
    assert _image_stats(out)[1] > 1e-3
    with pytest.raises(ParameterError):
        plot_series(tmp_path / "s2.png", None, {"sim": np.sqrt(x)})


@pytest.mark.parametrize("background", [True, False])
def test_writer_calls_plot_functions_of_warpfree_only(tmp_path, background):
    """A scene's plot handed to the writer (``Run.plot``) is drawn there; a function outside warpfree is refused
    with the writer's error, not run."""
    from warpfree.io.writer import OutputError, OutputWriter

    writer = OutputWriter(background=background, plots=True)
    try:
        writer.start()
        t = np.linspace(0.0, 0.5, 26)
        writer.submit([("call", {"function": "warpfree.validation.dam_break_2d:plot_front",
                                 "kwargs": dict(path=str(tmp_path / "front.png"), t=t, x_front=1.0 + t, a=1.0, g=9.81,
                                                max_err=0.1)})])
        writer.finish()
        assert (tmp_path / "front.png").stat().st_size > 1000
        with pytest.raises(OutputError, match="warpfree.<module>:<function>"):
            writer.submit([("call", {"function": "os:system", "kwargs": {"command": "true"}})])
            writer.finish()
    finally:
        writer.close()
