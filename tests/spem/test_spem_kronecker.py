"""SPEM's Kronecker-delta option (Mendes (2010), Section 3.1.5, eqs 3.31-3.35): the interpolation matrix against a
brute-force loop, nodal values that reproduce imposed fields, the size of what the option corrects, the
subset solve of a hard source, and bad input."""

from __future__ import annotations

import numpy as np
import pytest

from warpfree import device
from warpfree.errors import ParameterError
from warpfree.solvers.spem import (
    SPEMModel,
    staggered_box,
    staggered_line,
    support_for_jitter,
)
from warpfree.solvers.spem.kronecker import (
    NodalValues,
    interpolation_matrix,
    own_set_volume,
)

A, B, SPACING = 1.0, 0.6, 0.05  # a PEC box (m) and its spacing Δ (m)


def spline(q: float) -> float:
    """Eq. 2.9, scalar, written out again (not the module's)."""
    if q <= 0.5:
        return 2.0 / 3.0 - 4.0 * q ** 2 + 4.0 * q ** 3
    if q < 1.0:
        return 4.0 / 3.0 - 4.0 * q + 4.0 * q ** 2 - 4.0 / 3.0 * q ** 3
    return 0.0


def brute_force(position, support, dim):
    """ω (2.15) and M_ij = W(|x_j − x_i|/d_i) ω_j (3.31) by a plain double loop."""
    p = np.asarray(position, float)[:, :dim]
    n = p.shape[0]
    w = np.array([[spline(np.linalg.norm(p[j] - p[i]) / support[i]) for j in range(n)] for i in range(n)])
    omega = 1.0 / w.sum(axis=1)
    return omega, w * omega[None, :]


def box_model(jitter=0.0, support=1.1, scheme="sph"):
    device.use("cpu", 2)
    lay = staggered_box((0, 0), (A, B), SPACING, jitter=jitter, seed=3, h_staggering="centres")
    return lay, SPEMModel(lay, scheme=scheme, support=max(support, support_for_jitter(jitter)))


def mode(points):
    """TM11 profile of the box, sin(πx/a) sin(πy/b) (zero on the walls)."""
    return np.sin(np.pi * points[:, 0] / A) * np.sin(np.pi * points[:, 1] / B)


def test_matrix_equals_a_brute_force_loop():
    """M (and ω) from the KD-tree equal the double loop to 1e-12 on a small 30 %-jittered box (both sets, with the
    model's supports: widened ones on the walls), and on random 1D and 3D sets with supports varying 3x from
    particle to particle (W_ij uses i's support: M is not symmetric). The model's float32 ω (kernel) agrees
    to float32 rounding."""
    device.use("cpu", 2)
    lay = staggered_box((0, 0), (0.3, 0.2), SPACING, jitter=0.3, seed=5, h_staggering="centres")
    model = SPEMModel(lay, scheme="sph", support=support_for_jitter(0.3))
    for s in (model.electric, model.magnetic):
        p, d = s.numpy("position"), s.numpy("support").astype(np.float64)
        omega, dense = brute_force(p, d, 2)
        assert np.max(np.abs(own_set_volume(p, d, 2) - omega)) < 1e-12
        assert np.max(np.abs(s.numpy("volume") - omega) / omega) < 2e-6  # float32 kernel
        m = interpolation_matrix(p, d, omega, 2)
        assert m.format == "csr" and m.dtype == np.float64
        assert np.max(np.abs(m.toarray() - dense)) < 1e-12
    rng = np.random.default_rng(1)
    for dim in (1, 3):
        p = rng.uniform(0.0, 1.0, (60, dim))
        d = rng.uniform(0.15, 0.45, 60)
        omega, dense = brute_force(p, d, dim)
        m = interpolation_matrix(p, d, own_set_volume(p, d, dim), dim).toarray()
        assert np.max(np.abs(m - dense)) < 1e-12
        assert np.max(np.abs(m - m.T)) > 1e-3  # non-symmetric, as the notes say


@pytest.mark.parametrize("jitter", [0.0, 0.3])
def test_nodal_values_reproduce_the_field(jitter):
    """u = nodal(f) gives field(u) = f to 1e-10 relative (measured ~1e-15: condition ~3 uniform, ~16 jittered),
    on both sets and for two components at once. On the jittered layout the raw interpolant is off even in the
    interior (measured 9 %): SPH's rows Σ_j W_ij ω_j do not sum to one there (measured up to 12 %)."""
    _, model = box_model(jitter, support=1.1)
    for s in (model.electric, model.magnetic):
        nv = NodalValues.from_set(s, 2)
        p = s.numpy("position")
        f = np.stack([mode(p), np.cos(2.0 * p[:, 0]) + p[:, 1]], axis=1)
        u = nv.nodal(f)
        assert np.max(np.abs(nv.field(u) - f)) < 1e-10 * np.abs(f).max()
        assert np.max(np.abs(nv.field(u[:, 0]) - f[:, 0])) < 1e-10
    if jitter:
        nv = NodalValues.from_set(model.electric, 2)
        p = model.electric.numpy("position")
        inner = (p[:, 0] > 0.15) & (p[:, 0] < A - 0.15) & (p[:, 1] > 0.15) & (p[:, 1] < B - 0.15)
        assert np.max(np.abs(nv.field(mode(p)) - mode(p))[inner]) > 0.05
    # 1D line
    device.use("cpu", 2)
    line = SPEMModel(staggered_line(0.0, 1.0, 0.02, jitter=jitter, seed=2), scheme="sph",
                     support=max(2.0, support_for_jitter(jitter)))
    nv = NodalValues.from_set(line.electric, 1)
    f = np.sin(3.0 * line.electric.numpy("position")[:, 0])
    assert np.max(np.abs(nv.field(nv.nodal(f)) - f)) < 1e-10


def smoothing(support: float) -> float:
    """c in field(f) − f ≈ c Δ² ∇²f on a uniform 2D interior for a support h <= 2 spacings (own-set shells
    at Δ and √2 Δ only): Σ over the 4 axis neighbours of f_j − f_i ≈ Δ² ∇²f, over the 4 diagonal ones
    ≈ 2 Δ² ∇²f, so c = ω (W(1/h) + 2 W(√2/h)) with ω = 1/(W(0) + 4 W(1/h) + 4 W(√2/h)) (2.15)."""
    axis, diagonal = spline(1.0 / support), spline(2 ** 0.5 / support)
    return (axis + 2.0 * diagonal) / (2.0 / 3.0 + 4.0 * axis + 4.0 * diagonal)


@pytest.mark.parametrize("support", [1.1, 2.0])
def test_raw_values_are_not_the_field_but_nodal_values_are(support):
    """The point of the option, on the TM11 profile of a 1 m x 0.6 m PEC box, Δ = 0.05 m.

    Raw values read through the interpolant are smoothed: on the uniform interior the rows sum to one and
    Taylor gives field(f) − f = Σ_j W_ij ω_j (f_j − f_i) ≈ c Δ² ∇²f (``smoothing``): c = 1.49e-3 for the
    default support of 1.1 spacings (W(1/1.1) = 1.0e-3 against W(0) = 2/3), c = 0.159 at 2 spacings.
    Measured max |field(f) − f| in the interior: 1.396e-4 (1.1) and 1.474e-2 (2.0), within 0.6 % and 0.8 % of
    the estimate; asserted within 3 %: the stencils' Taylor remainder, Δ²(kx⁴+ky⁴)/(12(kx²+ky²)) = 0.5 % for the
    axis shell and more for the diagonal one, and the model's float32 ω, which perturbs the row sums by ~1e-6
    (< 1 % of 1.4e-4). On the walls f = 0 but the interpolant is not (the wall particles' supports are widened
    to 2.2 Δ and reach interior values): measured 3.57e-2 (1.1) and 4.11e-2 (2.0) of max|f| = 1, asserted > 3e-2.
    After conversion the interpolant reproduces f to rounding (measured < 1e-15, asserted < 1e-12)."""
    lay, model = box_model(0.0, support=support)
    e = model.electric
    nv = NodalValues.from_set(e, 2)
    p = e.numpy("position")
    f = mode(p)
    raw = nv.field(f) - f
    inner = (p[:, 0] > 0.15) & (p[:, 0] < A - 0.15) & (p[:, 1] > 0.15) & (p[:, 1] < B - 0.15)
    laplacian = -np.pi ** 2 * (1 / A ** 2 + 1 / B ** 2) * f
    estimate = smoothing(support) * SPACING ** 2 * laplacian
    assert np.max(np.abs(raw - estimate)[inner]) < 0.03 * np.max(np.abs(estimate[inner]))
    assert np.max(np.abs(raw[lay.on_wall])) > 0.03  # visible: 3 % of the peak
    u = nv.nodal(f)
    assert np.max(np.abs(nv.field(u) - f)) < 1e-12
    assert np.max(np.abs(u - f)) > 0.03  # the nodal values are not the field values


def test_subset_solve_imposes_a_line_and_keeps_the_others():
    """A hard source on a line of E particles (x = 0.25 m, off the walls): nodal_for imposes the interpolant's
    value there exactly (1e-12) while every other particle keeps its nodal value bit for bit; the factor is
    reused across calls (linear in f_s), imposing the interpolant's own values returns the nodal values, and the
    subset's order is the values' order. Measured: condition of M_ss 3.0; the imposed nodal values differ from
    f_s by up to 0.152 (of 1); setting u_s = f_s directly (the raw hard source) leaves the interpolant 0.103
    off there."""
    lay, model = box_model(0.0, support=2.0)
    e = model.electric
    p = e.numpy("position")
    line = np.flatnonzero((np.abs(p[:, 0] - 0.25) < 1e-6) & ~lay.on_wall)
    assert line.size == 11
    nv = NodalValues.from_set(e, 2, subset=line)
    assert nv.condition < 10.0
    u0 = NodalValues.from_set(e, 2).nodal(mode(p))  # a field already on the particles
    for amplitude in (1.0, -0.3):
        f_s = amplitude * np.cos(np.pi * (p[line, 1] - 0.3) / B)
        u = nv.nodal_for(f_s, u0)
        assert np.array_equal(u[nv.others], u0[nv.others])
        assert np.max(np.abs(nv.field(u)[line] - f_s)) < 1e-12
        assert np.max(np.abs(u[line] - f_s)) > 0.01  # the imposed nodal values are not f_s themselves
        assert np.array_equal(nv.nodal_for(f_s, u0[nv.others]), u)  # the others alone
        raw = u0.copy()
        raw[line] = f_s
        assert np.max(np.abs(nv.field(raw)[line] - f_s)) > 0.02 * abs(amplitude)  # a raw hard source is off
    assert np.max(np.abs(nv.nodal_for(nv.field(u0)[line], u0) - u0)) < 1e-12
    backwards = NodalValues.from_set(e, 2, subset=line[::-1])  # values follow the subset's order
    assert np.max(np.abs(backwards.nodal_for(f_s[::-1], u0) - u)) < 1e-14
    two = nv.nodal_for(np.stack([f_s, 2 * f_s], axis=1), np.stack([u0, 2 * u0], axis=1))
    assert np.max(np.abs(two[:, 1] - 2 * two[:, 0])) < 1e-12
    assert np.max(np.abs(nv.field(nv.nodal(mode(p))) - mode(p))) < 1e-12  # nodal still works (lazy full factor)


def test_bad_input():
    """Shapes, non-finite values, dim, subset, and singular / ill-conditioned matrices are named."""
    rng = np.random.default_rng(0)
    p = rng.uniform(0.0, 1.0, (40, 2))
    d = np.full(40, 0.3)
    w = own_set_volume(p, d, 2)

    def raises(name, call, match=None):
        with pytest.raises(ParameterError, match=match) as info:
            call()
        assert info.value.name == name

    raises("dim", lambda: NodalValues(p, d, w, 4))
    raises("dim", lambda: interpolation_matrix(p, d, w, True))
    raises("position", lambda: NodalValues(p[:, :1], d, w, 2))
    raises("position", lambda: NodalValues(p.ravel(), d, w, 2))
    bad = p.copy()
    bad[3, 1] = np.nan
    raises("position", lambda: NodalValues(bad, d, w, 2), "particle 3")
    raises("support", lambda: NodalValues(p, d[:-1], w, 2))
    raises("support", lambda: NodalValues(p, np.where(np.arange(40) == 7, 0.0, d), w, 2), "particle 7")
    raises("volume", lambda: NodalValues(p, d, np.full(40, np.inf), 2))
    nv = NodalValues(p, d, w, 2)
    raises("f", lambda: nv.nodal(np.ones(39)))
    raises("f", lambda: nv.nodal(np.where(np.arange(40) == 2, np.nan, 1.0)), "row 2")
    raises("u", lambda: nv.field(np.ones((40, 2, 2))))
    raises("subset", lambda: nv.nodal_for(np.ones(3), np.ones(40)))
    raises("subset", lambda: NodalValues(p, d, w, 2, subset=[1, 1]))
    raises("subset", lambda: NodalValues(p, d, w, 2, subset=[40]))
    raises("subset", lambda: NodalValues(p, d, w, 2, subset=[]))
    raises("subset", lambda: NodalValues(p, d, w, 2, subset=np.ones(39, bool)))
    sub = NodalValues(p, d, w, 2, subset=np.arange(40) < 5)
    raises("f_subset", lambda: sub.nodal_for(np.ones(4), np.ones(40)))
    raises("others", lambda: sub.nodal_for(np.ones(5), np.ones(30)))
    raises("others", lambda: sub.nodal_for(np.ones((5, 2)), np.ones(35)))
    # two coincident particles: identical rows and columns (singular); nearly coincident: ill conditioned
    for offset, match in ((0.0, "singular|ill conditioned"), (1e-9, "ill conditioned")):
        q = p.copy()
        q[1] = q[0] + offset
        raises("kronecker", lambda q=q: NodalValues(q, d, own_set_volume(q, d, 2), 2), match)
        with pytest.raises(ParameterError, match="closest particles are 0 and 1"):
            NodalValues(q, d, own_set_volume(q, d, 2), 2)
    q = p.copy()
    q[1] = q[0]
    raises("kronecker", lambda: NodalValues(q, d, own_set_volume(q, d, 2), 2, subset=[0, 1, 2]))
    NodalValues(q, d, own_set_volume(q, d, 2), 2, subset=[0, 2])  # the block without the twin is fine
