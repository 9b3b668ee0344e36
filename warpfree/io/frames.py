"""Headless PNG frames of particle fields and line plots for validation.

Matplotlib is used through ``matplotlib.figure.Figure`` and the Agg canvas directly (no pyplot, no global
backend switch, safe from worker threads).

- :func:`render_frame` draws one frame. 1D: the field against x. 2D: the particles as discs coloured by a field, sized so that
  particles at the mean spacing touch, boundary particles grey. 3D: two views side by side, an oblique
  perspective view (painter's algorithm: particles drawn far to near so near ones cover far ones, darker
  with depth) and an orthographic side (x–z) or top (x–y) view, also depth sorted; the container bounds
  drawn as a box outline and boundary particles faint behind the fluid.
- :func:`plot_series` draws curves (lines) against reference data (markers), e.g. a surge front against
  an experiment.

Lengths are in the scene's unit (m); ``time`` in s.
"""

from __future__ import annotations

import math
import os
import threading
from pathlib import Path

import numpy as np

from ..errors import ParameterError

__all__ = ["render_frame", "plot_series", "estimate_spacing"]

_BOUNDARY_GREY = (0.55, 0.55, 0.55)
_SOLID_COLOUR = (0.62, 0.45, 0.28)  # obstacles: opaque, a colour no colormap of the fields uses


# ----------------------------------------------------------------------------------------------- helpers

def _figure(width_in: float, height_in: float, dpi: float):
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width_in, height_in), dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def _save(fig, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp{os.getpid()}.png")
    # zlib level 3: ~3x faster to encode than matplotlib's default (6) for a few % larger files.
    fig.savefig(str(tmp), format="png", dpi=fig.dpi, pil_kwargs={"compress_level": 3})
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


def estimate_spacing(points: np.ndarray, sample: int = 2000) -> float:
    """Median nearest-neighbour distance of ``points`` (N, d), from a fixed subsample of query points."""
    from scipy.spatial import cKDTree

    p = np.asarray(points, dtype=np.float64)
    p = p[np.all(np.isfinite(p), axis=1)]
    if len(p) < 2:
        return float("nan")
    tree = cKDTree(p)
    q = p if len(p) <= sample else p[np.linspace(0, len(p) - 1, sample).astype(np.int64)]
    d, _ = tree.query(q, k=2)
    d = d[:, 1]
    d = d[d > 0]
    return float(np.median(d)) if len(d) else float("nan")


def _spacing(points: np.ndarray, spacing, extent: np.ndarray) -> float:
    if spacing is not None:
        from ..errors import require_positive

        return require_positive("spacing", spacing)
    s = estimate_spacing(points) if len(points) >= 2 else float("nan")
    if not (math.isfinite(s) and s > 0):
        # One particle (or all coincident): share the box evenly.
        s = float(np.prod(extent)) ** (1.0 / len(extent)) / max(len(points), 1) ** (1.0 / len(extent))
    return s


def _title(title: str, time) -> str:
    if time is None:
        return title
    t = f"t = {float(time):.4g} s"
    return f"{title}   {t}" if title else t


def _norm_cmap(values: np.ndarray, cmap, vmin, vmax):
    import matplotlib
    from matplotlib.colors import Normalize

    finite = values[np.isfinite(values)]
    lo = float(np.min(finite)) if vmin is None and len(finite) else vmin
    hi = float(np.max(finite)) if vmax is None and len(finite) else vmax
    lo = 0.0 if lo is None else float(lo)
    hi = 1.0 if hi is None else float(hi)
    if hi <= lo:
        lo, hi = lo - 0.5 * max(abs(lo), 1e-12), hi + 0.5 * max(abs(hi), 1e-12)
    cm = matplotlib.colormaps[cmap] if isinstance(cmap, str) else cmap
    return Normalize(lo, hi), cm


def _add_colorbar(fig, norm, cm, rect, label: str, orientation: str = "vertical"):
    from matplotlib.cm import ScalarMappable

    cax = fig.add_axes(rect)
    sm = ScalarMappable(norm=norm, cmap=cm)
    cb = fig.colorbar(sm, cax=cax, orientation=orientation)
    cb.set_label(label)
    return cb


#: Disc diameter in units of the particle spacing. 1 just touches along the lattice axes but leaves a
#: white dot in every lattice hole (distance √2/2 spacing to the nearest centres); 1.45 closes them, so a
#: filled region reads as filled, at the cost of drawing the free surface ~0.2 spacing too far out.
DISC = 1.45


def _splat(width_px: int, height_px: int, extent, layers, supersample: int | None = None) -> np.ndarray:
    """Rasterise discs into an RGBA image (height_px, width_px, 4), painter's order.

    ``layers``: a list of ``(X, Y, radius_px, rgba)``, world coordinates (extent ``(x0, x1, y0, y1)``),
    disc radius in output pixels (scalar or per disc) and colours (N, 4); discs are drawn in list order
    and, within a layer, in array order, each covering the ones before it. Every pixel holds the colour
    of the last disc covering its centre. The image is rendered ``supersample`` times finer and averaged
    down (premultiplied alpha), which anti-aliases the disc edges; by default 2 when that costs under
    ~2.5 M pixel writes, else 1. Pure NumPy, O(N + covered pixels).
    """
    layers = [(X, Y, r, c) for X, Y, r, c in layers if len(X)]
    if supersample is None:
        work = 0.0  # pixel writes at 2x: a (2 ceil(2r) + 1)^2 stamp per disc
        for X, _, r, _ in layers:
            r2x = np.ceil(2.0 * np.broadcast_to(np.asarray(r, dtype=np.float64), (len(X),)))
            work += float(np.sum((2.0 * r2x + 1.0) ** 2))
        supersample = 2 if work <= 2.5e6 else 1
    ss = max(1, int(supersample))
    Ws, Hs = max(1, int(width_px)) * ss, max(1, int(height_px)) * ss
    x0, x1, y0, y1 = (float(e) for e in extent)
    sx, sy = Ws / (x1 - x0), Hs / (y1 - y0)
    xs, ys, rs, cols = [], [], [], []
    for X, Y, r, c in layers:
        n = len(X)
        xs.append((np.asarray(X, dtype=np.float64) - x0) * sx)
        ys.append((y1 - np.asarray(Y, dtype=np.float64)) * sy)
        rs.append(np.broadcast_to(np.asarray(r, dtype=np.float64) * ss, (n,)))
        cols.append(np.broadcast_to(np.asarray(c, dtype=np.float64), (n, 4)))
    # colours premultiplied by alpha, float32, row 0 transparent: a pixel's colour is table[top + 1]
    table = np.zeros((1, 4), dtype=np.float32)
    top = np.full((Hs, Ws), -1, dtype=np.int32)
    if xs:
        cx, cy, r = np.concatenate(xs), np.concatenate(ys), np.concatenate(rs)
        rgba = np.concatenate(cols)
        table = np.zeros((len(rgba) + 1, 4), dtype=np.float32)
        table[1:, :3] = rgba[:, :3] * rgba[:, 3:4]
        table[1:, 3] = rgba[:, 3]
        r = np.clip(r, 0.0, float(max(Ws, Hs)))
        keep = np.isfinite(cx) & np.isfinite(cy) & (cx > -r - 1) & (cx < Ws + r + 1) & (cy > -r - 1) & \
            (cy < Hs + r + 1)
        rank = np.nonzero(keep)[0].astype(np.int32)
        cx, cy, r = cx[keep], cy[keep], r[keep]
        rint = np.ceil(r).astype(np.int64)
        # Draw into a buffer padded by the largest radius, so no disc needs a bounds test; crop after.
        pad = 2 * int(rint.max(initial=0)) + 3  # discs centred up to r + 1 outside the canvas still fit
        Wp, Hp = Ws + 2 * pad, Hs + 2 * pad
        ix = np.floor(cx).astype(np.int64)
        iy = np.floor(cy).astype(np.int64)
        base = (iy + pad) * Wp + (ix + pad)
        ox = (ix + 0.5 - cx).astype(np.float32)  # pixel-centre offset from the disc centre, in [-0.5, 0.5]
        oy = (iy + 0.5 - cy).astype(np.float32)
        r2 = (r * r).astype(np.float32)
        # every (pixel, disc) pair whose pixel centre the disc covers, gathered per stamp offset; then one
        # max per pixel: the disc drawn last wins (the centre pixel is always drawn, however small the disc)
        pixels, ranks = [base], [rank]
        for R in np.nonzero(np.bincount(rint))[0]:
            if R == 0:
                continue
            sel = np.nonzero(rint == R)[0]
            sb, sox, soy, sr2, srank = base[sel], ox[sel], oy[sel], r2[sel], rank[sel]
            for dy in range(-int(R), int(R) + 1):
                ddy = (soy + dy) ** 2
                for dx in range(-int(R), int(R) + 1):
                    if dx == 0 and dy == 0:
                        continue
                    m = (sox + dx) ** 2 + ddy <= sr2
                    pixels.append(sb[m] + (dy * Wp + dx))
                    ranks.append(srank[m])
        padded = np.full(Hp * Wp, -1, dtype=np.int32)
        np.maximum.at(padded, np.concatenate(pixels), np.concatenate(ranks))
        top = padded.reshape(Hp, Wp)[pad:pad + Hs, pad:pad + Ws]
    # average each ss x ss block of premultiplied colours, then divide by the mean alpha
    pm = np.zeros((Hs // ss, Ws // ss, 4), dtype=np.float32)
    for sy in range(ss):
        for sx in range(ss):
            pm += table[top[sy::ss, sx::ss] + 1]
    pm /= ss * ss
    alpha = pm[..., 3:4]
    img = np.zeros_like(pm)
    np.divide(pm[..., :3], alpha, out=img[..., :3], where=alpha > 0)
    img[..., 3:] = alpha
    return np.clip(img, 0.0, 1.0)


def _draw_discs(ax, fig, extent, layers) -> None:
    """Draw ``layers`` (see :func:`_splat`) as one image filling ``ax``, whose limits become ``extent``."""
    bbox = ax.get_position()
    wpx = max(1, int(round(bbox.width * fig.get_figwidth() * fig.dpi)))
    hpx = max(1, int(round(bbox.height * fig.get_figheight() * fig.dpi)))
    img = _splat(wpx, hpx, extent, layers)
    ax.imshow(img, extent=tuple(extent), origin="upper", interpolation="nearest", zorder=1,
              aspect="auto")
    ax.set_xlim(extent[0], extent[1])
    ax.set_ylim(extent[2], extent[3])


def _px_per_m(ax, fig, extent) -> float:
    return ax.get_position().width * fig.get_figwidth() * fig.dpi / (extent[1] - extent[0])


# ----------------------------------------------------------------------------------------------- frames

def render_frame(path, points, values, dim: int, field_name: str, bounds, boundary_points=None,
                 title: str = "", cmap="viridis", vmin: float | None = None, vmax: float | None = None, *,
                 solid_points=None,
                 time: float | None = None, spacing: float | None = None, dpi: int = 100,
                 view: str = "side", azimuth: float = -60.0, elevation: float = 25.0) -> Path:
    """Write a PNG of particles coloured by a field (1D: the field against x); returns the path.

    Parameters
    ----------
    points: (N, 3) (or (N, dim)) positions (m); values: (N,) field values.
    dim: 1, 2 or 3. field_name: colour-bar (1D: axis) label. bounds: ``((xmin, xmax)[, (ymin, ymax)[, (zmin,
        zmax)]])`` of the scene (the container), the extent of the plot (one pair per dimension).
    boundary_points: optional (M, 3) wall particles, grey (2D) or faint behind the fluid (3D).
    solid_points: optional (K, 3) particles of obstacles, opaque in their own colour, depth-sorted with the
        fluid in 3D so that an obstacle hides the fluid behind it and the fluid in front of it hides it.
    title: text of the title; ``time`` (s), if given, is appended as ``t = ... s``.
    vmin, vmax: colour range (default: the finite range of ``values``).
    spacing: particle spacing (m) for the marker size; default the median nearest-neighbour distance.
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
    h = _spacing(p, spacing, b[:, 1] - b[:, 0])
    if dim == 1:
        return _save(_frame_1d(p, v, b, field_name, _title(title, time), dpi, vmin, vmax), path)
    norm, cm = _norm_cmap(v, cmap, vmin, vmax)
    if dim == 2:
        fig = _frame_2d(p, v, b, bp, sp, h, norm, cm, field_name, _title(title, time), dpi)
    else:
        fig = _frame_3d(p, v, b, bp, sp, h, norm, cm, field_name, _title(title, time), dpi, view,
                        float(azimuth), float(elevation))
    return _save(fig, path)


def _fit_box(extent_x: float, extent_y: float, max_w: float, max_h: float) -> tuple[float, float]:
    """Axes size (in) of a box with the data aspect ratio that fits max_w x max_h."""
    scale = min(max_w / extent_x, max_h / extent_y)
    return extent_x * scale, extent_y * scale


#: the 2D frame's figure per layout, kept between frames of a run (per thread): building the axes, their ticks
#: and the colour bar cost as much as drawing them; a new frame only swaps the image, title and colour range
_layouts = threading.local()


def _frame_2d(p, v, b, bp, sp, h, norm, cm, field_name, title, dpi):
    lx, ly = b[0, 1] - b[0, 0], b[1, 1] - b[1, 0]
    wa, ha = _fit_box(lx, ly, 8.0, 6.0)
    horizontal = ha < 2.5  # a long flat tank: colour bar below
    left, right, bottom, top = 0.8, (0.3 if horizontal else 1.4), (1.3 if horizontal else 0.6), 0.5
    W, H = wa + left + right, ha + bottom + top
    extent = (b[0, 0], b[0, 1], b[1, 0], b[1, 1])
    key = (W, H, dpi, extent, field_name, cm.name)
    cache = _layouts.__dict__.setdefault("figures", {})
    if key not in cache:
        fig = _figure(W, H, dpi)
        ax = fig.add_axes([left / W, bottom / H, wa / W, ha / H])
        image = ax.imshow(np.zeros((1, 1, 4)), extent=extent, origin="upper", interpolation="nearest", zorder=1,
                          aspect="auto")
        ax.set_xlim(extent[0], extent[1])
        ax.set_ylim(extent[2], extent[3])
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel("x")
        ax.set_ylabel("y")
        rect = ([left / W, 0.35 / H, wa / W, 0.18 / H] if horizontal
                else [(left + wa + 0.2) / W, bottom / H, 0.2 / W, ha / H])
        bar = _add_colorbar(fig, norm, cm, rect, field_name, "horizontal" if horizontal else "vertical")
        if len(cache) >= 4:  # a run has one layout; keep a few for callers that draw several
            cache.pop(next(iter(cache)))
        cache[key] = (fig, ax, image, bar.mappable)
    fig, ax, image, bar_mappable = cache[key]
    r_px = 0.5 * DISC * h * _px_per_m(ax, fig, extent)
    rgba = _colours(v, norm, cm)
    order = np.argsort(np.isfinite(v), kind="stable")  # non-finite first so real values cover them
    layers = []
    if bp is not None and len(bp):
        layers.append((bp[:, 0], bp[:, 1], r_px, (*_BOUNDARY_GREY, 1.0)))
    if sp is not None:
        layers.append((sp[:, 0], sp[:, 1], r_px, (*_SOLID_COLOUR, 1.0)))
    layers.append((p[order, 0], p[order, 1], r_px, rgba[order]))
    bbox = ax.get_position()
    image.set_data(_splat(max(1, int(round(bbox.width * W * dpi))), max(1, int(round(bbox.height * H * dpi))),
                          extent, layers))
    bar_mappable.set_clim(norm.vmin, norm.vmax)
    ax.set_title(title)
    return fig


def _frame_1d(p, v, b, field_name, title, dpi, vmin, vmax):
    """A 1D set: the field against x, one marker per particle joined in x order."""
    fig = _figure(7.0, 3.6, dpi)
    ax = fig.add_axes([0.11, 0.15, 0.85, 0.74])
    order = np.argsort(p[:, 0], kind="stable")
    ax.plot(p[order, 0], v[order], "-", color="C0", lw=1.0)
    ax.plot(p[order, 0], v[order], ".", color="C0", ms=3)
    ax.set_xlim(b[0, 0], b[0, 1])
    if vmin is not None or vmax is not None:
        ax.set_ylim(vmin, vmax)
    ax.set_xlabel("x")
    ax.set_ylabel(field_name)
    ax.set_title(title)
    ax.grid(alpha=0.3)
    return fig


def _colours(v, norm, cm) -> np.ndarray:
    rgba = np.asarray(cm(norm(v)), dtype=np.float64).reshape(-1, 4)
    rgba[~np.isfinite(v)] = (1.0, 0.0, 1.0, 1.0)  # magenta: non-finite field value
    return rgba


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


def _frame_3d(p, v, b, bp, sp, h, norm, cm, field_name, title, dpi, view, azimuth, elevation):
    cam = _camera(b, azimuth, elevation)
    eye = cam[3]

    # Panel extents: projected bounds box (perspective) and the chosen orthographic plane.
    corners = np.array([[b[0, i], b[1, j], b[2, k]] for i in (0, 1) for j in (0, 1) for k in (0, 1)])
    cx, cy, _, _ = _project(corners, cam)
    px0, px1, py0, py1 = cx.min(), cx.max(), cy.min(), cy.max()
    padx, pady = 0.03 * (px1 - px0), 0.03 * (py1 - py0)
    px0, px1, py0, py1 = px0 - padx, px1 + padx, py0 - pady, py1 + pady
    a2, b2 = (0, 2) if view == "side" else (0, 1)

    panel_w, panel_h = 5.6, 4.6
    w1, h1 = _fit_box(px1 - px0, py1 - py0, panel_w, panel_h)
    w2, h2 = _fit_box(b[a2, 1] - b[a2, 0], b[b2, 1] - b[b2, 0], panel_w, panel_h)
    left, gap, right, bottom, top = 0.3, 0.9, 1.3, 0.6, 0.6
    W = left + panel_w + gap + panel_w + right
    H = bottom + panel_h + top
    fig = _figure(W, H, dpi)
    ax1 = fig.add_axes([(left + 0.5 * (panel_w - w1)) / W, (bottom + 0.5 * (panel_h - h1)) / H,
                        w1 / W, h1 / H])
    x2 = left + panel_w + gap
    ax2 = fig.add_axes([(x2 + 0.5 * (panel_w - w2)) / W, (bottom + 0.5 * (panel_h - h2)) / H, w2 / W, h2 / H])

    finite = np.all(np.isfinite(p), axis=1)
    rgba = _colours(v, norm, cm)
    faint = (*_BOUNDARY_GREY, 0.18)

    # --- oblique perspective view: far to near, darker with depth, discs shrink with distance
    extent1 = (px0, px1, py0, py1)
    r1 = 0.5 * DISC * h * _px_per_m(ax1, fig, extent1)
    X, Y, depth, f = _project(p, cam)
    order = np.argsort(-depth, kind="stable")
    order = order[finite[order]]
    if len(order):
        dn, dfar = depth[order[-1]], depth[order[0]]
        shade = 1.0 - 0.45 * (depth - dn) / max(dfar - dn, 1e-12)  # nearest 1, farthest 0.55
    else:
        shade = np.ones(len(p))
    c1 = rgba.copy()
    c1[:, :3] *= shade[:, None]
    layers = []
    if bp is not None and len(bp):
        bX, bY, _, bf = _project(bp, cam)
        layers.append((bX, bY, r1 * bf, faint))  # walls: faint, always behind the fluid
    if sp is not None:  # obstacles: opaque, sorted far to near together with the fluid
        sX, sY, sdepth, sf = _project(sp, cam)
        dn, dfar = min(depth[order].min(initial=np.inf), sdepth.min()), max(depth[order].max(initial=-np.inf),
                                                                            sdepth.max())
        scol = np.tile((*_SOLID_COLOUR, 1.0), (len(sp), 1))
        scol[:, :3] *= (1.0 - 0.45 * (sdepth - dn) / max(dfar - dn, 1e-12))[:, None]
        allX, allY = np.concatenate([X[order], sX]), np.concatenate([Y[order], sY])
        allf, alld = np.concatenate([f[order], sf]), np.concatenate([depth[order], sdepth])
        allc = np.vstack([c1[order], scol])
        back_to_front = np.argsort(-alld, kind="stable")
        layers.append((allX[back_to_front], allY[back_to_front], r1 * allf[back_to_front], allc[back_to_front]))
    else:
        layers.append((X[order], Y[order], r1 * f[order], c1[order]))
    _draw_discs(ax1, fig, extent1, layers)
    edges = _box_edges(b, eye)
    for e0, e1, front in edges:
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
    ax1.set_aspect("equal", adjustable="box")
    ax1.set_axis_off()
    ax1.set_title(f"perspective (az {azimuth:g}°, el {elevation:g}°)", fontsize=9)

    # --- orthographic side (x–z, looking along +y) or top (x–y, looking down -z) view
    extent2 = (b[a2, 0], b[a2, 1], b[b2, 0], b[b2, 1])
    r2 = 0.5 * DISC * h * _px_per_m(ax2, fig, extent2)
    key = -p[:, 1] if view == "side" else p[:, 2]  # far first: large y (side) / low z (top)
    order2 = np.argsort(key, kind="stable")
    order2 = order2[finite[order2]]
    layers = []
    if bp is not None and len(bp):
        layers.append((bp[:, a2], bp[:, b2], r2, faint))
    if sp is not None:  # obstacles with the fluid, far to near
        skey = -sp[:, 1] if view == "side" else sp[:, 2]
        allp = np.vstack([p[order2], sp])
        allc = np.vstack([rgba[order2], np.tile((*_SOLID_COLOUR, 1.0), (len(sp), 1))])
        back_to_front = np.argsort(np.concatenate([key[order2], skey]), kind="stable")
        layers.append((allp[back_to_front, a2], allp[back_to_front, b2], r2, allc[back_to_front]))
    else:
        layers.append((p[order2, a2], p[order2, b2], r2, rgba[order2]))
    _draw_discs(ax2, fig, extent2, layers)
    ax2.set_aspect("equal", adjustable="box")
    ax2.set_xlabel("xyz"[a2])
    ax2.set_ylabel("xyz"[b2])
    ax2.set_title("side view (x–z)" if view == "side" else "top view (x–y)", fontsize=9)

    fig.suptitle(title)
    _add_colorbar(fig, norm, cm, [(W - right + 0.25) / W, bottom / H, 0.2 / W, panel_h / H], field_name)
    return fig


# ----------------------------------------------------------------------------------------------- series

def _xy(label, value, x) -> tuple[np.ndarray, np.ndarray]:
    if isinstance(value, tuple) and len(value) == 2:
        xs, ys = value
    else:
        if x is None:
            raise ParameterError("ys", f"entry {label!r} is a bare y array but no shared x was given")
        xs, ys = x, value
    xs = np.asarray(xs, dtype=np.float64).reshape(-1)
    ys = np.asarray(ys, dtype=np.float64).reshape(-1)
    if xs.shape != ys.shape:
        raise ParameterError("ys", f"entry {label!r}: x has {xs.size} values, y has {ys.size}")
    return xs, ys


def plot_series(path, x, ys: dict, xlabel: str = "", ylabel: str = "", title: str = "",
                reference: dict | tuple | None = None, *, logx: bool = False, logy: bool = False,
                xlim=None, ylim=None, dpi: int = 100, marker: str | None = None) -> Path:
    """Line plot of computed series with reference data as markers; writes a PNG and returns the path.

    ``ys`` maps a label to ``(x, y)`` or to a bare ``y`` sharing the ``x`` argument (``x`` may be None
    when every entry carries its own x); ``marker`` (e.g. "o") marks their points too (a few computed values, a
    convergence study). ``reference`` maps a label to ``(x, y)`` (markers only), or is a single ``(x, y)`` pair
    labelled "reference".
    """
    fig = _figure(7.0, 4.6, dpi)
    ax = fig.add_axes([0.14, 0.13, 0.82, 0.78])
    for label, value in (ys or {}).items():
        xs, yv = _xy(label, value, x)
        ax.plot(xs, yv, lw=1.6, label=str(label), marker=marker, ms=4)
    if reference is not None:
        refs = {"reference": reference} if isinstance(reference, tuple) else reference
        markers = "osD^v<>ph*"
        for k, (label, value) in enumerate(refs.items()):
            xs, yv = _xy(label, value, None)
            ax.plot(xs, yv, ls="none", marker=markers[k % len(markers)], ms=5, mfc="none", mew=1.2, color="k",
                    label=str(label))
    if logx:
        ax.set_xscale("log")
    if logy:
        ax.set_yscale("log")
    if xlim is not None:
        ax.set_xlim(xlim)
    if ylim is not None:
        ax.set_ylim(ylim)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.grid(True, alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=9, frameon=False)
    return _save(fig, path)
