"""Floating-point operations a Warp kernel does per work item, read from the C++ Warp generates for it.

How it counts
    Warp writes each kernel as C++ (its kernel cache holds it once the module is loaded): one statement per operation,
    ``var_7 = wp::mul(var_3, var_5);``, every variable declared with its type. Each statement whose result is
    floating-point counts the scalar operations it stands for: an add or mul of two vec3 is 3, a dot of vec3 5, a
    cross 9, a 3x3 matrix times a vec3 15, a length 6 (one of them a square root); square roots, divisions' reciprocal
    and transcendental functions (exp, log, pow, sin, ...) count one each and are also counted apart (``special``),
    since a GPU runs them on its slower special-function units. Integer and index arithmetic, loads, stores,
    comparisons and conversions count nothing. A called ``@wp.func`` counts its own statements at each call.

    A loop's body counts once per trip. Trips are resolved where the kernel states them: a constant range; a range
    bounded by integer arguments of the launch; or a neighbour row, ``range(rows.start[i], rows.start[i] +
    rows.count[i])`` or ``range(rows.count[i])``, whose trips are the mean count of the launch's rows (a row of
    candidates within radius + skin: the pairs the kernel visits). A loop none of these resolve (a hash-grid query)
    counts its body once and the kernel is marked ``unresolved``. A hash-grid loop's trips are the candidates its
    query returns at the launch's query points (counted by a kernel here), every one counted with the whole body: an
    upper bound by the candidates' share within the radius (about 2.9 in 2D, 6.4 in 3D for a cell of one radius).

    Both sides of a branch count (an upper bound where a branch skips work, e.g. a pair beyond the radius); float64
    operations are counted apart (an H100 runs them at half the float32 rate).

Used by ``bench/core/roofline.py``: operations per work item beside the bytes, the arithmetic intensity, and the
floor that is the larger of the bandwidth time and the arithmetic time.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

import numpy as np

#: element-wise operations: one scalar operation per component of the result
ELEMENTWISE = {"add", "sub", "neg", "mul", "div", "mod", "min", "max", "abs", "sign", "floor", "ceil", "round",
               "trunc", "cw_mul", "cw_div", "atomic_add", "atomic_sub", "atomic_min", "atomic_max", "step"}
#: special functions (one operation each per component, also counted apart)
SPECIAL = {"sqrt", "cbrt", "exp", "exp2", "log", "log2", "log10", "pow", "sin", "cos", "tan", "asin", "acos", "atan",
           "atan2", "sinh", "cosh", "tanh", "erf", "erfc", "rsqrt"}

_FLOAT_SCALARS = {"wp::float16": 16, "wp::float32": 32, "wp::float64": 64, "float": 32, "double": 64}
_DECL = re.compile(r"^\s*(?:const\s+)?((?:wp::)?\w+(?:<[^;=]*?>)?)\s+(var_\w+)\s*(?:=[^;]*)?[;,)]")
_CALL = re.compile(r"^\s*(?:(var_\w+)\s*=\s*)?(wp::)?(\w+)\((.*)\);\s*$")
_LABEL = re.compile(r"^\s*(start|end)_(for|while)_(\d+):;")
_CONST = re.compile(r"^\s*const\s+[\w:<>, ]+?\s+(var_\w+)\s*=\s*(-?[\d.eE+-]+);")
_FUNC_HEAD = re.compile(r"^static\s+(?:CUDA_CALLABLE\s+)?[\w:<>, ]+?\s+(\w+)\($")
_ROW_COMMENT = re.compile(r"for \w+ in range\((?:([\w.]+)\.start\[\w+\],\s*\1\.start\[\w+\]\s*\+\s*)?([\w.]+)\.count\[\w+\]\)")
_CSR_COMMENT = re.compile(r"for \w+ in range\(([\w.]+)\.start\[\w+\],\s*\1\.start\[\w+ \+ 1\]\)")
_RANGE_COMMENT = re.compile(r"for \w+ in range\(([\w.]+)\):$")


@dataclass
class Type:
    """A variable's type: components and float bits (0: not floating-point); rows x cols for a matrix."""

    components: int = 1
    bits: int = 0
    rows: int = 1
    cols: int = 1


def parse_type(text: str) -> Type:
    """The :class:`Type` of a C++ type Warp emits (``wp::vec_t<3, wp::float32>``, ``wp::mat_t<3, 3, wp::float64>``,
    ``wp::float32``; anything else: not floating-point)."""
    text = text.strip()
    if text in _FLOAT_SCALARS:
        return Type(1, _FLOAT_SCALARS[text])
    m = re.match(r"wp::(vec_t|mat_t|quat_t|transform_t)<(.*)>$", text)
    if not m:
        return Type(1, 0)
    parts = [p.strip() for p in m.group(2).split(",")]
    bits = _FLOAT_SCALARS.get(parts[-1], 0)
    if m.group(1) == "vec_t":
        return Type(int(parts[0]), bits, int(parts[0]), 1)
    if m.group(1) == "mat_t":
        r, c = int(parts[0]), int(parts[1])
        return Type(r * c, bits, r, c)
    return Type(4 if m.group(1) == "quat_t" else 7, bits)


@dataclass
class Count:
    """Operations: float32 and float64 (special functions included), special functions apart."""

    f32: float = 0.0
    f64: float = 0.0
    special: float = 0.0

    def add(self, other: "Count", times: float = 1.0) -> None:
        self.f32 += times * other.f32
        self.f64 += times * other.f64
        self.special += times * other.special

    @property
    def total(self) -> float:
        return self.f32 + self.f64


def statement_operations(name: str, out: Type | None, args: list[Type]) -> tuple[float, bool]:
    """(scalar operations, special?) of the builtin ``name`` with result type ``out`` and argument types ``args``."""
    first = args[0] if args else Type()
    if name == "mul" and len(args) == 2 and args[0].components > 1 and args[1].components > 1:
        a, b = args
        if a.cols > 1 and b.cols > 1:      # matrix x matrix
            return a.rows * b.cols * (2 * a.cols - 1), False
        if a.cols > 1:                     # matrix x vector
            return a.rows * (2 * a.cols - 1), False
        if b.cols > 1:                     # vector x matrix
            return b.cols * (2 * b.rows - 1), False
    n = out.components if out is not None else first.components
    if name.startswith("atomic_") and len(args) >= 3:  # atomic_add(array, index, value): the value's components
        n = args[-1].components
    if name in ELEMENTWISE:
        return n, False
    if name in SPECIAL:
        return n, True
    k = first.components
    table = {"dot": 2 * k - 1, "ddot": 2 * k - 1, "length_sq": 2 * k - 1, "length": 2 * k, "normalize": 3 * k,
             "cross": 9, "outer": out.components if out is not None else 0, "trace": first.rows - 1,
             "determinant": {4: 3, 9: 14}.get(k, k * k), "inverse": {4: 8, 9: 45}.get(k, 2 * k * first.rows),
             "lerp": 3 * n, "clamp": 2 * n, "mul_add": 2 * n, "fma": 2 * n}
    ops = table.get(name, 0)
    return ops, name in ("length", "normalize", "inverse")


@dataclass
class Loop:
    """A loop of the generated code: its own statements' count, the loops inside it, how its trips are stated."""

    header: str = ""            # the Python line it came from (the comment Warp writes above it)
    iterator: str = ""          # the iterator variable (``wp::range`` or a query)
    init: str = ""              # the statement that made the iterator
    constant: tuple | None = None
    query: str | None = None    # a hash-grid query's arguments (grid, point, radius), as the Python line wrote them
    own: Count = field(default_factory=Count)
    inner: list = field(default_factory=list)


@dataclass
class Function:
    """A generated function (a kernel's forward body or a ``@wp.func``): its outermost block as a :class:`Loop`."""

    name: str
    types: dict
    body: Loop
    arguments: list


def _split_args(text: str) -> list[str]:
    out, depth, cur = [], 0, ""
    for ch in text:
        if ch in "(<":
            depth += 1
        elif ch in ")>":
            depth -= 1
        if ch == "," and depth == 0:
            out.append(cur.strip())
            cur = ""
        else:
            cur += ch
    if cur.strip():
        out.append(cur.strip())
    return out


def _parse_function(name: str, lines: list[str], functions: dict) -> Function:
    """Declarations, then the forward statements grouped into loops (``start_for_N`` ... ``end_for_N``)."""
    types, consts = {}, {}
    for line in lines:
        m = _DECL.match(line)
        if m:
            types[m.group(2)] = parse_type(m.group(1))
        c = _CONST.match(line)
        if c:
            consts[c.group(1)] = float(c.group(2))
    body = Loop(header="(kernel)")
    stack, comment, last_assign, queries, aliases = [body], "", {}, {}, {}
    forward = False
    for line in lines:
        s = line.strip()
        if s == "// forward":
            forward = True
            continue
        if not forward:
            continue
        if s.startswith("//"):
            comment = s[2:].split("<L")[0].strip()
            q = re.match(r"(\w+) = wp\.hash_grid_query\((.*)\)$", comment)
            if q:
                queries[q.group(1)] = q.group(2)
            alias = re.match(r"(\w+) = ([A-Za-z_][\w.]*)$", comment)  # a local naming an argument's field
            if alias:
                aliases[alias.group(1)] = alias.group(2)
            continue
        lab = _LABEL.match(s)
        if lab:
            if lab.group(1) == "start":
                loop = Loop(header=comment)
                inline = re.match(r"for \w+ in wp\.hash_grid_query\((.*)\):$", comment)
                named = re.match(r"while wp\.hash_grid_query_next\((\w+), \w+\):$", comment)
                loop.query = inline.group(1) if inline else (queries.get(named.group(1)) if named else None)
                stack[-1].inner.append(loop)
                stack.append(loop)
            else:
                stack.pop()
            continue
        top = stack[-1]
        if s.startswith("if (") and "goto end_" in s:  # a loop's exit test: its iterator, or a constant bound
            m = re.match(r"if \(iter_cmp\((var_\w+)\) == 0\)", s)
            if m:
                top.iterator = m.group(1)
                top.init = last_assign.get(m.group(1), "")
            else:
                m = re.match(r"if \((var_\w+) (>=|<=) (-?[\w.]+)\)", s)
                if m:
                    start = consts.get(last_assign.get(m.group(1), "").split("=")[-1].strip(" ;"), None)
                    raw = last_assign.get(m.group(1), "").split("=")[-1].strip(" ;")
                    try:
                        start = float(raw)
                    except ValueError:
                        pass
                    stop = consts.get(m.group(3))
                    try:
                        stop = float(m.group(3)) if stop is None else stop
                    except ValueError:
                        stop = None
                    if start is not None and stop is not None:
                        top.constant = (start, stop)
            continue
        m = re.match(r"^(var_\w+)\s*=\s*(.*);$", s)
        if m:
            last_assign[m.group(1)] = s
        call = _CALL.match(s)
        if not call:
            continue
        out_var, is_builtin, fname, argtext = call.groups()
        args = [types.get(a, Type()) for a in _split_args(argtext)]
        out = types.get(out_var) if out_var else None
        if is_builtin:
            ops, special = statement_operations(fname, out, args)
            result = out if out is not None and out.bits else next((a for a in args[::-1] if a.bits), None)
            if fname.startswith("atomic_") and args:
                result = args[-1]
            if ops and result is not None and result.bits:
                if result.bits == 64:
                    top.own.f64 += ops
                else:
                    top.own.f32 += ops
                if special:
                    top.own.special += ops if fname in SPECIAL else 1
        elif fname in functions:
            top.own.add(total(functions[fname].body, {}, {}))
    fn = Function(name, types, body, [])
    fn.consts, fn.aliases = consts, aliases
    return fn


def total(loop: Loop, trips: dict, _unused: dict, unresolved: list | None = None) -> Count:
    """A loop's operations: its own plus each inner loop's times that loop's trips (``trips``: id(loop) -> trips;
    a loop without one counts once and is added to ``unresolved``)."""
    out = Count()
    out.add(loop.own)
    for inner in loop.inner:
        t = trips.get(id(inner))
        if t is None:
            t = 1.0
            if unresolved is not None:
                unresolved.append(inner.header)
        out.add(total(inner, trips, _unused, unresolved), t)
    return out


@lru_cache(maxsize=None)
def _parse_source(path: str) -> dict:
    """Every generated function of a module's C++ (kernels' forward bodies, ``@wp.func`` primal bodies)."""
    text = Path(path).read_text().splitlines()
    bodies: dict[str, list[str]] = {}
    k = 0
    while k < len(text):
        line = text[k]
        m = _FUNC_HEAD.match(line)
        fwd = re.match(r"^static void (\w+)_cpu_kernel_forward\($", line)
        name = None
        if fwd:
            name = fwd.group(1) + "::kernel"
        elif m and not m.group(1).startswith("adj_") and "kernel_backward" not in line:
            name = m.group(1)
        if name is None:
            k += 1
            continue
        j = k + 1
        while j < len(text) and text[j] != "}":
            j += 1
        bodies[name] = text[k:j + 1]
        k = j + 1
    functions: dict[str, Function] = {}
    for name in [n for n in bodies if not n.endswith("::kernel")]:  # functions first (a kernel calls them)
        functions[name] = _parse_function(name, bodies[name], functions)
    kernels = {n[:-8]: _parse_function(n, b, functions) for n, b in bodies.items() if n.endswith("::kernel")}
    return kernels


def kernel_source(kernel) -> Path | None:
    """The C++ file of the kernel's module in Warp's kernel cache (the module loaded for the CPU)."""
    import warp as wp

    cache = Path(wp.config.kernel_cache_dir)
    ident = kernel.module.get_module_identifier()
    path = cache / ident / f"{ident}.cpp"
    if path.exists():
        return path
    mangled = kernel.get_mangled_name()
    for p in cache.glob("wp_*/*.cpp"):  # a module whose identifier moved (rebuilt options): find the kernel
        if f"static void {mangled}_cpu_kernel_forward(" in p.read_text():
            return p
    return None


def _int_value(value):
    return int(value) if isinstance(value, (int, np.integer)) and not isinstance(value, bool) else None


def _row_counts(value, items: int):
    """Mean count over a NeighbourRows-like struct's first ``items`` rows (its ``count`` array), or None."""
    count = getattr(value, "count", None)
    if count is None or not hasattr(count, "numpy"):
        return None
    c = count.numpy()
    if c.size == 0:
        return 0.0
    return float(np.mean(c[: min(items, c.size)])) if items else float(np.mean(c))


def _lookup(path: str, values: dict, aliases: dict | None = None):
    """The launch value an argument path names (``rows``, ``ns.grid``, ``penalty.solids.count``; a local the kernel
    set to such a path, through ``aliases``), or None."""
    head, *rest = path.split(".")
    for _ in range(8):
        if aliases and head in aliases and head not in values:
            head, *more = aliases[head].split(".")
            rest = more + rest
    head, *rest = ".".join([head, *rest]).split(".")
    value = values.get(head)
    for name in rest:
        value = getattr(value, name, None)
    return value


def _trips_from_header(header: str, values: dict, items: int, aliases: dict) -> float | None:
    """A loop's mean trips read from its Python line: a neighbour row, a CSR row or an integer of the launch."""
    rows = _ROW_COMMENT.search(header)
    if rows:
        return _row_counts(_lookup(rows.group(2), values, aliases), items)
    csr = _CSR_COMMENT.search(header)
    if csr:
        start = getattr(_lookup(csr.group(1), values, aliases), "start", None)
        if start is not None and hasattr(start, "numpy"):
            s = start.numpy().astype(np.int64)
            m = min(items, s.size - 1)
            return float(np.mean(np.diff(s[: m + 1]))) if m > 0 else 0.0
    plain = _RANGE_COMMENT.search(header)
    if plain:
        n = _int_value(_lookup(plain.group(1), values, aliases))
        return None if n is None else float(max(n, 0))
    return None


def _query_trips(query: str, values: dict, items: int, aliases: dict) -> float | None:
    """A hash-grid loop's mean trips: the candidates its query returns at each of the launch's query points
    (``grid, points[i], radius`` with each an argument path), counted by :func:`count_candidates`."""
    import warp as wp

    args = _split_args(query)
    if len(args) != 3:
        return None
    point = re.match(r"^([\w.]+)\[i\]$", args[1])
    grid, radius = _lookup(args[0], values, aliases), _lookup(args[2], values, aliases)
    points = _lookup(point.group(1), values, aliases) if point else None
    if grid is None or radius is None or not isinstance(points, wp.array) or points.dtype != wp.vec3:
        return None
    n = min(items, points.shape[0])
    if n == 0:
        return 0.0
    counts = wp.zeros(n, dtype=wp.int32, device=points.device)
    wp.launch(count_candidates, dim=n, inputs=[wp.uint64(int(grid)), points, float(radius), counts],
              device=points.device)
    return float(counts.numpy().mean())


def _candidates_kernel():
    import warp as wp

    @wp.kernel
    def count_candidates(grid: wp.uint64, points: wp.array(dtype=wp.vec3), radius: float,
                         counts: wp.array(dtype=wp.int32)):
        """counts[i] = the points a hash-grid query at points[i] returns (every candidate, as a loop visits them)."""
        i = wp.tid()
        n = int(0)
        for _k in wp.hash_grid_query(grid, points[i], radius):
            n += 1
        counts[i] = n

    return count_candidates


count_candidates = _candidates_kernel()


def kernel_operations(kernel, inputs: list, items: int) -> dict:
    """Operations per item of one launch of ``kernel(first, *inputs)`` over ``items`` items: ``{f32, f64, special,
    unresolved}`` (``unresolved``: the loops whose trips could not be read, each counted once)."""
    path = kernel_source(kernel)
    if path is None:
        return {"f32": math.nan, "f64": math.nan, "special": math.nan, "unresolved": ["(no generated source)"]}
    fn = _parse_source(str(path)).get(kernel.get_mangled_name())
    if fn is None:
        return {"f32": math.nan, "f64": math.nan, "special": math.nan, "unresolved": ["(kernel not in its source)"]}
    names = [a.label for a in kernel.adj.args]
    values = dict(zip(names, [0, *inputs]))
    trips: dict[int, float] = {}

    def resolve(loop: Loop) -> None:
        t = None
        if loop.constant is not None:
            t = max(0.0, loop.constant[1] - loop.constant[0])
        elif loop.init:
            m = re.search(r"wp::range\((.*)\);", loop.init)
            if m:
                bounds = []
                for a in _split_args(m.group(1)):
                    if a in fn.consts:
                        bounds.append(fn.consts[a])
                    elif a.startswith("var_") and _int_value(values.get(a[4:])) is not None:
                        bounds.append(float(values[a[4:]]))
                    else:
                        bounds.append(None)
                if len(bounds) == 1 and bounds[0] is not None:
                    t = max(0.0, bounds[0])
                elif len(bounds) >= 2 and None not in bounds[:2]:
                    step = bounds[2] if len(bounds) > 2 and bounds[2] else 1.0
                    t = max(0.0, math.ceil((bounds[1] - bounds[0]) / step))
            if t is None:
                t = _trips_from_header(loop.header, values, items, fn.aliases)
        if t is None and loop.query is not None:
            t = _query_trips(loop.query, values, items, fn.aliases)
        if t is not None:
            trips[id(loop)] = t
        for inner in loop.inner:
            resolve(inner)

    for inner in fn.body.inner:
        resolve(inner)
    unresolved: list[str] = []
    count = total(fn.body, trips, {}, unresolved)
    return {"f32": count.f32, "f64": count.f64, "special": count.special, "unresolved": sorted(set(unresolved))}
