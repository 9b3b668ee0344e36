"""The processes of a run: one (a plain run) or the ranks ``mpiexec -n N`` started, over MPI (mpi4py).

:func:`world` is what the rest of warpfree asks: ``world().size`` ranks, this one ``world().rank``. A run started
without ``mpiexec`` (or with one rank) gets a :class:`World` of one process that needs no MPI at all; a run started
by ``mpiexec`` with several ranks imports mpi4py, and refuses in one line naming the extra to install when it is
missing. Every collective a family needs is here, on NumPy arrays: reductions (:meth:`World.allreduce`), the rows
of every rank in rank order (:meth:`World.allgather`), a broadcast and the point-to-point exchange of the ghost
layers (:meth:`World.exchange`). Collectives are called by every rank in the same order; results are the same
on every rank (a reduction of floats is done in rank order on rank 0 and broadcast, so that every rank holds the
same bits).
"""

from __future__ import annotations

import os

import numpy as np

from warpfree.errors import ParameterError

__all__ = ["World", "world", "launched_ranks", "cuda_aware_mpi", "MPI_EXTRA", "CUDA_AWARE_VARIABLE"]

#: what to install for a distributed run
MPI_EXTRA = "pip install 'warpfree[mpi]'"
#: the environment variable that says whether the MPI library takes GPU memory: 1 (pass device buffers to MPI), 0
#: (stage them through pinned host memory); unset: ask the library (:func:`cuda_aware_mpi`)
CUDA_AWARE_VARIABLE = "WARPFREE_CUDA_AWARE_MPI"

#: environment variables an MPI launcher sets to the number of ranks (Open MPI, MPICH/Hydra and PMI, PMIx)
_SIZE_VARIABLES = ("OMPI_COMM_WORLD_SIZE", "PMI_SIZE", "MPI_LOCALNRANKS", "PMIX_SIZE")


def launched_ranks() -> int:
    """How many ranks an MPI launcher started (from its environment; 1 without one)."""
    for name in _SIZE_VARIABLES:
        value = os.environ.get(name, "")
        if value.isdigit() and int(value) > 1:
            return int(value)
    return 1


_cuda_aware: bool | None = None


def cuda_aware_mpi() -> bool:
    """Does the MPI library send and receive from GPU memory (is it CUDA-aware)? ``WARPFREE_CUDA_AWARE_MPI`` decides
    when set (1 or 0); otherwise Open MPI is asked (``MPIX_Query_cuda_support()``, its extension, looked up in the
    ``libmpi`` mpi4py loaded: 1 when the library was built with CUDA and its runtime supports CUDA buffers); any other
    MPI (MPICH, Cray MPICH, Intel MPI), or an Open MPI without the extension, counts as not CUDA-aware unless the
    variable says it is. Asked once per process, after MPI is initialised."""
    global _cuda_aware
    if _cuda_aware is None:
        setting = os.environ.get(CUDA_AWARE_VARIABLE, "").strip()
        if setting:
            if setting not in ("0", "1"):
                raise ParameterError(CUDA_AWARE_VARIABLE, f"must be 1 (the MPI library takes GPU memory) or 0, "
                                                          f"got {setting!r}")
            _cuda_aware = setting == "1"
        else:
            _cuda_aware = _open_mpi_cuda_support()
    return _cuda_aware


def _open_mpi_cuda_support() -> bool:
    """Open MPI's ``MPIX_Query_cuda_support()`` from the ``libmpi`` this process loaded (False where there is none)."""
    import ctypes

    try:
        with open("/proc/self/maps") as maps:
            libraries = sorted({line.split()[-1] for line in maps if "/libmpi.so" in line})
    except OSError:  # not Linux
        return False
    for path in libraries:
        try:
            query = ctypes.CDLL(path).MPIX_Query_cuda_support
        except (OSError, AttributeError):
            continue
        query.restype = ctypes.c_int
        return bool(query())
    return False


class World:
    """The ranks of a run. ``comm``: the mpi4py communicator (None for a run of one process)."""

    def __init__(self, comm=None):
        self.comm = comm
        self.size = 1 if comm is None else comm.Get_size()
        self.rank = 0 if comm is None else comm.Get_rank()

    @property
    def distributed(self) -> bool:
        """True when the run has more than one rank."""
        return self.size > 1

    @property
    def is_root(self) -> bool:
        """True on rank 0 (it writes the summary, the indices, frames and plots)."""
        return self.rank == 0

    def __repr__(self) -> str:
        return f"World(rank={self.rank}, size={self.size})"

    # -- collectives ---------------------------------------------------------------------------------
    def barrier(self) -> None:
        """Wait until every rank has arrived (nothing in one process)."""
        if self.comm is not None:
            self.comm.Barrier()

    def bcast(self, value, root: int = 0):
        """``value`` of rank ``root`` on every rank (any picklable object)."""
        return value if self.comm is None else self.comm.bcast(value, root=root)

    def allgather(self, rows: np.ndarray) -> list[np.ndarray]:
        """Every rank's ``rows`` (arrays of one dtype and trailing shape, any length), in rank order, on every rank."""
        rows = np.ascontiguousarray(rows)
        if self.comm is None:
            return [rows]
        from mpi4py import MPI

        counts = np.array(self.comm.allgather(rows.shape[0]), dtype=np.int64)
        width = int(np.prod(rows.shape[1:], dtype=np.int64)) * rows.dtype.itemsize
        out = np.empty((int(counts.sum()),) + rows.shape[1:], dtype=rows.dtype)
        sizes = counts * width
        displs = np.zeros_like(sizes)
        np.cumsum(sizes[:-1], out=displs[1:])
        self.comm.Allgatherv([rows.view(np.uint8).reshape(-1), MPI.BYTE],
                             [out.view(np.uint8).reshape(-1), (sizes, displs), MPI.BYTE])
        return np.split(out, np.cumsum(counts)[:-1])

    def allreduce(self, values, op: str = "sum") -> np.ndarray:
        """Elementwise ``op`` ("sum", "max", "min") of every rank's ``values`` (a NumPy array or number), the same
        bits on every rank: max and min are exact; a sum is taken in rank order on rank 0 and broadcast."""
        values = np.asarray(values)
        if values.dtype.kind in "iub":  # every rank the same integer type, whatever made its values
            values = values.astype(np.int64)
        if self.comm is None:
            return values.copy()
        if op in ("max", "min"):
            from mpi4py import MPI

            out = np.empty_like(values)
            self.comm.Allreduce(np.ascontiguousarray(values), out, op=MPI.MAX if op == "max" else MPI.MIN)
            return out
        if op != "sum":
            raise ValueError(f"allreduce: op must be sum, max or min, got {op!r}")
        parts = self.comm.gather(values, root=0)
        total = None
        if self.rank == 0:
            total = parts[0].copy()
            for part in parts[1:]:
                total = total + part
        return self.comm.bcast(total, root=0)

    def allreduce_in_place(self, array, op: str = "sum") -> None:
        """:meth:`allreduce` of a Warp (or NumPy) array, written back into it: nothing to do in one process (no copy,
        no device read)."""
        if self.comm is None:
            return
        values = array.numpy() if hasattr(array, "device") else array
        in_memory = not hasattr(array, "device") or array.device.is_cpu  # NumPy sees the array's own memory
        if op in ("max", "min") and in_memory and values.flags.c_contiguous and values.dtype.kind == "f":
            from mpi4py import MPI  # exact in any order: reduced where the values are, no copy

            self.comm.Allreduce(MPI.IN_PLACE, values, op=MPI.MAX if op == "max" else MPI.MIN)
            return
        reduced = self.allreduce(values, op).astype(values.dtype, copy=False)
        if hasattr(array, "device"):
            array.assign(reduced)
        else:
            array[...] = reduced

    def allreduce_matrix(self, matrix):
        """The sum of every rank's SciPy sparse ``matrix`` (one shape), entries added in rank order, as CSR on every
        rank: ``matrix`` itself in one process."""
        if self.comm is None:
            return matrix
        import scipy.sparse as sp

        coo = matrix.tocoo()
        rows = np.concatenate(self.allgather(coo.row.astype(np.int64)))
        cols = np.concatenate(self.allgather(coo.col.astype(np.int64)))
        data = np.concatenate(self.allgather(coo.data.astype(np.float64)))
        return sp.csr_matrix((data, (rows, cols)), shape=matrix.shape)

    def allgather_objects(self, value) -> list:
        """Every rank's ``value`` (any picklable object), in rank order, on every rank."""
        return [value] if self.comm is None else self.comm.allgather(value)

    def first_message(self, message: str | None) -> str | None:
        """The first rank's non-empty message (a problem one rank found), the same on every rank; None if none."""
        if self.comm is None:
            return message
        for m in self.comm.allgather(message):
            if m:
                return m
        return None

    def exchange(self, sends: dict[int, np.ndarray], receive_bytes: dict[int, int]) -> dict[int, np.ndarray]:
        """Point-to-point: ``sends[r]`` (uint8 buffers) to each rank r, and from each rank s the ``receive_bytes[s]``
        bytes it sends here (both sides know the sizes from their plan). Non-blocking, all at once."""
        if self.comm is None:
            return {}
        requests, received = [], {}
        for source, size in receive_bytes.items():
            buffer = np.empty(size, dtype=np.uint8)
            received[source] = buffer
            requests.append(self.comm.Irecv(buffer, source=source, tag=7))
        for dest, buffer in sends.items():
            requests.append(self.comm.Isend(np.ascontiguousarray(buffer), dest=dest, tag=7))
        if requests:
            from mpi4py import MPI

            MPI.Request.Waitall(requests)
        return received

    def persistent_exchange(self, sends: dict, receives: dict) -> "Messages":
        """The messages of an exchange repeated many times with the same buffers (``sends[r]`` to rank r, from each
        rank s into ``receives[s]``: uint8 NumPy arrays, or GPU arrays (``__cuda_array_interface__``) for a
        CUDA-aware MPI; their sizes agreed by both sides' plans), made once as persistent MPI requests:
        :meth:`Messages.start` and :meth:`Messages.wait` run them."""
        return Messages(self.comm, sends, receives)

    def exchange_sizes(self, sizes: dict[int, int]) -> dict[int, int]:
        """Each rank tells every other how many bytes (or items) it will send it: ``sizes[r]`` -> what each rank s
        will send here (only the nonzero ones)."""
        if self.comm is None:
            return {}
        row = np.zeros(self.size, dtype=np.int64)
        for r, n in sizes.items():
            row[r] = n
        matrix = np.empty((self.size, self.size), dtype=np.int64)
        self.comm.Allgather(row, matrix)
        return {s: int(matrix[s, self.rank]) for s in range(self.size) if matrix[s, self.rank] > 0}


class Messages:
    """Persistent point-to-point requests (:meth:`World.persistent_exchange`); no requests in one process."""

    TAG = 8

    def __init__(self, comm, sends: dict[int, np.ndarray], receives: dict[int, np.ndarray]):
        self.buffers = (sends, receives)         # the requests point into these
        self.requests = []
        if comm is None:
            return
        for source, buffer in receives.items():
            self.requests.append(comm.Recv_init(buffer, source=source, tag=self.TAG))
        for dest, buffer in sends.items():
            self.requests.append(comm.Send_init(buffer, dest=dest, tag=self.TAG))

    def start(self) -> None:
        """Start every persistent request of the exchange (the send buffers must hold their values)."""
        if self.requests:
            from mpi4py import MPI

            MPI.Prequest.Startall(self.requests)

    def wait(self) -> None:
        """Wait until every message started has been sent and received."""
        if self.requests:
            from mpi4py import MPI

            MPI.Request.Waitall(self.requests)

    def free(self) -> None:
        """Free the persistent requests."""
        for request in self.requests:
            request.Free()
        self.requests = []


def abort_on_error(code: int = 1) -> None:
    """In a distributed run, end every rank after an unexpected error on this one (which would otherwise leave
    the others waiting in a collective for ever)."""
    if _WORLD is not None and _WORLD.comm is not None:
        _WORLD.comm.Abort(code)


_WORLD: World | None = None


def world_started() -> bool:
    """Has :func:`world` been made (without making it)?"""
    return _WORLD is not None


def world() -> World:
    """The ranks of this run (made once). Several ranks need mpi4py: without it, ParameterError naming ``mpi``."""
    global _WORLD
    if _WORLD is None:
        if launched_ranks() > 1:
            try:
                from mpi4py import MPI
            except ImportError:
                raise ParameterError("mpi", f"this run was started on {launched_ranks()} ranks, and a distributed "
                                            f"run needs MPI for Python: {MPI_EXTRA}") from None
            _WORLD = World(MPI.COMM_WORLD if MPI.COMM_WORLD.Get_size() > 1 else None)
        else:
            _WORLD = World()
    return _WORLD
