"""The Kronecker-delta option of SPEM (Mendes 2010, §3.1.5): particle values as nodal parameters.

An SPH particle value u_j is a *nodal parameter*, not the field. The field at particle i is the interpolant
(3.31), over the particle's own set (E or H), i itself included::

    u^h(x_i) = Σ_j W_ij u_j ω_j,    W_ij = W(|x_j − x_i| / d_W,i),

with W the unnormalised cubic spline of eq. 2.9 evaluated with the support d_W,i of particle i (the particle
at which W is evaluated) and ω_j = 1 / Σ_k W(|x_k − x_j| / d_W,j) the own-set volume of eq. 2.15. Since
W_ij ω_j ≠ 0 for some j ≠ i, u^h(x_i) ≠ u_i: the kernel lacks the Kronecker-delta property. To impose field
values f_i (initial fields, Dirichlet data, a hard source) one must solve for the nodal values::

    M u = f,    M_ij = W_ij ω_j   (diagonal included),

which is (3.31) written for every particle. The thesis writes it as (3.32)-(3.35): dividing row i of (3.31) by
W_ii ω_i gives (3.32)/(3.33), u_i = Σ_{j≠i} −W_ij ω_j u_j / (W_ii ω_i) + f_i / (W_ii ω_i), i.e. (3.34)
A u + b = u with b_i = f_i / (W_ii ω_i), and (3.35) (A − I) u + b = 0.

Erratum. The printed A (3.34) has off-diagonal entries −W_ij ω_j; to match (3.33) they must also be divided by
W_ii ω_i. With that division, (A − I) = −D⁻¹ M and b = D⁻¹ f for D = diag(W_ii ω_i), so (3.35) is exactly
M u = f; this module solves the clean form directly (the row scaling D changes neither the solution nor, on a
near-uniform layout where W_ii ω_i is nearly constant, the conditioning).

M is sparse (the own-set neighbours within each particle's support), non-symmetric in general (W_ij uses d_W,i
and is weighted by ω_j), and constant because the particles do not move: it is built and LU-factorised once
(``scipy.sparse.linalg.splu``), then every solve is a pair of triangular substitutions. A hard source that
imposes values at a subset s of particles at every step, with the other particles o keeping theirs, solves
the block system M_ss u_s = f_s − M_so u_o with the factorisation of M_ss kept (:class:`NodalValues` with
``subset``).

Units. Positions and supports in m; W (2.9, unnormalised) and ω (2.15) are dimensionless, so M is
dimensionless and u carries the unit of the field (V/m for E, A/m for H).

Caveat: what the option is for. With the default FPM scheme the particle values already are point values:
FPM's derivative is exact for linear fields when u_j is taken as the field at x_j, and the solver never reads a
value through the SPH interpolant. Converting would then *change* a correct initial field. The option matters
for the "sph" and "cspm" schemes, whose values are read through the SPH interpolant. Even there its size
depends on the support: with the default 1.1 spacings the nearest own-set neighbours sit at q = 1/1.1, where
W = 1.0e-3 against W(0) = 2/3, so M is the identity to ~0.6 % per row and the interpolant of raw values differs
from them by ω W(q₁) Δ² ∇²f ≈ 1.5e-3 Δ² ∇²f in a uniform interior; with 2-3 spacings (the supports plain
SPH needs) the difference is percent-level (see tests/spem/test_spem_kronecker.py for the measured numbers).
Particles with widened supports (E particles on a wall) differ more.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import LinearOperator, onenormest, splu
from scipy.spatial import cKDTree

from warpfree.errors import ParameterError, require_integer
from warpfree.kernels.smoothing import unit_cubic_spline_values

__all__ = ["KRONECKER_CONDITION_LIMIT", "NodalValues", "interpolation_matrix", "own_set_volume"]

#: largest admitted 1-norm condition estimate of M (or M_ss): beyond it a solve loses more than half of float64's
#: digits, and the nodal values would amplify rounding in f by as much (nearly coincident particles, or a support
#: so wide that neighbouring rows of M become nearly equal)
KRONECKER_CONDITION_LIMIT = 1.0e8


# -- the kernel and the matrix ----------------------------------------------------------------------------------
def _pairs(position: np.ndarray, support: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Own-set pairs (i, j, q_ij) with q_ij = |x_j − x_i| / d_W,i < 1, i = j included (q = 0). The KD-tree is
    searched once to the widest support (m); pairs beyond particle i's own support are dropped afterwards."""
    n = position.shape[0]
    pairs = cKDTree(position).query_pairs(r=float(support.max()), output_type="ndarray")
    diagonal = np.arange(n)
    i = np.concatenate([diagonal, pairs[:, 0], pairs[:, 1]])
    j = np.concatenate([diagonal, pairs[:, 1], pairs[:, 0]])
    q = np.linalg.norm(position[j] - position[i], axis=1) / support[i]
    keep = q < 1.0
    return i[keep], j[keep], q[keep]


def _check_set(position, support, volume, dim) -> tuple[np.ndarray, np.ndarray, np.ndarray | None, int]:
    """Validated float64 copies: positions (N, dim) in m, supports (N,) in m, volumes (N,) (or None); ``dim``."""
    dim = require_integer("dim", dim, minimum=1, maximum=3)
    p = np.asarray(position, dtype=np.float64)
    if p.ndim != 2 or p.shape[0] < 1 or p.shape[1] < dim:
        raise ParameterError("position", f"must be an (N, >= {dim}) array of particle positions (m) with N >= 1, "
                                         f"got shape {p.shape}")
    p = np.ascontiguousarray(p[:, :dim])
    if not np.all(np.isfinite(p)):
        bad = int(np.argmax(~np.all(np.isfinite(p), axis=1)))
        raise ParameterError("position", f"must be finite; particle {bad} has {p[bad].tolist()}")
    n = p.shape[0]
    out = []
    for name, value in (("support", support), ("volume", volume)):
        if value is None:
            out.append(None)
            continue
        v = np.asarray(value, dtype=np.float64)
        if v.shape != (n,):
            raise ParameterError(name, f"must have one value per particle, shape ({n},), got {v.shape}")
        if not np.all(np.isfinite(v) & (v > 0)):
            bad = int(np.argmax(~(np.isfinite(v) & (v > 0))))
            raise ParameterError(name, f"must be finite and > 0; particle {bad} has {v[bad]}")
        out.append(v)
    return p, out[0], out[1], dim


def own_set_volume(position, support, dim: int) -> np.ndarray:
    """ω_i = 1 / Σ_k W(|x_k − x_i| / d_W,i) over the particle's own set, k = i included (eq. 2.15;
    dimensionless). The float64 counterpart of ``warpfree.kernels.spem.own_set_volume`` (float32), for set-up
    code and tests that do not build a model."""
    p, d, _, _ = _check_set(position, support, None, dim)
    i, _, q = _pairs(p, d)
    return 1.0 / np.bincount(i, weights=unit_cubic_spline_values(q), minlength=p.shape[0])


def interpolation_matrix(position, support, volume, dim: int) -> sp.csr_matrix:
    """The SPH interpolation matrix of one particle set, M_ij = W(|x_j − x_i| / d_W,i) ω_j (3.31, the clean form
    of 3.32-3.35; dimensionless), float64 CSR with sorted indices, so that (M u)_i = u^h(x_i).

    position: (N, >= dim) particle positions (m; columns beyond ``dim`` are ignored, e.g. a ParticleSet's 3D
    padding); support: (N,) support radii d_W (m); volume: (N,) own-set volumes ω (2.15, dimensionless);
    dim: 1, 2 or 3. No periodic images (SPEM's space is free)."""
    p, d, w, _ = _check_set(position, support, volume, dim)
    n = p.shape[0]
    i, j, q = _pairs(p, d)
    m = sp.csr_matrix((unit_cubic_spline_values(q) * w[j], (i, j)), shape=(n, n))
    m.sort_indices()
    return m


# -- the solves -------------------------------------------------------------------------------------------------
def _closest_pair(position: np.ndarray, support: np.ndarray, rows: np.ndarray) -> str:
    """A sentence naming the closest pair among particles ``rows`` (the usual cause of a singular M)."""
    if rows.size < 2:
        return ""
    p = position[rows]
    dist, nearest = cKDTree(p).query(p, k=2)
    a = int(np.argmin(dist[:, 1]))
    b = int(nearest[a, 1])
    ia, ib = int(rows[a]), int(rows[b])
    return (f"; the closest particles are {ia} and {ib} at {np.round(p[a], 6).tolist()} and "
            f"{np.round(p[b], 6).tolist()}, {dist[a, 1]:.3g} m apart ({dist[a, 1] / support[ia]:.3g} of the support)")


def _factorise(matrix: sp.csr_matrix, what: str, position: np.ndarray, support: np.ndarray, rows: np.ndarray):
    """LU of ``matrix`` (splu) and its 1-norm condition estimate ||A||_1 ||A⁻¹||_1 (the exact column-sum norm of A,
    Higham-Tisseur's estimate of the inverse's through the factor: a few solves). A singular or ill-conditioned
    matrix raises ParameterError("kronecker", ...) naming the closest particles."""
    n = matrix.shape[0]
    try:
        lu = splu(sp.csc_matrix(matrix))
    except RuntimeError as err:  # "Factor is exactly singular"
        raise ParameterError("kronecker", f"the interpolation matrix {what} (3.31-3.35) is singular ({err}): two "
                                          f"rows are identical, e.g. coincident particles"
                                          f"{_closest_pair(position, support, rows)}") from None
    pivots = np.abs(lu.U.diagonal())
    if not np.all(np.isfinite(pivots)) or pivots.min() == 0.0:
        raise ParameterError("kronecker", f"the interpolation matrix {what} (3.31-3.35) is singular (zero pivot)"
                                          f"{_closest_pair(position, support, rows)}")
    inverse = LinearOperator((n, n), dtype=np.float64, matvec=lu.solve, matmat=lu.solve,
                             rmatvec=lambda x: lu.solve(x, trans="T"), rmatmat=lambda x: lu.solve(x, trans="T"))
    norm = float(abs(matrix).sum(axis=0).max())
    condition = norm * float(onenormest(inverse))
    if not condition <= KRONECKER_CONDITION_LIMIT:
        raise ParameterError("kronecker", f"the interpolation matrix {what} (3.31-3.35) is ill conditioned "
                                          f"(1-norm condition ~{condition:.3g} > {KRONECKER_CONDITION_LIMIT:.0g}): "
                                          f"nearly coincident particles, or a support so wide that neighbouring "
                                          f"rows are nearly equal{_closest_pair(position, support, rows)}")
    return lu, condition


def _values(name: str, value, n: int) -> np.ndarray:
    """A float64 (n,) or (n, k) array of finite values (k components per particle), else ParameterError(name)."""
    v = np.asarray(value, dtype=np.float64)
    if v.ndim not in (1, 2) or v.shape[0] != n:
        raise ParameterError(name, f"must have one value (or one row of components) per particle, shape ({n},) or "
                                   f"({n}, k), got {v.shape}")
    if not np.all(np.isfinite(v)):
        bad = int(np.argmax(~np.isfinite(v.reshape(n, -1)).all(axis=1)))
        raise ParameterError(name, f"must be finite; row {bad} is {v[bad].tolist()}")
    return v


class NodalValues:
    """Nodal parameters u from field values f and back, on one particle set (3.31-3.35; see the module docstring).

    position (N, >= dim) m, support (N,) m, volume (N,) ω (2.15), dim: as :func:`interpolation_matrix`.
    subset: None (impose values at every particle: M is factorised once), or the indices (or an (N,) boolean
    mask) of the particles whose field values are imposed while the others keep their nodal values: then the
    block M_ss is factorised once, for :meth:`nodal_for` (a hard source imposed at every step).

    Attributes: ``matrix`` (M, CSR), ``n``, ``subset`` (the indices in the order given; values at the subset are
    passed and returned in this order) / ``others`` (the remaining indices, sorted; both None without a subset),
    ``condition`` (1-norm condition estimate of the factorised matrix, M or M_ss).
    A singular or ill-conditioned matrix raises ParameterError("kronecker", ...)."""

    def __init__(self, position, support, volume, dim: int, subset=None):
        p, d, w, self.dim = _check_set(position, support, volume, dim)
        self._position, self._support = p, d
        self.matrix = interpolation_matrix(p, d, w, self.dim)
        self.n = p.shape[0]
        self._lu = None
        self.subset = self.others = None
        if subset is None:
            self._lu, self.condition = _factorise(self.matrix, "M", p, d, np.arange(self.n))
            return
        self.subset = self._check_subset(subset)
        self.others = np.setdiff1d(np.arange(self.n), self.subset)
        rows = self.matrix[self.subset]
        self._block_ss = rows[:, self.subset].tocsr()
        self._block_so = rows[:, self.others].tocsr()
        self._subset_lu, self.condition = _factorise(self._block_ss, "M_ss", p, d, self.subset)

    @classmethod
    def from_set(cls, particles, dim: int, subset=None) -> NodalValues:
        """For a model's ParticleSet (``model.electric`` / ``model.magnetic``): its position, support and own-set
        volume fields (read from the device once)."""
        return cls(particles.numpy("position"), particles.numpy("support"), particles.numpy("volume"), dim, subset)

    def _check_subset(self, subset) -> np.ndarray:
        s = np.asarray(subset)
        if s.dtype == bool:
            if s.shape != (self.n,):
                raise ParameterError("subset", f"a boolean mask must have shape ({self.n},), got {s.shape}")
            s = np.flatnonzero(s)
        if s.ndim != 1 or s.size == 0 or not np.issubdtype(s.dtype, np.integer):
            raise ParameterError("subset", f"must be a non-empty 1D array of particle indices, got {subset!r}")
        if s.min() < 0 or s.max() >= self.n or np.unique(s).size != s.size:
            raise ParameterError("subset", f"must hold distinct particle indices in 0..{self.n - 1}")
        return s.astype(np.int64)

    def field(self, u) -> np.ndarray:
        """The field at the particles, u^h(x_i) = Σ_j W_ij u_j ω_j = (M u)_i (3.31), for nodal values u of shape
        (N,) or (N, k) (unit of the field)."""
        return self.matrix @ _values("u", u, self.n)

    def nodal(self, f) -> np.ndarray:
        """Nodal values u with M u = f (3.35 in its clean form), for field values f of shape (N,) or (N, k) (unit
        of the field). Without a subset M was factorised at construction; with one it is factorised (and checked)
        on the first call."""
        f = _values("f", f, self.n)
        if self._lu is None:
            self._lu, _ = _factorise(self.matrix, "M", self._position, self._support, np.arange(self.n))
        return self._lu.solve(f)

    def nodal_for(self, f_subset, others) -> np.ndarray:
        """All N nodal values after imposing field values ``f_subset`` (n_s,) or (n_s, k), in the order of
        ``subset``, at the subset while the other particles keep the nodal values ``others``: u_s solves
        M_ss u_s = f_s − M_so u_o with the factor kept. ``others`` is either the current nodal values of every
        particle, (N,) / (N, k) (the subset's entries are ignored), or those of the others only, (N − n_s,) /
        (N − n_s, k). Returns a new (N,) / (N, k) array whose other entries are ``others``' values, unchanged."""
        if self.subset is None:
            raise ParameterError("subset", "nodal_for needs the NodalValues built with a subset (use nodal otherwise)")
        ns, no = self.subset.size, self.others.size
        f = _values("f_subset", f_subset, ns)
        o = np.asarray(others, dtype=np.float64)
        if o.ndim >= 1 and o.shape[0] == self.n:
            o = o[self.others]
        o = _values("others", o, no)
        if o.shape[1:] != f.shape[1:]:
            raise ParameterError("others", f"must have the components of f_subset, {f.shape[1:]}, got {o.shape[1:]}")
        u = np.empty((self.n,) + f.shape[1:], dtype=np.float64)
        u[self.others] = o
        u[self.subset] = self._subset_lu.solve(f - self._block_so @ o)
        return u
