"""Output layer: VTU/PVD series, PNG frames and plots, meshes."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest


from warpfree.errors import ParameterError
from warpfree.io.frames import (_splat, colour_range, estimate_spacing, length_scale, quantity_label,
                                render_frame, write_png)
from warpfree.io.vtk import VtuSeries, read_pvd, read_snapshot, read_units, write_pvtu, write_vtu


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


def test_vtu_records_units_that_readers_leave_aside(tmp_path):
    """Units ride on the data arrays as an attribute (non-ASCII as character references); meshio reads the values
    as before, read_units reads the units back, in a VTU and in a parallel index."""
    rng = np.random.default_rng(3)
    pts = rng.random((7, 3))
    fields = {"potential": rng.random(7), "velocity": rng.random((7, 2)), "species": np.zeros(7)}
    units = {"position": "λ_D", "potential": "m_e λ_D² ω_pe²/e", "velocity": "λ_D ω_pe", "species": "1"}
    path = write_vtu(tmp_path / "a.vtu", pts, fields, units)
    assert read_units(path) == units
    assert b"&#955;_D" in path.read_bytes() and path.read_bytes().isascii()
    points, read = read_snapshot(path)
    np.testing.assert_array_equal(points, pts)
    np.testing.assert_array_equal(read["potential"], fields["potential"])
    np.testing.assert_array_equal(read["velocity"][:, :2], fields["velocity"])
    # a unit only for some fields: the others carry none
    assert read_units(write_vtu(tmp_path / "b.vtu", pts, fields, {"potential": "V"})) == {"potential": "V"}
    write_pvtu(tmp_path / "c.pvtu", ["a.vtu"], pts[:0], {k: v[:0] for k, v in fields.items()}, units)
    assert read_units(tmp_path / "c.pvtu") == units
    np.testing.assert_array_equal(read_snapshot(tmp_path / "a.vtu")[1]["species"], fields["species"])


def test_a_vtu_without_points_is_refused_and_no_empty_index_is_left(tmp_path):
    with pytest.raises(ParameterError, match="points"):
        write_vtu(tmp_path / "empty.vtu", np.zeros((0, 3)), {})
    pts = np.zeros((2, 3))
    s = VtuSeries(tmp_path, "fluid")
    s.write(5, 0.5, pts, {})
    # a resume from before the first snapshot leaves no index naming nothing
    r = VtuSeries(tmp_path, "fluid", resume_after_time=0.1)
    assert r.entries == [] and not (tmp_path / "fluid.pvd").exists()


# ---------------------------------------------------------------------------------------------- frames

def test_labels_and_length_scales():
    assert quantity_label("pressure", "Pa") == "pressure (Pa)"
    assert quantity_label("species", "1") == "species (dimensionless)"
    assert quantity_label("parameter", None) == "parameter"
    assert length_scale(0.003, "m") == (1e-3, "mm")
    assert length_scale(0.2, "m") == (1.0, "m")
    assert length_scale(4.2, "m") == (1.0, "m")
    assert length_scale(2e-5, "m") == (1e-6, "µm")
    assert length_scale(0.003, "λ_D") == (1.0, "λ_D")  # other units as they are


def test_colour_range_of_a_series():
    """The scene's scale fixes the range; else a frame whose values spread; a field at rest fixes nothing and is
    drawn about its value, never with a degenerate range."""
    assert colour_range(np.zeros(5), (0.0, 6.0)) == ((0.0, 6.0), True)
    assert colour_range(np.array([1.0, 3.0, np.nan]), None) == ((1.0, 3.0), True)
    assert colour_range(np.zeros(5), None) == ((-1.0, 1.0), False)
    assert colour_range(np.full(5, 300.0), None) == ((270.0, 330.0), False)
    assert colour_range(np.full(5, -2.0), None) == ((-2.2, -1.8), False)
    assert colour_range(np.full(3, np.nan), None) == ((-1.0, 1.0), False)
    assert colour_range(1e5 + 1e-7 * np.arange(3), None)[1] is False  # round-off about a value is no spread


def test_png_writer_round_trip(tmp_path):
    from PIL import Image

    rgb = np.random.default_rng(0).integers(0, 256, (13, 17, 3), dtype=np.uint8)
    path = write_png(tmp_path / "x.png", rgb, dpi=100)
    with Image.open(path) as im:
        assert im.mode == "RGB" and np.array_equal(np.asarray(im), rgb)
        assert round(im.info["dpi"][0]) == 100
    with pytest.raises(ParameterError, match="rgb"):
        write_png(tmp_path / "y.png", rgb[..., 0])

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
    with pytest.raises(ParameterError, match="vmax"):
        render_frame(tmp_path / "x.png", pts, pts[:, 1], 2, "y", ((0, 1), (0, 1)), vmin=1.0, vmax=1.0)
    with pytest.raises(ParameterError, match="vmin"):
        render_frame(tmp_path / "x.png", pts, pts[:, 1], 2, "y", ((0, 1), (0, 1)), vmin=float("nan"), vmax=1.0)


def test_frames_of_one_range_share_every_pixel_but_particles_and_title(tmp_path):
    """Frames of a series (one colour range) differ only where the particles and the title are: axes, ticks, labels
    and colour bar are the same pixels (the template), and the colour of a value is the same in every frame."""
    dx = 0.02
    g = np.mgrid[0:0.6:dx, 0:0.4:dx].reshape(2, -1).T + dx / 2
    pts = np.c_[g, np.zeros(len(g))]
    bounds = ((-0.05, 1.6), (-0.05, 0.8))
    kw = dict(vmin=0.0, vmax=2.0, field_unit="m/s", length_unit="m", spacing=dx)
    a = _image_stats(render_frame(tmp_path / "a.png", pts, np.full(len(pts), 0.5), 2, "speed", bounds,
                                  title="t = 0", **kw))[0]
    b = _image_stats(render_frame(tmp_path / "b.png", pts + [0.8, 0.0, 0.0], np.full(len(pts), 0.5), 2, "speed",
                                  bounds, title="t = 1", **kw))[0]
    differ = np.any(a != b, axis=2)
    assert differ.any() and not differ[:, int(0.86 * a.shape[1]):].any()  # the colour bar and its label

    def block_colour(img):
        return np.median(img[differ & (img.max(axis=2) - img.min(axis=2) > 0.2)], axis=0)  # saturated: particles

    np.testing.assert_allclose(block_colour(a), block_colour(b), atol=1.5 / 255)


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


def test_an_obstacle_under_water_stays_visible_in_3d(tmp_path):
    """An obstacle wholly inside the fluid, which the fluid in front of it hides, is drawn over it translucent with
    its outline: the frame with it differs from the frame without it in both views."""
    dx = 0.05
    water = np.mgrid[0:1.0:dx, 0:0.5:dx, 0:0.4:dx].reshape(3, -1).T + dx / 2
    solid = np.mgrid[0.4:0.6:dx, 0.2:0.3:dx, 0.1:0.25:dx].reshape(3, -1).T + dx / 2
    inside = np.all((water[:, None, :] - solid[None, :, :]) ** 2 < 1e-12, axis=2).any(axis=1)
    water = water[~inside]
    kw = dict(vmin=0.0, vmax=0.4, field_unit="m", length_unit="m", spacing=dx)
    bounds = ((0, 1.0), (0, 0.5), (0, 0.6))
    without = _image_stats(render_frame(tmp_path / "a.png", water, water[:, 2], 3, "z", bounds, **kw))[0]
    with_obstacle = _image_stats(render_frame(tmp_path / "b.png", water, water[:, 2], 3, "z", bounds,
                                              solid_points=solid, **kw))[0]
    differ = np.any(np.abs(with_obstacle - without) > 0.05, axis=2)
    half = differ.shape[1] // 2
    assert differ[:, :half].sum() > 50 and differ[:, half:].sum() > 50  # the perspective and the side view


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
