"""Headless PNG frames of particle fields (the validation figures are :mod:`warpfree.io.validation_plots`).

- :func:`render_frame` draws one frame. 1D: the field against x. 2D: the particles as discs coloured by a field, sized
  so that particles at the mean spacing touch, boundary particles grey, obstacles in a colour of their own. 3D: two
  views side by side, an oblique perspective view (painter's algorithm: particles drawn far to near so near ones cover
  far ones, darker with depth) and an orthographic side (x–z) or top (x–y) view, also depth sorted; the container
  bounds drawn as a box outline, boundary particles faint behind the fluid, and the obstacles seen through the fluid
  (drawn once more over it, translucent, with their outline).

How a frame is drawn (chosen by measurement: ``bench/core/frame_cost.py``). What a frame series keeps from frame to
frame (axes, ticks, labels, the colour bar of its one colour range, the panels' titles) is drawn once by Matplotlib
into a *template* (per thread, per layout): the figure's pixels, and for each panel the pixels under and over its
particles (the axes' background, the box edges behind; the spines, the box edges in front). A frame then costs only
its particles, rasterised by NumPy (:func:`_splat`) into the panels' pixel boxes, its title (Pillow, in Matplotlib's
font) and the PNG encoding (:func:`write_png`: no filter, zlib level 1). 1D frames keep their Matplotlib figure and
draw only the curve over the saved background (blitting). The same arguments give the same bytes, in any thread or
process.

Units: lengths in the scene's unit (``length_unit``: "m" is shown with the SI prefix that suits the plotted extent,
e.g. mm), ``time`` in ``time_unit``, the field in ``field_unit`` (labels as :func:`quantity_label` writes them).
"""

from __future__ import annotations

import math
import os
import struct
import threading
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..units import display_scale
from .validation_plots import new_figure

__all__ = ["render_frame", "estimate_spacing", "quantity_label", "length_scale", "colour_range",
           "write_png", "DIMENSIONLESS"]

_BOUNDARY_GREY = (0.55, 0.55, 0.55)
_SOLID_COLOUR = (0.62, 0.45, 0.28)  # obstacles: opaque, a colour no colormap of the fields uses
#: 3D: the opacity of an obstacle drawn again over the fluid (it shows through water that covers it) and of its outline
_SOLID_GHOST_ALPHA, _SOLID_OUTLINE_ALPHA = 0.45, 0.9
_NON_FINITE = (1.0, 0.0, 1.0, 1.0)  # magenta: a non-finite field value
#: the unit string of a dimensionless quantity (SI's "1"), shown as "(dimensionless)"
DIMENSIONLESS = "1"
#: the zorder of the particle image in a panel: artists above it are drawn over the particles, the rest under them
_IMAGE_ZORDER = 1.0


# ----------------------------------------------------------------------------------------------- labels and ranges

def quantity_label(name: str, unit: str | None) -> str:
    """``"pressure (Pa)"``; a dimensionless quantity (unit "1") ``"name (dimensionless)"``; no unit known: the name."""
    if unit is None:
        return name
    return f"{name} ({'dimensionless' if unit == DIMENSIONLESS else unit})"


def length_scale(extent: float, unit: str | None) -> tuple[float, str | None]:
    """(factor, unit) axes show lengths in: metres get the largest SI prefix that puts the plotted ``extent`` (m) at
    0.05 or more of it (a 3 mm resistor reads 0 to 3 mm, a 0.2 m cavity stays in m); any other unit is shown as is."""
    return display_scale(extent, unit, "m", 0.05)


def colour_range(values, scale=None) -> tuple[tuple[float, float], bool]:
    """The colour range of a frame series and whether it is fixed: ``((vmin, vmax), fixed)``.

    ``scale`` (vmin, vmax), the scene's, fixes it. Otherwise the finite ``values`` of the frame fix it when they spread
    (max - min above 1e-9 of their largest magnitude); a frame without spread (a field at rest: every value equal, or
    none finite) fixes nothing, and is drawn with the range c ± |c|/10 about its value c (c ± 1 in the field's unit
    when c = 0, or when no value is finite): the next frame is asked again.
    """
    if scale is not None:
        return (float(scale[0]), float(scale[1])), True
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    v = v[np.isfinite(v)]
    if v.size:
        lo, hi = float(v.min()), float(v.max())
        if hi - lo > 1e-9 * max(abs(lo), abs(hi)):
            return (lo, hi), True
        c = 0.5 * (lo + hi)
    else:
        c = 0.0
    half = abs(c) / 10.0 if c != 0.0 else 1.0
    return (c - half, c + half), False


def _check_range(vmin, vmax, values) -> tuple[float, float]:
    """vmin, vmax as given, else (either missing) from :func:`colour_range` of ``values``; vmax > vmin, both finite."""
    if vmin is None or vmax is None:
        (lo, hi), _ = colour_range(values)
        vmin = lo if vmin is None else vmin
        vmax = hi if vmax is None else vmax
    for name, value in (("vmin", vmin), ("vmax", vmax)):
        if not math.isfinite(float(value)):
            raise ParameterError(name, f"must be finite, got {value!r}")
    if float(vmax) <= float(vmin):
        raise ParameterError("vmax", f"must be above vmin ({vmin!r}), got {vmax!r}")
    return float(vmin), float(vmax)


# ----------------------------------------------------------------------------------------------- helpers

def _png_chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def write_png(path, rgb: np.ndarray, dpi: float | None = None) -> Path:
    """Write an 8-bit RGB image (H, W, 3) as a PNG, atomically; returns the path. Rows unfiltered, zlib level 1: 3x
    faster than Pillow's encoder at its fastest level for frames of the same size (large flat areas compress well
    either way). ``dpi``: recorded as the image's physical pixel size (pHYs), as Matplotlib does."""
    img = np.ascontiguousarray(rgb, dtype=np.uint8)
    if img.ndim != 3 or img.shape[2] != 3:
        raise ParameterError("rgb", f"must be an (H, W, 3) image, got shape {img.shape}")
    h, w, _ = img.shape
    rows = np.empty((h, 3 * w + 1), dtype=np.uint8)
    rows[:, 0] = 0  # filter type 0 (none) on every row
    rows[:, 1:] = img.reshape(h, -1)
    parts = [b"\x89PNG\r\n\x1a\n", _png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 2, 0, 0, 0))]
    if dpi is not None:
        per_metre = int(round(dpi / 0.0254))
        parts.append(_png_chunk(b"pHYs", struct.pack(">IIB", per_metre, per_metre, 1)))
    parts += [_png_chunk(b"IDAT", zlib.compress(rows, 1)), _png_chunk(b"IEND", b"")]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}.png")
    tmp.write_bytes(b"".join(parts))
    os.replace(tmp, path)
    return path


def _check_bounds(bounds, dim: int) -> np.ndarray:
    try:
        b = np.asarray(bounds, dtype=np.float64)
    except (TypeError, ValueError):
        raise ParameterError("bounds", f"must be {dim} (min, max) pairs, got {bounds!r}") from None
    if b.shape != (dim, 2) or not np.all(np.isfinite(b)) or np.any(b[:, 1] <= b[:, 0]):
        raise ParameterError("bounds", f"must be {dim} finite (min, max) pairs with max > min, "
                                       f"got {bounds!r}")
    return b


def _check_points(name: str, points, dim: int) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] < dim or p.shape[1] > 3:
        raise ParameterError(name, f"must have shape (N, {dim}) or (N, 3), got {p.shape}")
    return p[:, :dim]


def estimate_spacing(points: np.ndarray, sample: int = 256) -> float:
    """Median nearest-neighbour distance of ``points`` (N, d), from ``sample`` query points evenly spread over the
    array (coincident points left aside; nan for fewer than two distinct points). Brute force in NumPy, O(sample N):
    the run shell calls it once per frame series, and SciPy's import would cost the stepping process more."""
    p = np.asarray(points, dtype=np.float64)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) < 2:
        return float("nan")
    q = p if len(p) <= sample else p[np.linspace(0, len(p) - 1, sample).astype(np.int64)]
    block = max(1, (1 << 22) // len(p))  # queries per block: at most ~4 M distances at a time
    nearest = []
    for s in range(0, len(q), block):
        d2 = np.zeros((min(block, len(q) - s), len(p)))
        for axis in range(p.shape[1]):
            d2 += (q[s:s + block, axis, None] - p[None, :, axis]) ** 2
        d2[d2 == 0.0] = np.inf  # the query itself, and points on top of it
        nearest.append(np.sqrt(d2.min(axis=1)))
    d = np.concatenate(nearest)
    d = d[np.isfinite(d)]
    return float(np.median(d)) if len(d) else float("nan")


def _spacing(points: np.ndarray, spacing, extent: np.ndarray) -> float:
    if spacing is not None:
        from ..errors import require_positive

        return require_positive("spacing", spacing)
    s = estimate_spacing(points) if len(points) >= 2 else float("nan")
    if not (math.isfinite(s) and s > 0):
        # One particle (or all coincident, or none): share the box evenly among them (at least one).
        s = float(np.prod(extent)) ** (1.0 / len(extent)) / max(len(points), 1) ** (1.0 / len(extent))
    return s


def _title(title: str, time, time_unit: str) -> str:
    if time is None:
        return title
    t = f"t = {float(time):.4g} {time_unit}"
    return f"{title}   {t}" if title else t


def _colormap(cmap):
    import matplotlib

    return matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap


def _colours(v, vmin: float, vmax: float, cm) -> np.ndarray:
    """RGBA (N, 4) of the values ``v`` on the colormap ``cm`` over [vmin, vmax] (values beyond take its end colours, as
    the colour bar's extensions say); non-finite values magenta."""
    from matplotlib.colors import Normalize

    rgba = np.asarray(cm(Normalize(vmin, vmax)(v)), dtype=np.float64).reshape(-1, 4)
    rgba[~np.isfinite(v)] = _NON_FINITE
    return rgba


#: Disc diameter in units of the particle spacing. 1 just touches along the lattice axes but leaves a
#: white dot in every lattice hole (distance √2/2 spacing to the nearest centres); 1.45 closes them, so a
#: filled region reads as filled, at the cost of drawing the free surface ~0.2 spacing too far out.
DISC = 1.45

#: pixel writes (2x-supersampled stamps) above which discs are drawn without supersampling
_SUPERSAMPLE_BUDGET = 2.5e6


def _buffer(name: str, size: int, dtype) -> np.ndarray:
    """A flat scratch array of this thread, reused from frame to frame (no fresh pages to fault in per frame)."""
    buffers = _templates.__dict__.setdefault("buffers", {})
    buf = buffers.get(name)
    if buf is None or buf.size < size or buf.dtype != dtype:
        buf = buffers[name] = np.empty(size, dtype=dtype)
    return buf[:size]


def _top_disc(Ws: int, Hs: int, cx, cy, r) -> np.ndarray:
    """(Hs, Ws) int32: per pixel 1 + the index of the last disc (array order) covering its centre, 0 where none; a
    view of this thread's scratch buffer, valid until the next call.

    Discs are centred at (cx, cy) (pixels, y down) with radii r (pixels). A disc covers, in each pixel row within its
    radius, one run of pixels: those whose centre lies within sqrt(r² - dy²) of its centre's column. The runs of every
    disc and row are expanded into (pixel, disc) pairs at once; one ``np.maximum.at`` then keeps the last disc per
    pixel. The centre pixel is always drawn, however small the disc.
    """
    rank = np.arange(1, len(cx) + 1, dtype=np.int32)
    r = np.clip(r, 0.0, float(max(Ws, Hs)))
    keep = np.isfinite(cx) & np.isfinite(cy) & (cx > -r - 1) & (cx < Ws + r + 1) & (cy > -r - 1) & (cy < Hs + r + 1)
    rank, cx, cy, r = rank[keep], cx[keep], cy[keep], r[keep]
    R = int(np.ceil(r.max(initial=0.0)))
    # Draw into a buffer padded by the largest radius, so no disc needs a bounds test; crop after.
    pad = 2 * R + 3  # discs centred up to r + 1 outside the canvas still fit
    Wp, Hp = Ws + 2 * pad, Hs + 2 * pad
    padded = _buffer("top", Hp * Wp, np.int32)
    padded.fill(0)
    ix = np.floor(cx)
    iy = np.floor(cy)
    # row dy of a disc: pixel centres at x offsets dx + (ix + 0.5 - cx) within the half-width sqrt(r² - (dy + oy)²)
    dy = np.arange(-R, R + 1)
    oy = (iy + 0.5 - cy)[:, None] + dy[None, :]
    ox = (ix + 0.5 - cx)[:, None]
    with np.errstate(invalid="ignore"):
        half = np.sqrt(r[:, None] ** 2 - oy ** 2)  # nan (no run) where the row misses the disc
        first = np.ceil(-half - ox)
        last = np.floor(half - ox)
    first[:, R] = np.fmin(first[:, R], 0.0)  # the centre row reaches the centre pixel
    last[:, R] = np.fmax(last[:, R], 0.0)
    length = np.where(last >= first, last - first + 1.0, 0.0).astype(np.int32).ravel()
    start = ((iy + pad)[:, None] + dy[None, :]) * Wp + (ix + pad)[:, None] + np.nan_to_num(first)
    # pixel k of the run that starts at pixel s and is the j-th run: s + k = (s - offset_j) + (its index among all)
    before = np.cumsum(length) - length
    pixels = np.repeat((start.ravel() - before).astype(np.int32), length)
    pixels += np.arange(pixels.size, dtype=np.int32)
    ranks = np.repeat(np.repeat(rank, dy.size), length)
    np.maximum.at(padded, pixels, ranks)
    return padded.reshape(Hp, Wp)[pad:pad + Hs, pad:pad + Ws]


def _cover(width_px: int, height_px: int, extent, layers, supersample: int | None = None):
    """The discs of ``layers`` (see :func:`_splat`) rasterised at ``supersample`` x the resolution: ``(top, table,
    ss)``, ``top`` (H ss, W ss) int32 the index into ``table`` of the colour each sub-pixel takes (0: none), ``table``
    (discs + 1, 4) float32 the discs' colours premultiplied by their alpha (row 0 transparent), ``ss`` the
    supersampling used (None: 2 when that costs under :data:`_SUPERSAMPLE_BUDGET` pixel writes, else 1); ``top`` is
    None when no layer has a disc."""
    layers = [(X, Y, r, c) for X, Y, r, c in layers if len(X)]
    if supersample is None:
        work = 0.0  # pixel writes at 2x: a (2 ceil(2r) + 1)^2 stamp per disc
        for X, _, r, _ in layers:
            r2x = np.ceil(2.0 * np.broadcast_to(np.asarray(r, dtype=np.float64), (len(X),)))
            work += float(np.sum((2.0 * r2x + 1.0) ** 2))
        supersample = 2 if work <= _SUPERSAMPLE_BUDGET else 1
    ss = max(1, int(supersample))
    Ws, Hs = max(1, int(width_px)) * ss, max(1, int(height_px)) * ss
    if not layers:
        return None, np.zeros((1, 4), dtype=np.float32), ss
    x0, x1, y0, y1 = (float(e) for e in extent)
    sx, sy = Ws / (x1 - x0), Hs / (y1 - y0)
    cx = np.concatenate([(np.asarray(X, dtype=np.float64) - x0) * sx for X, _, _, _ in layers])
    cy = np.concatenate([(y1 - np.asarray(Y, dtype=np.float64)) * sy for _, Y, _, _ in layers])
    r = np.concatenate([np.broadcast_to(np.asarray(rr, dtype=np.float64) * ss, (len(X),)) for X, _, rr, _ in layers])
    rgba = np.concatenate([np.broadcast_to(np.asarray(c, dtype=np.float64), (len(X), 4)) for X, _, _, c in layers])
    table = np.zeros((len(rgba) + 1, 4), dtype=np.float32)
    table[1:, :3] = rgba[:, :3] * rgba[:, 3:4]
    table[1:, 3] = rgba[:, 3]
    return _top_disc(Ws, Hs, cx, cy, r), table, ss


def _blocks(top: np.ndarray, ss: int) -> tuple[np.ndarray, tuple]:
    """Each ss x ss block of sub-pixels ``top``: the index its first sub-pixel takes (H, W), and where the blocks are
    whose sub-pixels do not all take that index (``np.nonzero``'s tuple): edges of discs, a few per cent of them."""
    corner = top[0::ss, 0::ss]
    uniform = np.ones(corner.shape, dtype=bool)
    for j in range(ss):
        for i in range(ss):
            if i or j:
                uniform &= top[j::ss, i::ss] == corner
    return corner, np.nonzero(~uniform)


def _block_mean(top: np.ndarray, table: np.ndarray, ss: int, blocks: tuple) -> np.ndarray:
    """The mean of ``table[top]`` over the sub-pixels of each block in ``blocks`` (len, channels) float32."""
    acc = np.zeros((len(blocks[0]), table.shape[1]), dtype=np.float32)
    for j in range(ss):
        for i in range(ss):
            acc += table[top[j::ss, i::ss][blocks]]
    return acc / (ss * ss)


def _downsample(top: np.ndarray, table: np.ndarray, ss: int) -> np.ndarray:
    """``table[top]`` averaged over each ss x ss block: (H, W, channels) float32. A block one colour covers whole
    (most blocks) takes that colour as it is; the others the mean of their sub-pixels' colours."""
    if ss == 1:
        return np.take(table, top, axis=0)
    corner, mixed = _blocks(top, ss)
    out = np.take(table, corner, axis=0)
    if len(mixed[0]):
        out[mixed] = _block_mean(top, table, ss, mixed)
    return out


def _splat_premultiplied(width_px: int, height_px: int, extent, layers, supersample: int | None = None
                         ) -> np.ndarray:
    """:func:`_splat` as a float32 image (H, W, 4) of colours premultiplied by their alpha (alpha last)."""
    top, table, ss = _cover(width_px, height_px, extent, layers, supersample)
    if top is None:
        return np.zeros((max(1, int(height_px)), max(1, int(width_px)), 4), dtype=np.float32)
    return _downsample(top, table, ss)


def _to_bytes(rgb: np.ndarray) -> np.ndarray:
    """Colours in [0, 1] (any shape) as uint8, rounded to nearest."""
    return (np.clip(rgb, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _panel_pixels(panel: "_Panel", layers) -> np.ndarray:
    """The panel's finished pixels (height, width, 3) uint8 for a panel whose pixels under the particles are one
    colour: each disc colour is laid over that colour once (a table of a few thousand rows, not a million pixels),
    the sub-pixels' table rows averaged per pixel (:func:`_downsample`, linear, so the same colours as averaging
    first), then the pixels over the particles (:meth:`_Panel` ``over_*``) laid on top. What :func:`_compose` gives
    for the premultiplied image of the same discs, to rounding."""
    top, table, ss = _cover(panel.width, panel.height, panel.extent, layers)
    over_under = table[:, :3] + panel.under_colour[None, :] * (1.0 - table[:, 3:4])
    if top is None:
        pixels = np.broadcast_to(_to_bytes(over_under[0]), (panel.height, panel.width, 3)).copy()
    elif ss == 1:
        pixels = np.take(_to_bytes(over_under), top, axis=0)
    else:
        corner, mixed = _blocks(top, ss)
        pixels = np.take(_to_bytes(over_under), corner, axis=0)  # np.take: ~4x faster than [] on rows
        if len(mixed[0]):
            pixels[mixed] = _to_bytes(_block_mean(top, over_under, ss, mixed))
    i = panel.over_index
    if i is not None and i.size:
        flat = pixels.reshape(-1, 3)
        flat[i] = _to_bytes(panel.over_rgb + flat[i].astype(np.float32) / 255.0 * (1.0 - panel.over_alpha))
    return pixels


def _splat(width_px: int, height_px: int, extent, layers, supersample: int | None = None) -> np.ndarray:
    """Rasterise discs into an RGBA image (height_px, width_px, 4), painter's order.

    ``layers``: a list of ``(X, Y, radius_px, rgba)``, world coordinates (extent ``(x0, x1, y0, y1)``),
    disc radius in output pixels (scalar or per disc) and colours (N, 4); discs are drawn in list order
    and, within a layer, in array order, each covering the ones before it. Every pixel holds the colour
    of the last disc covering its centre. The image is rendered ``supersample`` times finer and averaged
    down (premultiplied alpha), which anti-aliases the disc edges; by default 2 when that costs under
    ~2.5 M pixel writes, else 1. Pure NumPy, O(N + covered pixels).
    """
    pm = _splat_premultiplied(width_px, height_px, extent, layers, supersample)
    alpha = pm[..., 3:4]
    img = np.zeros_like(pm)
    np.divide(pm[..., :3], alpha, out=img[..., :3], where=alpha > 0)
    img[..., 3:] = alpha
    return np.clip(img, 0.0, 1.0)


def _outline(pm: np.ndarray) -> np.ndarray:
    """The pixels on the edge of an image's covered region (alpha > 0.5 with an uncovered 4-neighbour), (H, W) bool."""
    inside = pm[..., 3] > 0.5
    edge = np.zeros_like(inside)
    edge[1:, :] |= inside[1:, :] & ~inside[:-1, :]
    edge[:-1, :] |= inside[:-1, :] & ~inside[1:, :]
    edge[:, 1:] |= inside[:, 1:] & ~inside[:, :-1]
    edge[:, :-1] |= inside[:, :-1] & ~inside[:, 1:]
    return edge


# ----------------------------------------------------------------------------------------------- templates

@dataclass
class _Panel:
    """One panel of a template: its pixel box in the figure (top-left origin), the world extent it shows, and the
    pixels under its particles (RGB, float32 in [0, 1]) and over them (those with any cover: flat indices into the box,
    premultiplied RGB and alpha)."""

    x0: int
    y0: int
    width: int
    height: int
    extent: tuple
    under: np.ndarray | None = None
    under_colour: np.ndarray | None = None  # the colour of ``under`` where it is one colour throughout (3,)
    over_index: np.ndarray | None = None
    over_rgb: np.ndarray | None = None
    over_alpha: np.ndarray | None = None

    @property
    def px_per_unit(self) -> float:
        return self.width / (self.extent[1] - self.extent[0])


@dataclass
class _Template:
    """A frame series' fixed pixels (H, W, 3) uint8, its panels and where its title goes."""

    pixels: np.ndarray
    panels: list
    title_x: float   # the title's centre (px from the left)
    title_y: float   # its baseline (anchor "ms") or top (anchor "mt"), px from the top
    title_anchor: str
    font_px: float
    dpi: float


#: the templates of the frame series drawn in this thread (a run draws one or two series; a few are kept)
_templates = threading.local()
_TEMPLATES_KEPT = 8


def _cached(key, build):
    cache = _templates.__dict__.setdefault("entries", {})
    if key not in cache:
        if len(cache) >= _TEMPLATES_KEPT:
            cache.pop(next(iter(cache)))
        cache[key] = build()
    return cache[key]


def _rgba(fig) -> np.ndarray:
    fig.canvas.draw()
    return np.array(fig.canvas.buffer_rgba(), dtype=np.uint8)  # straight (not premultiplied) alpha: Agg's "plain"


def _pixel_box(ax, fig_height_px: int) -> tuple[int, int, int, int]:
    """(x0, y0, width, height) of an axes in whole pixels, y0 from the figure's top."""
    bb = ax.get_window_extent()
    x0, x1 = int(round(bb.x0)), int(round(bb.x1))
    top, bottom = fig_height_px - int(round(bb.y1)), fig_height_px - int(round(bb.y0))
    return x0, top, max(1, x1 - x0), max(1, bottom - top)


def _capture(fig, panel_axes: list) -> tuple[np.ndarray, list[_Panel]]:
    """Render ``fig`` into its template pixels and, for each ``(ax, extent)`` of ``panel_axes``, the panel's pixels
    under and over the particle image (a panel's artists of zorder above :data:`_IMAGE_ZORDER` are over it). The
    figure is drawn whole once; the layers by drawing only their artists again on the cleared canvas."""
    full = _rgba(fig)
    renderer = fig.canvas.get_renderer()
    H = full.shape[0]
    panels = []
    for ax, extent in panel_axes:
        x0, y0, w, h = _pixel_box(ax, H)
        panel = _Panel(x0, y0, w, h, extent)
        box = (slice(y0, y0 + h), slice(x0, x0 + w))
        artists = sorted((a for a in ax.get_children() if a is not ax.patch and a.get_visible()),
                         key=lambda a: a.get_zorder())
        under = [fig.patch] + ([ax.patch] if ax.axison and ax.get_frame_on() else [])
        under += [a for a in artists if a.get_zorder() <= _IMAGE_ZORDER]
        over = [a for a in artists if a.get_zorder() > _IMAGE_ZORDER]
        for layer in (under, over):
            renderer.clear()  # transparent
            for a in layer:
                a.draw(renderer)
            pixels = np.array(renderer.buffer_rgba(), dtype=np.uint8)[box]
            if layer is under:
                panel.under = pixels[..., :3].astype(np.float32) / 255.0
                if np.all(panel.under == panel.under[0, 0]):
                    panel.under_colour = panel.under[0, 0].copy()
            else:
                flat = pixels.reshape(-1, 4)
                index = np.nonzero(flat[:, 3])[0]
                alpha = flat[index, 3:4].astype(np.float32) / 255.0
                panel.over_index, panel.over_alpha = index, alpha
                panel.over_rgb = flat[index, :3].astype(np.float32) / 255.0 * alpha
        panels.append(panel)
    return full[..., :3].copy(), panels


def _font(size_px: float):
    """Matplotlib's default font (DejaVu Sans) at ``size_px`` pixels, for Pillow; the basic layout engine (no
    libraqm), so the glyphs placed are the same on every machine with this Pillow."""
    from matplotlib import font_manager, rcParams
    from PIL import ImageFont

    path = font_manager.findfont(font_manager.FontProperties(family=rcParams["font.family"]))
    fonts = _templates.__dict__.setdefault("fonts", {})
    key = (path, round(size_px, 3))
    if key not in fonts:
        fonts[key] = ImageFont.truetype(path, size_px, layout_engine=ImageFont.Layout.BASIC)
    return fonts[key]


def _draw_title(pixels: np.ndarray, template: _Template, text: str) -> None:
    """Write ``text`` in black into ``pixels`` where the template's title goes (centred, kept inside the image)."""
    if not text:
        return
    from PIL import Image, ImageDraw

    size = template.font_px
    font = _font(size)
    left, top, right, bottom = font.getbbox(text, anchor=template.title_anchor)
    H, W = pixels.shape[:2]
    while right - left > W - 4 and size > 6:  # a title wider than the frame: smaller, never cut
        size *= 0.9
        font = _font(size)
        left, top, right, bottom = font.getbbox(text, anchor=template.title_anchor)
    x = min(max(template.title_x, 2 - left), W - 2 - right)
    y = template.title_y
    x0, y0 = int(math.floor(x + left)), int(math.floor(y + top))
    w, h = int(math.ceil(x + right)) - x0 + 1, int(math.ceil(y + bottom)) - y0 + 1
    mask = Image.new("L", (w, h), 0)
    ImageDraw.Draw(mask).text((x - x0, y - y0), text, fill=255, font=font, anchor=template.title_anchor)
    m = np.asarray(mask, dtype=np.uint16)
    ys, xs = slice(max(y0, 0), min(y0 + h, H)), slice(max(x0, 0), min(x0 + w, W))
    m = m[ys.start - y0:ys.stop - y0, xs.start - x0:xs.stop - x0, None]
    region = pixels[ys, xs].astype(np.uint16)
    pixels[ys, xs] = ((region * (255 - m) + 127) // 255).astype(np.uint8)


def _compose(template: _Template, images: list[np.ndarray], title: str) -> np.ndarray:
    """The frame: the template's pixels with each panel's premultiplied particle image (H, W, 4) between the pixels
    under and over it (or the panel's finished pixels, (H, W, 3) uint8: :func:`_panel_pixels`), and the title."""
    out = template.pixels.copy()
    for panel, pm in zip(template.panels, images):
        if pm.dtype == np.uint8:  # finished already (:func:`_panel_pixels`)
            out[panel.y0:panel.y0 + panel.height, panel.x0:panel.x0 + panel.width] = pm
            continue
        under = panel.under if panel.under_colour is None else panel.under_colour
        rgb = pm[..., :3] + under * (1.0 - pm[..., 3:4])
        flat = rgb.reshape(-1, 3)
        i = panel.over_index
        flat[i] = panel.over_rgb + flat[i] * (1.0 - panel.over_alpha)
        out[panel.y0:panel.y0 + panel.height, panel.x0:panel.x0 + panel.width] = _to_bytes(rgb)
    _draw_title(out, template, title)
    return out


def _add_colorbar(fig, vmin, vmax, cm, rect, label: str, orientation: str = "vertical"):
    from matplotlib.cm import ScalarMappable
    from matplotlib.colors import Normalize

    cax = fig.add_axes(rect)
    sm = ScalarMappable(norm=Normalize(vmin, vmax), cmap=cm)
    cb = fig.colorbar(sm, cax=cax, orientation=orientation, extend="both")
    cb.set_label(label)
    return cb


def _fit_box(extent_x: float, extent_y: float, max_w: float, max_h: float) -> tuple[float, float]:
    """Axes size (in) of a box with the data aspect ratio that fits max_w x max_h."""
    scale = min(max_w / extent_x, max_h / extent_y)
    return extent_x * scale, extent_y * scale


def _axis_labels(b: np.ndarray, axes: tuple[int, int], length_unit: str | None):
    """(factor, x label, y label) of a panel showing coordinates ``axes`` of the bounds ``b``."""
    factor, unit = length_scale(float(np.max(b[list(axes), 1] - b[list(axes), 0])), length_unit)
    return factor, quantity_label("xyz"[axes[0]], unit), quantity_label("xyz"[axes[1]], unit)


def _template_2d(b: np.ndarray, vmin, vmax, cm, field_label: str, length_unit, dpi: float) -> _Template:
    from matplotlib import rcParams

    lx, ly = b[0, 1] - b[0, 0], b[1, 1] - b[1, 0]
    wa, ha = _fit_box(lx, ly, 8.0, 6.0)
    horizontal = ha < 2.5  # a long flat tank: colour bar below
    left, right, bottom, top = 0.9, (0.3 if horizontal else 1.5), (1.45 if horizontal else 0.6), 0.5
    W, H = wa + left + right, ha + bottom + top
    extent = (b[0, 0], b[0, 1], b[1, 0], b[1, 1])
    factor, xlabel, ylabel = _axis_labels(b, (0, 1), length_unit)
    fig = new_figure(W, H, dpi)
    ax = fig.add_axes([left / W, bottom / H, wa / W, ha / H])
    ax.set_xlim(extent[0] / factor, extent[1] / factor)
    ax.set_ylim(extent[2] / factor, extent[3] / factor)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    rect = ([left / W, 0.62 / H, wa / W, 0.18 / H] if horizontal
            else [(left + wa + 0.2) / W, bottom / H, 0.2 / W, ha / H])
    _add_colorbar(fig, vmin, vmax, cm, rect, field_label, "horizontal" if horizontal else "vertical")
    pixels, panels = _capture(fig, [(ax, extent)])
    pad_px = rcParams["axes.titlepad"] * dpi / 72.0
    panel = panels[0]
    return _Template(pixels, panels, panel.x0 + 0.5 * panel.width, panel.y0 - pad_px, "ms",
                     _font_px("large", dpi), dpi)


def _font_px(size, dpi: float) -> float:
    from matplotlib.font_manager import FontProperties

    return FontProperties(size=size).get_size_in_points() * dpi / 72.0


def _frame_2d(p, v, b, bp, sp, h, vmin, vmax, cm, field_label, title, dpi, length_unit):
    key = ("2d", tuple(b.ravel()), vmin, vmax, cm.name, field_label, length_unit, dpi)
    template = _cached(key, lambda: _template_2d(b, vmin, vmax, cm, field_label, length_unit, dpi))
    panel = template.panels[0]
    r_px = 0.5 * DISC * h * panel.px_per_unit
    rgba = _colours(v, vmin, vmax, cm)
    order = np.argsort(np.isfinite(v), kind="stable")  # non-finite first so real values cover them
    layers = []
    if bp is not None and len(bp):
        layers.append((bp[:, 0], bp[:, 1], r_px, (*_BOUNDARY_GREY, 1.0)))
    if sp is not None:
        layers.append((sp[:, 0], sp[:, 1], r_px, (*_SOLID_COLOUR, 1.0)))
    layers.append((p[order, 0], p[order, 1], r_px, rgba[order]))
    if panel.under_colour is not None:
        image = _panel_pixels(panel, layers)
    else:
        image = _splat_premultiplied(panel.width, panel.height, panel.extent, layers)
    return _compose(template, [image], title)


# ----------------------------------------------------------------------------------------------- frames

def render_frame(path, points, values, dim: int, field_name: str, bounds, boundary_points=None,
                 title: str = "", cmap="viridis", vmin: float | None = None, vmax: float | None = None, *,
                 solid_points=None, time: float | None = None, time_unit: str = "s",
                 field_unit: str | None = None, length_unit: str | None = None,
                 spacing: float | None = None, dpi: int = 100,
                 view: str = "side", azimuth: float = -60.0, elevation: float = 25.0) -> Path:
    """Write a PNG of particles coloured by a field (1D: the field against x); returns the path.

    Parameters
    ----------
    points: (N, 3) (or (N, dim)) positions (``length_unit``); values: (N,) field values (``field_unit``).
    dim: 1, 2 or 3. field_name: the field's name, labelled with ``field_unit`` on the colour bar (1D: the y axis).
    bounds: ``((xmin, xmax)[, (ymin, ymax)[, (zmin, zmax)]])`` of the scene (the container), the extent of the plot
        (one pair per dimension).
    boundary_points: optional (M, 3) wall particles, grey (2D) or faint behind the fluid (3D).
    solid_points: optional (K, 3) particles of obstacles, opaque in their own colour; in 3D depth-sorted with the fluid,
        and drawn again over it, translucent with their outline, so that an obstacle under water stays visible.
    title: text of the title; ``time`` (in ``time_unit``), if given, is appended as ``t = ... <time_unit>``.
    vmin, vmax: the colour range (1D: the y range); either missing: :func:`colour_range` of ``values``. Values beyond
        it take the colour map's end colours (the colour bar's extensions).
    field_unit, length_unit: the units of the values and the positions (None: labels without a unit).
    spacing: particle spacing (``length_unit``) for the marker size; default the median nearest-neighbour distance.
    view: 3D only, the second panel: ``"side"`` (x–z, looking along +y) or ``"top"`` (x–y, looking down).
    azimuth, elevation: 3D only, the oblique camera direction in degrees (z up).
    """
    if dim not in (1, 2, 3):
        raise ParameterError("dim", f"must be 1, 2 or 3, got {dim!r}")
    b = _check_bounds(bounds, dim)
    p = _check_points("points", points, dim)
    v = np.asarray(values, dtype=np.float64).reshape(-1)
    if v.shape[0] != p.shape[0]:
        raise ParameterError("values", f"must have one value per point ({p.shape[0]}), got {v.shape[0]}")
    bp = None if boundary_points is None else _check_points("boundary_points", boundary_points, dim)
    sp = None if solid_points is None or not len(solid_points) else _check_points("solid_points", solid_points, dim)
    if view not in ("side", "top"):
        raise ParameterError("view", f"must be 'side' or 'top', got {view!r}")
    vmin, vmax = _check_range(vmin, vmax, v)
    label = quantity_label(field_name, field_unit)
    text = _title(title, time, time_unit)
    if dim == 1:
        pixels = _frame_1d(p, v, b, label, text, dpi, vmin, vmax, length_unit)
    else:
        h = _spacing(p, spacing, b[:, 1] - b[:, 0])
        cm = _colormap(cmap)
        if dim == 2:
            pixels = _frame_2d(p, v, b, bp, sp, h, vmin, vmax, cm, label, text, dpi, length_unit)
        else:
            pixels = _frame_3d(p, v, b, bp, sp, h, vmin, vmax, cm, label, text, dpi, view, float(azimuth),
                               float(elevation), length_unit)
    return write_png(path, pixels, dpi)


# ----------------------------------------------------------------------------------------------- 1D

@dataclass
class _LineFigure:
    """A 1D frame series' figure: its background saved once (blitting), the curve redrawn per frame."""

    fig: object
    ax: object
    line: object
    background: object
    template: _Template


def _line_figure(b, label, dpi, vmin, vmax, length_unit) -> _LineFigure:
    from matplotlib import rcParams

    fig = new_figure(7.0, 3.6, dpi)
    ax = fig.add_axes([0.12, 0.15, 0.84, 0.74])
    factor, unit = length_scale(float(b[0, 1] - b[0, 0]), length_unit)
    ax.set_xlim(b[0, 0] / factor, b[0, 1] / factor)
    margin = 0.05 * (vmax - vmin)
    ax.set_ylim(vmin - margin, vmax + margin)
    ax.set_xlabel(quantity_label("x", unit))
    ax.set_ylabel(label)
    ax.grid(alpha=0.3)
    (line,) = ax.plot([], [], "-", color="C0", lw=1.0, marker=".", ms=3)
    line.set_visible(False)
    fig.canvas.draw()
    background = fig.canvas.copy_from_bbox(fig.bbox)
    line.set_visible(True)
    x0, y0, w, _ = _pixel_box(ax, int(round(fig.bbox.height)))
    pad_px = rcParams["axes.titlepad"] * dpi / 72.0
    template = _Template(None, [], x0 + 0.5 * w, y0 - pad_px, "ms", _font_px("large", dpi), dpi)
    return _LineFigure(fig, ax, line, background, template)


def _frame_1d(p, v, b, label, title, dpi, vmin, vmax, length_unit) -> np.ndarray:
    """A 1D set: the field against x, one marker per particle joined in x order."""
    key = ("1d", tuple(b.ravel()), vmin, vmax, label, length_unit, dpi)
    figure = _cached(key, lambda: _line_figure(b, label, dpi, vmin, vmax, length_unit))
    factor = length_scale(float(b[0, 1] - b[0, 0]), length_unit)[0]
    order = np.argsort(p[:, 0], kind="stable")
    canvas, ax = figure.fig.canvas, figure.ax
    canvas.restore_region(figure.background)
    figure.line.set_data(p[order, 0] / factor, v[order])
    ax.draw_artist(figure.line)
    for spine in ax.spines.values():  # drawn over the curve, as a full draw does
        ax.draw_artist(spine)
    pixels = np.array(canvas.buffer_rgba(), dtype=np.uint8)[..., :3].copy()
    _draw_title(pixels, figure.template, title)
    return pixels


# ----------------------------------------------------------------------------------------------- 3D

def _camera(b, azimuth, elevation):
    """Camera frame (u right, v up, w towards the camera), eye position and distance."""
    az, el = math.radians(azimuth), math.radians(elevation)
    w = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    up = np.array([0.0, 0.0, 1.0]) if abs(w[2]) < 0.999 else np.array([0.0, 1.0, 0.0])
    u = np.cross(up, w)
    u /= np.linalg.norm(u)
    vv = np.cross(w, u)
    centre = b.mean(axis=1)
    dist = 2.5 * float(np.linalg.norm(b[:, 1] - b[:, 0]))
    return u, vv, w, centre + dist * w, dist


def _project(x, cam):
    """Perspective projection: screen (X, Y) in metres at the centre plane, depth (m), size factor."""
    u, vv, w, eye, dist = cam
    q = x - eye
    depth = -(q @ w)
    f = dist / np.maximum(depth, 1e-9 * dist)
    return (q @ u) * f, (q @ vv) * f, depth, f


def _box_edges(b, eye):
    """The 12 edges of the bounds box as (corner_a, corner_b, front): front edges touch a visible face."""
    corners = np.array([[b[0, i], b[1, j], b[2, k]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    centre = b.mean(axis=1)
    visible = {}
    for axis in range(3):
        for side in (0, 1):
            n = np.zeros(3)
            n[axis] = 1.0 if side else -1.0
            fc = centre.copy()
            fc[axis] = b[axis, side]
            visible[(axis, side)] = float(n @ (eye - fc)) > 0.0
    edges = []
    for a in range(8):
        for c in range(a + 1, 8):
            diff = [((a >> (2 - k)) & 1) != ((c >> (2 - k)) & 1) for k in range(3)]
            if sum(diff) != 1:
                continue
            # the two faces meeting at this edge: the fixed coordinates' sides
            faces = [(k, (a >> (2 - k)) & 1) for k in range(3) if not diff[k]]
            edges.append((corners[a], corners[c], any(visible[f] for f in faces)))
    return edges


def _panels_3d(b, cam, view):
    """The perspective panel's extent (projected bounds box, 3 % margin) and the orthographic panel's axes."""
    corners = np.array([[b[0, i], b[1, j], b[2, k]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    cx, cy, _, _ = _project(corners, cam)
    px0, px1, py0, py1 = cx.min(), cx.max(), cy.min(), cy.max()
    padx, pady = 0.03 * (px1 - px0), 0.03 * (py1 - py0)
    a2, b2 = (0, 2) if view == "side" else (0, 1)
    return (px0 - padx, px1 + padx, py0 - pady, py1 + pady), (a2, b2)


def _template_3d(b, vmin, vmax, cm, field_label, dpi, view, azimuth, elevation, length_unit) -> _Template:
    cam = _camera(b, azimuth, elevation)
    extent1, (a2, b2) = _panels_3d(b, cam, view)
    panel_w, panel_h = 5.6, 4.6
    w1, h1 = _fit_box(extent1[1] - extent1[0], extent1[3] - extent1[2], panel_w, panel_h)
    w2, h2 = _fit_box(b[a2, 1] - b[a2, 0], b[b2, 1] - b[b2, 0], panel_w, panel_h)
    left, gap, right, bottom, top = 0.3, 0.9, 1.4, 0.6, 0.6
    W = left + panel_w + gap + panel_w + right
    H = bottom + panel_h + top
    fig = new_figure(W, H, dpi)
    ax1 = fig.add_axes([(left + 0.5 * (panel_w - w1)) / W, (bottom + 0.5 * (panel_h - h1)) / H, w1 / W, h1 / H])
    x2 = left + panel_w + gap
    ax2 = fig.add_axes([(x2 + 0.5 * (panel_w - w2)) / W, (bottom + 0.5 * (panel_h - h2)) / H, w2 / W, h2 / H])
    ax1.set_xlim(extent1[0], extent1[1])
    ax1.set_ylim(extent1[2], extent1[3])
    for e0, e1, front in _box_edges(b, cam[3]):
        ex, ey, _, _ = _project(np.stack([e0, e1]), cam)
        if front:
            ax1.plot(ex, ey, color="0.25", lw=0.9, alpha=0.7, zorder=3)
        else:
            ax1.plot(ex, ey, color="0.6", lw=0.8, ls=(0, (3, 3)), zorder=0.5)
    # axis triad at the lower corner, so the orientation is readable
    o = b[:, 0]
    L = 0.15 * float(np.min(b[:, 1] - b[:, 0]))
    for k, name in enumerate("xyz"):
        tip = o.copy()
        tip[k] += L
        tx, ty, _, _ = _project(np.stack([o, tip]), cam)
        ax1.plot(tx, ty, color="k", lw=1.2, zorder=4)
        ax1.text(tx[1], ty[1], name, fontsize=8, zorder=4)
    ax1.set_axis_off()
    ax1.set_title(f"perspective (az {azimuth:g}°, el {elevation:g}°)", fontsize=9)
    extent2 = (b[a2, 0], b[a2, 1], b[b2, 0], b[b2, 1])
    factor, xlabel, ylabel = _axis_labels(b, (a2, b2), length_unit)
    ax2.set_xlim(extent2[0] / factor, extent2[1] / factor)
    ax2.set_ylim(extent2[2] / factor, extent2[3] / factor)
    ax2.set_xlabel(xlabel)
    ax2.set_ylabel(ylabel)
    ax2.set_title("side view (x–z)" if view == "side" else "top view (x–y)", fontsize=9)
    _add_colorbar(fig, vmin, vmax, cm, [(W - right + 0.25) / W, bottom / H, 0.2 / W, panel_h / H], field_label)
    pixels, panels = _capture(fig, [(ax1, extent1), (ax2, extent2)])
    # the title (suptitle's place: centred, its top 2 % of the height below the figure's top)
    return _Template(pixels, panels, 0.5 * W * dpi, 0.02 * H * dpi, "mt", _font_px("large", dpi), dpi)


def _shade(depth, near: float, far: float) -> np.ndarray:
    """Brightness by depth: nearest 1, farthest 0.55."""
    return 1.0 - 0.45 * (depth - near) / max(far - near, 1e-12)


def _with_solid_over(pm: np.ndarray, solid_pm: np.ndarray | None) -> np.ndarray:
    """A panel's image with the obstacles' own image drawn again over it, translucent, and their outline: an obstacle
    the fluid covers stays visible through it (the fluid in front of it still tinted by it)."""
    if solid_pm is None:
        return pm
    ghost = solid_pm * _SOLID_GHOST_ALPHA
    out = ghost + pm * (1.0 - ghost[..., 3:4])
    edge = _outline(solid_pm)
    line = np.array([*(c * 0.55 for c in _SOLID_COLOUR), 1.0], dtype=np.float32) * _SOLID_OUTLINE_ALPHA
    out[edge] = line + out[edge] * (1.0 - _SOLID_OUTLINE_ALPHA)
    return out


def _frame_3d(p, v, b, bp, sp, h, vmin, vmax, cm, field_label, title, dpi, view, azimuth, elevation, length_unit):
    key = ("3d", tuple(b.ravel()), vmin, vmax, cm.name, field_label, dpi, view, azimuth, elevation, length_unit)
    template = _cached(key, lambda: _template_3d(b, vmin, vmax, cm, field_label, dpi, view, azimuth, elevation,
                                                 length_unit))
    cam = _camera(b, azimuth, elevation)
    panel1, panel2 = template.panels
    finite = np.all(np.isfinite(p), axis=1)
    rgba = _colours(v, vmin, vmax, cm)
    faint = (*_BOUNDARY_GREY, 0.18)
    solid = np.tile((*_SOLID_COLOUR, 1.0), (len(sp), 1)) if sp is not None else None

    # --- oblique perspective view: far to near, darker with depth, discs shrink with distance
    r1 = 0.5 * DISC * h * panel1.px_per_unit
    X, Y, depth, f = _project(p, cam)
    order = np.argsort(-depth, kind="stable")
    order = order[finite[order]]
    depths = [depth[order]]
    if sp is not None:
        sX, sY, sdepth, sf = _project(sp, cam)
        depths.append(sdepth)
    every = np.concatenate(depths)
    near, far = (every.min(), every.max()) if every.size else (0.0, 1.0)
    c1 = rgba.copy()
    c1[:, :3] *= _shade(depth, near, far)[:, None]
    layers = []
    if bp is not None and len(bp):
        bX, bY, _, bf = _project(bp, cam)
        layers.append((bX, bY, r1 * bf, faint))  # walls: faint, always behind the fluid
    solid_image = None
    if sp is not None:  # obstacles: opaque, sorted far to near together with the fluid
        scol = solid.copy()
        scol[:, :3] *= _shade(sdepth, near, far)[:, None]
        allX, allY = np.concatenate([X[order], sX]), np.concatenate([Y[order], sY])
        allf, alld = np.concatenate([f[order], sf]), np.concatenate([depth[order], sdepth])
        allc = np.vstack([c1[order], scol])
        back_to_front = np.argsort(-alld, kind="stable")
        layers.append((allX[back_to_front], allY[back_to_front], r1 * allf[back_to_front], allc[back_to_front]))
        behind = np.argsort(-sdepth, kind="stable")
        solid_image = _splat_premultiplied(panel1.width, panel1.height, panel1.extent,
                                           [(sX[behind], sY[behind], r1 * sf[behind], scol[behind])])
    else:
        layers.append((X[order], Y[order], r1 * f[order], c1[order]))
    image1 = _with_solid_over(_splat_premultiplied(panel1.width, panel1.height, panel1.extent, layers), solid_image)

    # --- orthographic side (x–z, looking along +y) or top (x–y, looking down -z) view
    a2, b2 = (0, 2) if view == "side" else (0, 1)
    r2 = 0.5 * DISC * h * panel2.px_per_unit
    key2 = -p[:, 1] if view == "side" else p[:, 2]  # far first: large y (side) / low z (top)
    order2 = np.argsort(key2, kind="stable")
    order2 = order2[finite[order2]]
    layers = []
    if bp is not None and len(bp):
        layers.append((bp[:, a2], bp[:, b2], r2, faint))
    solid_image = None
    if sp is not None:  # obstacles with the fluid, far to near
        skey = -sp[:, 1] if view == "side" else sp[:, 2]
        allp = np.vstack([p[order2], sp])
        allc = np.vstack([rgba[order2], solid])
        back_to_front = np.argsort(np.concatenate([key2[order2], skey]), kind="stable")
        layers.append((allp[back_to_front, a2], allp[back_to_front, b2], r2, allc[back_to_front]))
        solid_image = _splat_premultiplied(panel2.width, panel2.height, panel2.extent,
                                           [(sp[:, a2], sp[:, b2], r2, solid)])
    else:
        layers.append((p[order2, a2], p[order2, b2], r2, rgba[order2]))
    image2 = _with_solid_over(_splat_premultiplied(panel2.width, panel2.height, panel2.extent, layers), solid_image)
    return _compose(template, [image1, image2], title)
