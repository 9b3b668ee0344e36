"""SPH smoothing kernels as ``@wp.func``: value ``W(r, h)``, radial derivative ``dW/dr`` and gradient.

float32: SPH fluids and SPEM fields tolerate single precision; EFG's MLS weights live elsewhere in
float64. Units: ``r`` and ``h`` in metres (or the scene's length unit); ``W`` in 1/m^dim.

All kernels are normalised, ``∫ W dV = 1`` in 1, 2 and 3 dimensions, and vanish at ``r >= kappa*h``:

- cubic spline (Monaghan 1992), support 2h, q = r/h::

      W = σ_d [1 - 1.5 q² + 0.75 q³]      0 <= q < 1
      W = σ_d 0.25 (2 - q)³               1 <= q < 2
      σ_1 = 2/(3h), σ_2 = 10/(7π h²), σ_3 = 1/(π h³)

- Wendland C2 (Wendland 1995; the DualSPHysics default), support 2h::

      W = α_d (1 - q/2)⁴ (2q + 1)           (2D, 3D)   α_2 = 7/(4π h²), α_3 = 21/(16π h³)
      W = α_1 (1 - q/2)³ (1.5q + 1)         (1D)       α_1 = 5/(8h)

- quintic spline (Morris 1997), support 3h::

      W = β_d [(3-q)⁵ - 6(2-q)⁵₊ + 15(1-q)⁵₊]   β_1 = 1/(120h), β_2 = 7/(478π h²), β_3 = 1/(120π h³)

Chapter 5 of a Portuguese thesis on SPH fluids (§5.5) quotes the support ratio κh = 1.2 dx; it also asks for
>= 20 neighbours in 2D and >= 56 in 3D, which needs h ≈ 1.2–1.3 dx with support 2h. No kernel here fixes h: WCSPH
takes h = 1.6 dx in 2D and 1.3 dx in 3D by default (``warpfree.solvers.wcsph.model.DEFAULT_H_FACTOR``, where the
measurement behind the 2D value is), the heat example and WCSPH's wall relaxation 1.3 dx.

Beside them, the one unnormalised cubic spline on a unit support (:func:`unit_cubic_spline`), generic in its
precision: the SPEM particle weight (float32) and the MLS cubic weight (float64).
"""

from typing import Any

import warp as wp

CUBIC_SPLINE = wp.constant(0)
WENDLAND_C2 = wp.constant(1)
QUINTIC_SPLINE = wp.constant(2)

#: name -> (id, support radius in units of h)
KERNELS = {
    "cubic_spline": (0, 2.0),
    "wendland_c2": (1, 2.0),
    "quintic_spline": (2, 3.0),
}

PI = wp.constant(3.14159265358979)


def kernel_id(name: str) -> int:
    """Integer id of a kernel by name (``cubic_spline``, ``wendland_c2``, ``quintic_spline``)."""
    if name not in KERNELS:
        raise ValueError(f"kernel: must be one of {sorted(KERNELS)}, got {name!r}")
    return KERNELS[name][0]


def support_factor(name: str) -> float:
    """Support radius of the named kernel in units of h (2 for cubic and Wendland C2, 3 for quintic)."""
    kernel_id(name)
    return KERNELS[name][1]


#: σ_d for h = 1, per kernel name and dimension (1, 2, 3): the host-side twin of :func:`kernel_sigma`
SIGMA = {
    "cubic_spline": (2.0 / 3.0, 10.0 / (7.0 * 3.14159265358979), 1.0 / 3.14159265358979),
    "wendland_c2": (5.0 / 8.0, 7.0 / (4.0 * 3.14159265358979), 21.0 / (16.0 * 3.14159265358979)),
    "quintic_spline": (1.0 / 120.0, 7.0 / (478.0 * 3.14159265358979), 1.0 / (120.0 * 3.14159265358979)),
}


def normalisation(name: str, dim: int, h: float) -> float:
    """σ_d(h) = σ_d(1)/h^dim of the named kernel (1/m^dim), on the host (constants of kernel structs)."""
    kernel_id(name)
    return SIGMA[name][dim - 1] / h ** dim


@wp.func
def kernel_sigma(kind: int, dim: int, h: float) -> float:
    """Normalisation constant σ_d(h) of the kernel (1/m^dim)."""
    hd = h
    if dim == 2:
        hd = h * h
    elif dim == 3:
        hd = h * h * h
    s = float(0.0)
    if kind == 0:
        if dim == 1:
            s = 2.0 / 3.0
        elif dim == 2:
            s = 10.0 / (7.0 * PI)
        else:
            s = 1.0 / PI
    elif kind == 1:
        if dim == 1:
            s = 5.0 / 8.0
        elif dim == 2:
            s = 7.0 / (4.0 * PI)
        else:
            s = 21.0 / (16.0 * PI)
    else:
        if dim == 1:
            s = 1.0 / 120.0
        elif dim == 2:
            s = 7.0 / (478.0 * PI)
        else:
            s = 1.0 / (120.0 * PI)
    return s / hd


@wp.func
def kernel_shape(kind: int, dim: int, q: float) -> float:
    """Dimensionless shape f(q) with W = σ_d f(q)."""
    f = float(0.0)
    if kind == 0:
        if q < 1.0:
            f = 1.0 - 1.5 * q * q + 0.75 * q * q * q
        elif q < 2.0:
            t = 2.0 - q
            f = 0.25 * t * t * t
    elif kind == 1:
        if q < 2.0:
            t = 1.0 - 0.5 * q
            if dim == 1:
                f = t * t * t * (1.5 * q + 1.0)
            else:
                f = t * t * t * t * (2.0 * q + 1.0)
    else:
        if q < 3.0:
            t3 = 3.0 - q
            f = t3 * t3 * t3 * t3 * t3
            if q < 2.0:
                t2 = 2.0 - q
                f = f - 6.0 * t2 * t2 * t2 * t2 * t2
            if q < 1.0:
                t1 = 1.0 - q
                f = f + 15.0 * t1 * t1 * t1 * t1 * t1
    return f


@wp.func
def kernel_shape_dq(kind: int, dim: int, q: float) -> float:
    """df/dq of the dimensionless shape."""
    d = float(0.0)
    if kind == 0:
        if q < 1.0:
            d = -3.0 * q + 2.25 * q * q
        elif q < 2.0:
            t = 2.0 - q
            d = -0.75 * t * t
    elif kind == 1:
        if q < 2.0:
            t = 1.0 - 0.5 * q
            if dim == 1:
                d = -3.0 * q * t * t
            else:
                d = -5.0 * q * t * t * t
    else:
        if q < 3.0:
            t3 = 3.0 - q
            d = -5.0 * t3 * t3 * t3 * t3
            if q < 2.0:
                t2 = 2.0 - q
                d = d + 30.0 * t2 * t2 * t2 * t2
            if q < 1.0:
                t1 = 1.0 - q
                d = d - 75.0 * t1 * t1 * t1 * t1
    return d


@wp.func
def kernel_grad_coef(kind: int, dim: int, q: float) -> float:
    """(df/dq)/q, finite at q = 0; ∇_i W = (σ_d/h²) (df/dq)/q · r_ij avoids the divisions by r and h.

    Wendland C2 and the inner cubic branch need no division at all, which matters in hot loops.
    """
    c = float(0.0)
    if kind == 0:
        if q < 1.0:
            c = -3.0 + 2.25 * q
        elif q < 2.0:
            t = 2.0 - q
            c = -0.75 * t * t / q
    elif kind == 1:
        if q < 2.0:
            t = 1.0 - 0.5 * q
            if dim == 1:
                c = -3.0 * t * t
            else:
                c = -5.0 * t * t * t
    else:
        if q < 1.0:
            c = -120.0 + 120.0 * q * q - 50.0 * q * q * q  # f = 66 - 60q² + 30q⁴ - 10q⁵ for q < 1
        elif q < 3.0:
            c = kernel_shape_dq(kind, dim, q) / q
    return c


@wp.func
def kernel_w(kind: int, dim: int, r: float, h: float) -> float:
    """W(r, h) in 1/m^dim."""
    return kernel_sigma(kind, dim, h) * kernel_shape(kind, dim, r / h)


@wp.func
def kernel_dwdr(kind: int, dim: int, r: float, h: float) -> float:
    """dW/dr in 1/m^(dim+1); zero at r = 0 and beyond the support."""
    return kernel_sigma(kind, dim, h) * kernel_shape_dq(kind, dim, r / h) / h


@wp.func
def kernel_grad(kind: int, dim: int, rij: wp.vec3, r: float, h: float) -> wp.vec3:
    """∇_i W(x_i - x_j) = dW/dr · r_ij / r, with r_ij = x_i - x_j; the zero vector at r = 0."""
    if r <= 1.0e-12 * h:
        return wp.vec3(0.0, 0.0, 0.0)
    return rij * (kernel_dwdr(kind, dim, r, h) / r)


@wp.func
def unit_cubic_spline(q: Any):
    """(W, dW/dq) of the unnormalised cubic spline on the unit support: W = 2/3 - 4q² + 4q³ for q <= 1/2,
    4/3 - 4q + 4q² - 4/3 q³ for 1/2 < q < 1, 0 from 1 on (q = r/R >= 0, R the support radius; W(0) = 2/3). The SPEM
    weight (Mendes 2010, eq. 2.9, float32) and the MLS cubic weight (Rocha 2012, eq. 3.32, float64) in the precision of
    q: its
    constants are built in that type (a float literal such as 4.0 / 3.0 would enter a float64 function as a float32
    constant, and W and dW/dq would then disagree at 1e-7)."""
    w = type(q)(0.0)
    dw = type(q)(0.0)
    two = type(q)(2.0)
    three = type(q)(3.0)
    four = type(q)(4.0)
    if q <= type(q)(0.5):
        w = two / three - four * q * q + four * q * q * q
        dw = -type(q)(8.0) * q + type(q)(12.0) * q * q
    elif q < type(q)(1.0):
        third4 = four / three
        w = third4 - four * q + four * q * q - third4 * q * q * q
        dw = -four + type(q)(8.0) * q - four * q * q
    return w, dw


@wp.kernel
def _unit_spline(x: wp.array(dtype=wp.float64), w: wp.array(dtype=wp.float64)):
    i = wp.tid()
    value, slope = unit_cubic_spline(x[i])
    w[i] = value


def unit_cubic_spline_values(q):
    """:func:`unit_cubic_spline`'s W at ``q`` on the host (float64 NumPy array like ``q``), evaluated by the same
    function the kernels use."""
    import numpy as np

    values = np.ascontiguousarray(np.atleast_1d(np.asarray(q, dtype=np.float64)))
    out = wp.zeros(len(values), dtype=wp.float64, device="cpu")
    if len(values):
        wp.launch(_unit_spline, dim=len(values), inputs=[wp.array(values, dtype=wp.float64, device="cpu"), out],
                  device="cpu")
    return out.numpy().reshape(np.shape(q))


PROFILE_QUANTITIES = ("shape", "grad_coef", "dwdr")


@wp.kernel
def _profile(kind: int, dim: int, h: float, quantity: int, x: wp.array(dtype=float), out: wp.array(dtype=float)):
    """out[i] = f(q), (df/dq)/q (q = x[i]) or dW/dr(r = x[i], h), by ``quantity`` 0, 1, 2."""
    i = wp.tid()
    if quantity == 0:
        out[i] = kernel_shape(kind, dim, x[i])
    elif quantity == 1:
        out[i] = kernel_grad_coef(kind, dim, x[i])
    else:
        out[i] = kernel_dwdr(kind, dim, x[i], h)


def kernel_profile(name: str, dim: int, x, quantity: str = "shape", h: float = 1.0):
    """The kernels' own values on the host, for set-up constants (float64 NumPy array like ``x``):
    ``shape`` f(q) at q = x, ``grad_coef`` (df/dq)/q at q = x, ``dwdr`` dW/dr at r = x (1/m^(dim+1)) for ``h``."""
    import numpy as np

    if quantity not in PROFILE_QUANTITIES:
        raise ValueError(f"quantity: must be one of {PROFILE_QUANTITIES}, got {quantity!r}")
    values = np.atleast_1d(np.asarray(x, dtype=np.float32))
    inp = wp.array(values, dtype=float, device="cpu")
    out = wp.zeros(len(values), dtype=float, device="cpu")
    wp.launch(_profile, dim=len(values), inputs=[kernel_id(name), int(dim), float(h), PROFILE_QUANTITIES.index(quantity),
                                                 inp, out], device="cpu")
    return out.numpy().astype(np.float64).reshape(np.shape(x))
