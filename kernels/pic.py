"""PIC kernels (Marques 2008, ch. 4): MLS fits at the particles, charge deposit as a node gather, field gather,
leapfrog push. Normalised units (ε0 = 1; charges in e, masses in m_e, lengths and times in the scene's units).

Precision: float64 throughout (positions ``wp.vec2d``, MLS fits, charges, fields): the shape functions come from
the same ill-conditioned moment matrices as EFG's (``kernels/mls.py``), and the deposit must keep the total
charge to round-off. Float32 ``wp.vec3`` copies of the positions serve only the ``wp.HashGrid`` queries.

Per step (Marques 2008, §2.2, ch. 4 and §5.2):

1. :func:`particle_fits`: each particle p queries the node grid and stores the γ-form of its MLS fit (γ, ∂γ,
   the basis scale) — Marques (2008) stores φ and ∇φ per particle (§5.3.2); γ is their compact form: φ_I(x_p) =
   w_I(x_p) γ_p·p((x_I - x_p)/s_p).
2. :func:`deposit`: each node I gathers the particles in its support through a HashGrid over the particles (in a
   periodic box, querying at its own periodic copies: ``warpfree.neighbours.GatherGrid``) and sums Q_I = Σ_p q_p φ_I(x_p) (eq 4.4) — a gather, race-free and bitwise the same for any thread count. Node and
   particle decide membership by the same float64 test on the same offset (``offset2d``), so Σ_I Q_I = Σ_p q_p
   Σ_I φ_I(x_p) = Σ_p q_p to round-off (partition of unity, eq 4.3).
3. :func:`particle_field`: E(x_p) = -Σ_I u_I ∇φ_I(x_p) (eq 4.5), the same nodes and fit; or the momentum-conserving
   form Σ_I φ_I(x_p) E_I from nodal fields (``warpfree.solvers.pic.field``).
4. :func:`leapfrog_push`: v^{n+1/2} = v^{n-1/2} + (q/m) E^n Δt, x^{n+1} = x^n + v^{n+1/2} Δt (eqs 2.21 / 4.7),
   positions wrapped along periodic axes, reflected at walls or absorbed by them (the next sort's
   :func:`cell_keys` moves absorbed particles past the live ones; :func:`count_live` counts those left);
   :func:`inject_particles` adds a wall source's particles; with a static magnetic field B = bz ẑ the
   velocity step is Boris's (:func:`boris_velocity`); :func:`kick` gives the half-step start
   v^{-1/2} = v^0 - (q/m) E^0 Δt/2.

Periodic boxes: the node grid holds the nodes' periodic images (``warpfree.neighbours``: static, placed once) and
the deposit queries the particle grid at the nodes' copies (no particle images, so nothing to count per step); offsets are minimum images (``kernels/space.py``), never HashGrid wrap-around.
"""

import warp as wp

from .mls import ALGEBRA, MLSFit, NodeSet, inside_support, serving_node, weight_function
from .neighbours import GatherCopies, copy_takes
from .space import Box2d, offset2d, wrap2d

#: the kernels that carry a step or a solve: bench/core/register_report.py holds them to its register budget
HOT_KERNELS = ("particle_fits", "deposit", "particle_field", "leapfrog_push")

#: a sort key is cell × CELL_KEY + particle id (ids are int32)
CELL_KEY = wp.constant(wp.int64(2 ** 31))


class MLSKernels:
    """The three kernels that evaluate MLS shape functions, compiled for one basis size (``basis_terms``: 3 linear,
    6 quadratic) so that the moment-matrix loops have constant bounds (``bench/results/pic_design.md``)."""

    def __init__(self, particle_fits, deposit, particle_field):
        self.particle_fits = particle_fits
        self.deposit = deposit
        self.particle_field = particle_field


_MLS_KERNELS: dict = {}


def mls_kernels(basis_terms: int, weight_kind: int = 0, rectangular: bool = False) -> MLSKernels:
    """:class:`MLSKernels` for ``basis_terms`` and the nodes' weight (``kernels/mls.py: weight_function``; cached:
    one compile per combination)."""
    key = (basis_terms, int(weight_kind), bool(rectangular))
    if key in _MLS_KERNELS:
        return _MLS_KERNELS[key]
    alg = ALGEBRA[basis_terms]
    node_weight = weight_function(weight_kind, rectangular)

    @wp.kernel
    def particle_fits(
        first: int,
        ns: NodeSet,
        position32: wp.array(dtype=wp.vec3),
        position: wp.array(dtype=wp.vec2d),
        inv_scale: wp.float64,
        fit: wp.array(dtype=MLSFit),
        count: wp.array(dtype=wp.int32),
    ):
        """The MLS fit of particle i over the nodes whose support holds it (``kernels/mls.py``: the same algebra as
        ``shape_functions``, in one pass: the basis is scaled by one length for every particle, 1/``inv_scale``, the
        nodes' mean support radius, where ``shape_functions`` takes each point's own mean; an MLS fit with a complete
        basis does not depend on that scale); ``count[i]``: those nodes (fewer than the basis terms: fit.rcond = 0)."""
        i = first + wp.tid()
        x = position[i]
        terms = wp.static(basis_terms)
        n = int(0)
        moments = alg.Moments()
        query = wp.hash_grid_query(ns.grid, position32[i], ns.reach)
        k = int(0)
        while wp.hash_grid_query_next(query, k):
            j = serving_node(ns, position32[i], x, k)
            if j < 0:
                continue
            d = offset2d(ns.box, x, ns.nodes[j])
            n += 1
            moments = alg.add_node(moments, node_weight(d, ns.support[j]), alg.local_basis(-d, inv_scale))
        count[i] = n
        if n < terms:
            empty = MLSFit()
            fit[i] = empty
            return
        fit[i] = alg.mls_fit(moments, inv_scale)

    @wp.kernel
    def deposit(
        first: int,
        ns: NodeSet,
        particles: GatherCopies,
        position32: wp.array(dtype=wp.vec3),
        position: wp.array(dtype=wp.vec2d),
        species: wp.array(dtype=wp.int32),
        macro_charge: wp.array(dtype=wp.float64),
        inv_scale: wp.float64,
        fit: wp.array(dtype=MLSFit),
        charge: wp.array(dtype=wp.float64),
    ):
        """Q_I = Σ_p q_p φ_I(x_p) (Marques 2008, eq. 4.4): node I gathers the particles in its support (``particles``:
        the HashGrid over the particles, cell = ``ns.reach``, and the nodes' periodic copies,
        ``warpfree.neighbours.GatherGrid``); q_p = ``macro_charge[species[p]]``. In a periodic box the node queries
        at each of its copies and takes a particle from the copy within reach of it (``copy_takes``): no particle is
        counted twice, and the particles need no images."""
        i = first + wp.tid()
        xi = ns.nodes[i]
        q = wp.float64(0.0)
        for s in range(particles.start[i], particles.start[i + 1]):
            at = ns.nodes32[i] + particles.shift[s]
            query = wp.hash_grid_query(particles.grid, at, ns.reach)
            p = int(0)
            while wp.hash_grid_query_next(query, p):
                if not copy_takes(particles, at, position32[p]):
                    continue
                d = offset2d(ns.box, position[p], xi)
                if not inside_support(ns.params, d, ns.support[i]):
                    continue
                phi = alg.shape(fit[p], node_weight(d, ns.support[i]), alg.local_basis(-d, inv_scale))
                q = q + macro_charge[species[p]] * phi
        charge[i] = q

    @wp.kernel
    def particle_field(
        first: int,
        ns: NodeSet,
        position32: wp.array(dtype=wp.vec3),
        position: wp.array(dtype=wp.vec2d),
        inv_scale: wp.float64,
        fit: wp.array(dtype=MLSFit),
        potential: wp.array(dtype=wp.float64),
        nodal_field: wp.array(dtype=wp.vec2d),
        interpolate: int,
        field: wp.array(dtype=wp.vec2d),
    ):
        """E at particle p with its stored fit: ``interpolate`` 0: E(x_p) = -Σ_I u_I ∇φ_I(x_p) (Marques 2008, eq. 4.5, the
        energy-conserving gather); 1: E(x_p) = Σ_I φ_I(x_p) E_I from nodal fields E_I (the momentum-conserving gather,
        ``warpfree.solvers.pic.field``)."""
        i = first + wp.tid()
        x = position[i]
        zero = wp.float64(0.0)
        ex = zero
        ey = zero
        query = wp.hash_grid_query(ns.grid, position32[i], ns.reach)
        k = int(0)
        while wp.hash_grid_query_next(query, k):
            j = serving_node(ns, position32[i], x, k)
            if j < 0:
                continue
            d = offset2d(ns.box, x, ns.nodes[j])
            w = node_weight(d, ns.support[j])
            p = alg.local_basis(-d, inv_scale)
            if interpolate != 0:
                phi = alg.shape(fit[i], w, p)
                ex = ex + phi * nodal_field[j][0]
                ey = ey + phi * nodal_field[j][1]
            else:
                v = alg.shape_value(fit[i], w, p)
                ex = ex - potential[j] * v[1]
                ey = ey - potential[j] * v[2]
        field[i] = wp.vec2d(ex, ey)

    _MLS_KERNELS[key] = MLSKernels(particle_fits, deposit, particle_field)
    return _MLS_KERNELS[key]


@wp.func
def boris_velocity(v: wp.vec2d, qm: wp.float64, e: wp.vec2d, bz: wp.float64, dt: wp.float64) -> wp.vec2d:
    """v advanced by Δt under E (in the plane) and a uniform B = bz ẑ (Boris 1970): half an electric kick, a
    rotation by 2 atan(q bz Δt / 2m) (|v| kept exactly), the other half kick. bz = 0: v + (q/m) E Δt."""
    if bz == wp.float64(0.0):
        return v + qm * dt * e
    half = wp.float64(0.5) * qm * dt
    minus = v + half * e
    t = half * bz
    # v' = v⁻ + v⁻ × t ẑ, v⁺ = v⁻ + v' × s ẑ with s = 2t/(1 + t²); (a × c ẑ) = (a_y c, -a_x c)
    prime = wp.vec2d(minus[0] + minus[1] * t, minus[1] - minus[0] * t)
    s = wp.float64(2.0) * t / (wp.float64(1.0) + t * t)
    plus = wp.vec2d(minus[0] + prime[1] * s, minus[1] - prime[0] * s)
    return plus + half * e


@wp.struct
class SpeciesTable:
    """Per species (a particle's ``species`` indexes it): q/m and the macro-particle's mass M."""

    charge_over_mass: wp.array(dtype=wp.float64)
    macro_mass: wp.array(dtype=wp.float64)


@wp.struct
class ParticleArrays:
    """The particles' slots as kernels read them: float64 ``position`` and ``velocity``, ``species``,
    ``particle_id``, the float32 ``position32`` the HashGrid queries take, and ``exit_wall`` (w + 1 for a particle
    that left through wall w: the box's four, then a region's boundary groups; 0 inside; one past the last wall for
    an injected particle another rank holds, which this rank drops)."""

    position: wp.array(dtype=wp.vec2d)
    velocity: wp.array(dtype=wp.vec2d)
    species: wp.array(dtype=wp.int32)
    particle_id: wp.array(dtype=wp.int32)
    position32: wp.array(dtype=wp.vec3)
    exit_wall: wp.array(dtype=wp.int32)


@wp.struct
class PushParams:
    """The push's constants: the ``box``, the static ``magnetic_field`` B_z, the step ``dt`` and what each wall does
    with a particle that reaches it (``absorb[w]``: 1 absorbs, 0 reflects; w = 2 axis + side)."""

    box: Box2d
    magnetic_field: wp.float64
    dt: wp.float64
    absorb: wp.array(dtype=wp.int32)


@wp.kernel
def kick(
    first: int,
    table: SpeciesTable,
    particles: ParticleArrays,
    field: wp.array(dtype=wp.vec2d),
    bz: wp.float64,
    dt: wp.float64,
):
    """v advanced by Δt without moving the particle (:func:`boris_velocity`); Δt = -Δt/2 gives the leapfrog's
    half-step start v^{-1/2} (Marques 2008, §2.2.3)."""
    i = first + wp.tid()
    velocity = particles.velocity
    velocity[i] = boris_velocity(velocity[i], table.charge_over_mass[particles.species[i]], field[i], bz, dt)


@wp.kernel
def leapfrog_push(
    first: int,
    push: PushParams,
    table: SpeciesTable,
    particles: ParticleArrays,
    field: wp.array(dtype=wp.vec2d),
    kinetic: wp.array(dtype=wp.float64),
    momentum: wp.array(dtype=wp.vec2d),
):
    """v^{n+1/2} = v^{n-1/2} + (q/m) E^n Δt (Boris with the magnetic field B_z); x^{n+1} = x^n + v^{n+1/2} Δt,
    wrapped along periodic axes (eqs 2.21 / 4.7). At the walls of the other axes: ``push.absorb[w]`` 0 reflects the
    particle (position and velocity), 1 absorbs it: ``exit_wall[i]`` = w + 1 (w = 2 axis + side, side 0 lower, 1
    upper; 0: still inside) and the particle is left where it landed, for the next sort to drop. Writes the
    time-centred kinetic energy ½ M (|v^{n-1/2}|² + |v^{n+1/2}|²)/2 and momentum M (v^{n-1/2} + v^{n+1/2})/2 at time
    n (M: the macro-particle's mass)."""
    i = first + wp.tid()
    box = push.box
    dt = push.dt
    absorb = push.absorb
    position = particles.position
    velocity = particles.velocity
    s = particles.species[i]
    old = velocity[i]
    new = boris_velocity(old, table.charge_over_mass[s], field[i], push.magnetic_field, dt)
    x = position[i] + dt * new
    m = table.macro_mass[s]
    kinetic[i] = wp.float64(0.25) * m * (wp.dot(old, old) + wp.dot(new, new))
    momentum[i] = wp.float64(0.5) * m * (old + new)
    left = int(0)
    for a in range(2):
        if box.periodic[a] == wp.float64(0.0):
            lo = box.lower[a]
            hi = lo + box.length[a]
            side = int(-1)
            if x[a] < lo:
                side = 0
            elif x[a] >= hi:
                side = 1
            if side >= 0:
                w = 2 * a + side
                if absorb[w] != 0:
                    if left == 0:
                        left = w + 1
                elif side == 0:
                    x[a] = wp.float64(2.0) * lo - x[a]
                    new[a] = -new[a]
                else:
                    x[a] = wp.float64(2.0) * hi - x[a]
                    new[a] = -new[a]
    if left == 0:
        x = wrap2d(box, x)
    particles.exit_wall[i] = left
    velocity[i] = new
    position[i] = x
    particles.position32[i] = wp.vec3(float(x[0]), float(x[1]), 0.0)


@wp.struct
class WallSource:
    """A wall source (``warpfree.solvers.pic.injection``): its species index, random ``seed``, ``inward`` +1 (lower
    wall, emits along +y) or -1 (upper), the cold beam's ``normal_speed``, the thermal source's ``thermal_speed`` (0:
    cold) and the drift along the wall ``drift_x``."""

    species: int
    seed: int
    inward: wp.float64
    normal_speed: wp.float64
    thermal_speed: wp.float64
    drift_x: wp.float64


@wp.kernel
def inject_particles(
    first: int,
    box: Box2d,
    source: WallSource,
    slot0: int,
    id0: int,
    dt: wp.float64,
    particles: ParticleArrays,
):
    """New particle i of a wall ``source`` into slot ``slot0`` + i with id ``id0`` + i: x uniform along the wall, v_n
    = the cold beam's normal speed or v_th sqrt(-2 ln U) (thermal: the flux-weighted half-Maxwellian), v_x = the
    drift along the wall (+ v_th N(0, 1) when thermal), a depth v_n Δt U inside the wall. Counter-based random
    numbers (the source's seed, the id): the same particles for any thread count. One that would land beyond the
    opposite wall is marked absorbed there."""
    i = first + wp.tid()
    slot = slot0 + i
    pid = id0 + i
    inward = source.inward
    rng = wp.rand_init(source.seed, pid)
    along = wp.float64(wp.randf(rng))
    depth = wp.float64(wp.randf(rng))
    vn = source.normal_speed
    vx = source.drift_x
    if source.thermal_speed > wp.float64(0.0):
        u = wp.float64(1.0) - wp.float64(wp.randf(rng))   # (0, 1]
        vn = source.thermal_speed * wp.sqrt(wp.float64(-2.0) * wp.log(u))
        vx = vx + source.thermal_speed * wp.float64(wp.randn(rng))
    lo = box.lower[1]
    hi = lo + box.length[1]
    wall = lo
    far = 4  # exit code of the upper wall (w = 2·1 + 1, + 1)
    if inward < wp.float64(0.0):
        wall = hi
        far = 3
    y = wall + inward * vn * dt * depth
    x = wp.vec2d(box.lower[0] + box.length[0] * along, y)
    left = int(0)
    if y < lo or y >= hi:
        left = far
    particles.position[slot] = x
    particles.velocity[slot] = wp.vec2d(vx, inward * vn)
    particles.species[slot] = source.species
    particles.particle_id[slot] = pid
    particles.position32[slot] = wp.vec3(float(x[0]), float(x[1]), 0.0)
    particles.exit_wall[slot] = left


@wp.kernel
def cell_keys(
    first: int,
    box: Box2d,
    inv_cell: wp.float64,
    cells_x: int,
    dead_key: int,
    exit_wall: wp.array(dtype=wp.int32),
    position: wp.array(dtype=wp.vec2d),
    particle_id: wp.array(dtype=wp.int32),
    keys: wp.array(dtype=wp.int64),
    values: wp.array(dtype=wp.int32),
):
    """Sort key of particle i: its cell (side 1/``inv_cell``) in row-major order, then its id (``CELL_KEY`` ×
    cell + id), so that particles sharing nodes sit together in memory (the deposit's node gather reads them) in an
    order that depends on their positions and ids alone, not on the order before (a part of the particles, as a rank
    of a distributed run holds them, sorts into the order they have among all); an absorbed particle (``exit_wall``
    w + 1 > 0; one past the last wall: another rank's) gets cell ``dead_key`` + w, past every cell: the sort moves it
    to the end, grouped by wall."""
    i = first + wp.tid()
    values[i] = i
    cell = int(0)
    if exit_wall[i] > 0:
        cell = dead_key + exit_wall[i] - 1
    else:
        d = position[i] - box.lower
        cx = int(wp.floor(d[0] * inv_cell))
        cy = int(wp.floor(d[1] * inv_cell))
        cell = cy * cells_x + cx
    keys[i] = wp.int64(cell) * CELL_KEY + wp.int64(particle_id[i])


@wp.kernel
def count_live(
    first: int,
    total: int,
    dead_key: int,
    keys: wp.array(dtype=wp.int64),
    live: wp.array(dtype=wp.int32),
):
    """After the sort: live[0] = the number of keys whose cell is below ``dead_key`` (the one slot where live ends
    writes it; ``live`` must hold 0 beforehand for the case of none)."""
    i = first + wp.tid()
    dead = wp.int64(dead_key) * CELL_KEY
    if keys[i] < dead:
        if i + 1 == total:
            live[0] = total
        elif keys[i + 1] >= dead:
            live[0] = i + 1


@wp.kernel
def permute_particles(
    first: int,
    order: wp.array(dtype=wp.int32),
    source: ParticleArrays,
    target: ParticleArrays,
):
    """Slot i of ``target`` takes particle order[i] of ``source`` (a gather: each thread writes only slot i), and
    target's float32 positions follow."""
    i = first + wp.tid()
    j = order[i]
    x = source.position[j]
    target.position[i] = x
    target.velocity[i] = source.velocity[j]
    target.species[i] = source.species[j]
    target.particle_id[i] = source.particle_id[j]
    target.position32[i] = wp.vec3(float(x[0]), float(x[1]), 0.0)


@wp.kernel
def flag_bad_particles(
    first: int,
    terms: int,
    rcond_limit: wp.float64,
    count: wp.array(dtype=wp.int32),
    fit: wp.array(dtype=MLSFit),
    velocity: wp.array(dtype=wp.vec2d),
    flags: wp.array(dtype=wp.int32),
):
    """flags[i] = 1 when particle i's MLS fit is ill-posed (fewer nodes than basis terms, or a scaled pivot below
    ``rcond_limit``) or its velocity is not finite: the step's check reduces these on the device (one read)."""
    i = first + wp.tid()
    v = velocity[i]
    bad = count[i] < terms or not (fit[i].rcond >= rcond_limit)
    if not (wp.isfinite(v[0]) and wp.isfinite(v[1])):
        bad = True
    flags[i] = int(bad)


# --- a region's boundary: particles crossing it are absorbed or reflected -----------------------------------------


@wp.struct
class RegionBoundary:
    """A region's boundary as chords (``warpfree.solvers.pic.boundary``): chord k runs from ``chord_start[k]`` to
    ``chord_end[k]`` (within 1e-7 of the exact curve), belongs to group ``chord_group[k]``, whose particles are
    absorbed (``group_absorbs[g]`` 1: ``exit_wall`` = ``first_exit`` + g) or reflected specularly (0); a uniform grid of
    ``cells_x`` × ``cells_y`` cells of side ``cell`` from ``lower`` lists each cell's chords (``cell_start``,
    ``cell_chords``: CSR)."""

    chord_start: wp.array(dtype=wp.vec2d)
    chord_end: wp.array(dtype=wp.vec2d)
    chord_group: wp.array(dtype=wp.int32)
    group_absorbs: wp.array(dtype=wp.int32)
    lower: wp.vec2d
    cell: wp.float64
    cells_x: int
    cells_y: int
    cell_start: wp.array(dtype=wp.int32)
    cell_chords: wp.array(dtype=wp.int32)
    first_exit: int


@wp.func
def cell_range(boundary: RegionBoundary, lo: wp.float64, hi: wp.float64, axis: int, cells: int) -> wp.vec2i:
    """The cells [first, last] along ``axis`` that [lo, hi] overlaps, clamped to the grid (first > last: none)."""
    a = int(wp.floor((lo - boundary.lower[axis]) / boundary.cell))
    b = int(wp.floor((hi - boundary.lower[axis]) / boundary.cell))
    return wp.vec2i(wp.max(a, 0), wp.min(b, cells - 1))


@wp.func
def first_crossing(boundary: RegionBoundary, a: wp.vec2d, b: wp.vec2d, skip: int) -> wp.vec2d:
    """(t, chord) of the first chord the segment a -> b crosses at a + t (b - a), 0 < t <= 1 (chord ``skip``
    excluded: the one just reflected from); (2, -1) if none. Crossing: t and s in [0, 1] of d × e ≠ 0, d = b - a,
    e = the chord."""
    d = b - a
    best_t = wp.float64(2.0)
    best = int(-1)
    xs = cell_range(boundary, wp.min(a[0], b[0]), wp.max(a[0], b[0]), 0, boundary.cells_x)
    ys = cell_range(boundary, wp.min(a[1], b[1]), wp.max(a[1], b[1]), 1, boundary.cells_y)
    for cy in range(ys[0], ys[1] + 1):
        for cx in range(xs[0], xs[1] + 1):
            c = cy * boundary.cells_x + cx
            for j in range(boundary.cell_start[c], boundary.cell_start[c + 1]):
                k = boundary.cell_chords[j]
                if k == skip:
                    continue
                p = boundary.chord_start[k]
                e = boundary.chord_end[k] - p
                denom = d[0] * e[1] - d[1] * e[0]
                if denom == wp.float64(0.0):
                    continue
                w = p - a
                t = (w[0] * e[1] - w[1] * e[0]) / denom
                s = (w[0] * d[1] - w[1] * d[0]) / denom
                if t > wp.float64(0.0) and t <= wp.float64(1.0) and s >= wp.float64(0.0) and s <= wp.float64(1.0):
                    if t < best_t:
                        best_t = t
                        best = k
    return wp.vec2d(best_t, wp.float64(best))


@wp.kernel
def cross_boundary(
    first: int,
    boundary: RegionBoundary,
    dt: wp.float64,
    particles: ParticleArrays,
):
    """After the push (x^{n+1} = x^n + v^{n+1/2} Δt): the step's path x^n -> x^{n+1} (x^n = x^{n+1} - v^{n+1/2} Δt)
    against the region's boundary. At the first chord it crosses the particle is absorbed (``exit_wall`` = the
    chord's group's code, left where it landed for the sort to drop) or reflected specularly: x mirrored across the
    chord's line, v's normal component reversed, and the rest of the path tested again (up to 4 reflections; a
    fifth crossing absorbs it into that chord's group, counted). Particles the push already took out are left."""
    i = first + wp.tid()
    if particles.exit_wall[i] != 0:
        return
    x = particles.position[i]
    v = particles.velocity[i]
    a = x - dt * v
    skip = int(-1)
    moved = int(0)
    for bounce in range(5):
        hit = first_crossing(boundary, a, x, skip)
        k = int(hit[1])
        if k < 0:
            break
        g = boundary.chord_group[k]
        if boundary.group_absorbs[g] != 0 or bounce == 4:
            particles.exit_wall[i] = boundary.first_exit + g
            break
        e = boundary.chord_end[k] - boundary.chord_start[k]
        n = wp.normalize(wp.vec2d(-e[1], e[0]))
        crossing = a + hit[0] * (x - a)
        x = x - wp.float64(2.0) * wp.dot(x - crossing, n) * n
        v = v - wp.float64(2.0) * wp.dot(v, n) * n
        a = crossing
        skip = k
        moved = 1
    if moved != 0:
        particles.position[i] = x
        particles.velocity[i] = v
        particles.position32[i] = wp.vec3(float(x[0]), float(x[1]), 0.0)


@wp.struct
class SurfaceSourceArrays:
    """A source on a region's boundary (``warpfree.solvers.pic.emission``): its chords (``chord_start`` to
    ``chord_end``, on the exact curve to 1e-7, ``inward`` the unit normal into the region), the cumulative share of the
    step's particles up to each chord (``share``: 0 to 1, one more entry than chords), the step's particle ``count``,
    the species index, random ``seed``, the emission ``normal_speed`` (cold) or ``thermal_speed`` (> 0: a
    half-Maxwellian flux) and the ``inset`` every particle starts at least this far inside (beyond the chords'
    distance from the curve)."""

    chord_start: wp.array(dtype=wp.vec2d)
    chord_end: wp.array(dtype=wp.vec2d)
    inward: wp.array(dtype=wp.vec2d)
    share: wp.array(dtype=wp.float64)
    chords: int
    count: int
    species: int
    seed: int
    normal_speed: wp.float64
    thermal_speed: wp.float64
    inset: wp.float64


@wp.kernel
def emit_from_surface(
    first: int,
    source: SurfaceSourceArrays,
    slot0: int,
    id0: int,
    dt: wp.float64,
    particles: ParticleArrays,
):
    """New particle i of the step's n from a surface ``source`` into slot ``slot0`` + i with id ``id0`` + i: stratified
    over the chords' shares, its place s = (i + U)/n on the cumulative share (a binary search finds the chord, the
    share left over places it along it), v = v_n n_in (v_n the cold speed, or v_th sqrt(-2 ln U) from the
    flux-weighted half-Maxwellian, with a tangential v_th N(0, 1)), started ``inset`` + v_n Δt U inside the surface (a
    uniformly random time within the step). Counter-based random numbers (the source's seed, the id): the same
    particles for any thread count."""
    i = first + wp.tid()
    slot = slot0 + i
    pid = id0 + i
    rng = wp.rand_init(source.seed, pid)
    place = (wp.float64(i) + wp.float64(wp.randf(rng))) / wp.float64(source.count)
    lo = int(0)
    hi = source.chords
    while hi - lo > 1:  # the last k with share[k] <= place
        mid = (lo + hi) // 2
        if source.share[mid] <= place:
            lo = mid
        else:
            hi = mid
    k = lo
    width = source.share[k + 1] - source.share[k]
    along = wp.float64(0.5)
    if width > wp.float64(0.0):
        along = wp.min(wp.max((place - source.share[k]) / width, wp.float64(0.0)), wp.float64(1.0))
    depth = wp.float64(wp.randf(rng))
    normal = source.inward[k]
    tangent = wp.vec2d(normal[1], -normal[0])
    vn = source.normal_speed
    vt = wp.float64(0.0)
    if source.thermal_speed > wp.float64(0.0):
        u = wp.float64(1.0) - wp.float64(wp.randf(rng))   # (0, 1]
        vn = source.thermal_speed * wp.sqrt(wp.float64(-2.0) * wp.log(u))
        vt = source.thermal_speed * wp.float64(wp.randn(rng))
    p = source.chord_start[k] + along * (source.chord_end[k] - source.chord_start[k])
    x = p + (source.inset + vn * dt * depth) * normal
    particles.position[slot] = x
    particles.velocity[slot] = vn * normal + vt * tangent
    particles.species[slot] = source.species
    particles.particle_id[slot] = pid
    particles.position32[slot] = wp.vec3(float(x[0]), float(x[1]), 0.0)
    particles.exit_wall[slot] = 0
