"""The space particles live in: displacements between two points, free or periodic per axis.

Every kernel takes the displacement between two particles from here, never as ``x[i] - x[j]``
inline, so that a periodic box works in every kernel.

- Free axes: r_ij = x_i - x_j.
- Periodic axes (box side L): the minimum image, r_ij = d - L round(d / L) with d = x_i - x_j, so
  |r_ij| <= L/2 along that axis. Neighbour queries in a periodic box go through image points built
  on the host side (``warpfree.neighbours``), never through HashGrid wrap-around (Warp issue #283:
  wrap-around misses neighbours at the lower face).

Two forms of the same function:

- :func:`displacement` switches the periodic axes at run time (``box.periodic`` holds 1 or 0 per
  axis): for set-up and neighbour kernels, where a few extra operations per pair do not matter.
- :func:`displacement_function` returns a ``@wp.func`` compiled for one pattern of periodic axes:
  in free space it is exactly ``x_i - x_j``, so the hot loops of a solver pay nothing for periodicity
  they do not use.

Precision: float32 positions (``wp.vec3``), as the HashGrid. Units: the scene's length unit. The float64 2D
form (:class:`Box2d`, :func:`offset2d`) serves the MLS kernels (EFG nodes, PIC particles), whose moment matrices
need float64 offsets (``kernels/mls.py``).
"""

import warp as wp


@wp.struct
class Box:
    """An axis-aligned box: ``lower`` corner, side ``length``, ``periodic`` (1.0 or 0.0 per axis)."""

    lower: wp.vec3
    length: wp.vec3
    inv_length: wp.vec3
    periodic: wp.vec3


@wp.func
def minimum_image(d: float, length: float, inv_length: float) -> float:
    """d - L round(d/L): the component of the nearest image, in [-L/2, L/2]."""
    return d - length * wp.round(d * inv_length)


@wp.func
def displacement(box: Box, xi: wp.vec3, xj: wp.vec3) -> wp.vec3:
    """r_ij = x_i - x_j, the minimum image along the periodic axes of ``box`` (run-time switch)."""
    d = xi - xj
    return wp.vec3(
        d[0] - box.periodic[0] * box.length[0] * wp.round(d[0] * box.inv_length[0]),
        d[1] - box.periodic[1] * box.length[1] * wp.round(d[1] * box.inv_length[1]),
        d[2] - box.periodic[2] * box.length[2] * wp.round(d[2] * box.inv_length[2]),
    )


@wp.func
def image_displacement(xi: wp.vec3, image: wp.vec3) -> wp.vec3:
    """x_i - y for a point y that already stands where it acts (an image point placed by a shift)."""
    return xi - image


@wp.func
def wrap(box: Box, x: wp.vec3) -> wp.vec3:
    """Bring a position back into the box along its periodic axes: lower <= x < lower + L."""
    out = x
    for a in range(3):
        if box.periodic[a] != 0.0:
            s = x[a] - box.lower[a]
            s = s - box.length[a] * wp.floor(s * box.inv_length[a])
            if s >= box.length[a]:  # float rounding of a point just below the lower face
                s = s - box.length[a]
            out[a] = box.lower[a] + s
    return out


@wp.struct
class Box2d:
    """The float64 2D box of the MLS kernels: ``lower`` corner, side ``length``, ``periodic`` (1.0 or 0.0 per axis)."""

    lower: wp.vec2d
    length: wp.vec2d
    inv_length: wp.vec2d
    periodic: wp.vec2d


@wp.func
def offset2d(box: Box2d, xi: wp.vec2d, xj: wp.vec2d) -> wp.vec2d:
    """r_ij = x_i - x_j in float64, the minimum image along the periodic axes of ``box`` (exactly x_i - x_j on a
    free axis)."""
    d = xi - xj
    return wp.vec2d(
        d[0] - box.periodic[0] * box.length[0] * wp.round(d[0] * box.inv_length[0]),
        d[1] - box.periodic[1] * box.length[1] * wp.round(d[1] * box.inv_length[1]),
    )


@wp.func
def wrap2d(box: Box2d, x: wp.vec2d) -> wp.vec2d:
    """x brought back into the box along its periodic axes (float64): lower <= x < lower + L."""
    out = x
    for a in range(2):
        if box.periodic[a] != wp.float64(0.0):
            s = x[a] - box.lower[a]
            s = s - box.length[a] * wp.floor(s * box.inv_length[a])
            if s >= box.length[a]:  # rounding of a point just below the lower face
                s = s - box.length[a]
            if s < wp.float64(0.0):
                s = s + box.length[a]
            out[a] = box.lower[a] + s
    return out


_displacements: dict = {}


def displacement_function(periodic: tuple):
    """``@wp.func displacement(box: Box, xi, xj) -> wp.vec3`` compiled for one pattern of periodic axes.

    ``periodic`` is a tuple of three booleans. With no periodic axis the function is exactly
    ``xi - xj``; each periodic axis adds one minimum-image correction (a round and two multiplies).
    Functions are cached, so kernels built for the same pattern share one function.
    """
    key = tuple(bool(p) for p in periodic)
    if len(key) != 3:
        raise ValueError(f"periodic: need three flags, got {periodic!r}")
    if key in _displacements:
        return _displacements[key]
    px, py, pz = key

    @wp.func
    def displacement_compiled(box: Box, xi: wp.vec3, xj: wp.vec3) -> wp.vec3:
        d = xi - xj
        if wp.static(px):
            d = wp.vec3(minimum_image(d[0], box.length[0], box.inv_length[0]), d[1], d[2])
        if wp.static(py):
            d = wp.vec3(d[0], minimum_image(d[1], box.length[1], box.inv_length[1]), d[2])
        if wp.static(pz):
            d = wp.vec3(d[0], d[1], minimum_image(d[2], box.length[2], box.inv_length[2]))
        return d

    _displacements[key] = displacement_compiled
    return displacement_compiled
