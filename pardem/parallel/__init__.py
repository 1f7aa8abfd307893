"""Everything that talks MPI: the cut of the annulus into sectors or rings of sectors (``cut``,
``choice``), the decomposition with its
collectives (``comm``, mpi4py), the compiled exchange of migrants and ghosts (``exchange``), the
per-step ghost refresh (``halo``, ``refresh``) and libmpi itself (``native``).

On one rank nothing here loads MPI: ``decomposition`` returns a ``SerialDecomposition`` and the
step loop is compiled without a ghost refresh. ``world()`` gives COMM_WORLD only when the
process was started by an MPI launcher with more than one rank.
"""

from __future__ import annotations

import os
import time

from .serial import SerialDecomposition

# rank-count variables that MPI launchers set (MPICH/Hydra, Open MPI, PMIx, Slurm)
_SIZE_VARIABLES = ("PMI_SIZE", "OMPI_COMM_WORLD_SIZE", "PMIX_SIZE", "MPI_LOCALNRANKS",
                   "SLURM_NTASKS")

# Ghosts are selected this many skins wider than an interaction needs, so that most builds
# keep the ghosts and owners and only rebuild the lists locally (comm.Decomposition.exchange_due).
GHOST_MARGIN_SKINS = 4.0


def launched_ranks() -> int:
    """How many ranks the launcher started (1 if none says more)."""
    for name in _SIZE_VARIABLES:
        try:
            n = int(os.environ.get(name, "1"))
        except ValueError:
            continue
        if n > 1:
            return n
    return 1


def world():
    """MPI COMM_WORLD if this process is one of several ranks, else None (MPI not loaded)."""
    if launched_ranks() <= 1:
        return None
    from mpi4py import MPI

    return MPI.COMM_WORLD if MPI.COMM_WORLD.Get_size() > 1 else None


def decomposition(comm, reach_width: float, inner_radius: float = 0.0, margin: float = 0.0,
                  cut: str = "auto"):
    """The decomposition of a run on the ranks of ``comm`` (None or one rank: serial).
    reach_width (m): the farthest a listed partner can be (largest diameter + skin); margin
    (m): extra ghost width (GHOST_MARGIN_SKINS skins); cut: "auto", "sectors" or "RxA" (R
    rings of A sectors, ``choice.requested_rings``)."""
    if comm is None or comm.Get_size() == 1:
        return SerialDecomposition(reach_width, margin)
    from .comm import Decomposition

    return Decomposition(comm, reach_width, inner_radius, margin=margin, cut=cut)


def smallest_node_share(comm, amount: float) -> float:
    """``amount`` (a node's resource) divided among the ranks on this node, the smallest such
    share of any node (collective; ``amount`` itself on one rank)."""
    if comm is None or comm.Get_size() == 1:
        return amount
    from mpi4py import MPI

    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    try:
        share = amount / node.Get_size()
    finally:
        node.Free()
    return comm.allreduce(share, op=MPI.MIN)


def usable_cores() -> frozenset[int]:
    """The cores this process may run on (its CPU affinity: a batch system's or a launcher's
    binding; every core where the platform cannot say)."""
    try:
        return frozenset(os.sched_getaffinity(0))
    except AttributeError:  # macOS, Windows
        return frozenset(range(os.cpu_count() or 1))


def most_crowded_node(comm) -> tuple[int, int]:
    """(ranks, cores) of the node with the fewest cores per rank (collective): the ranks that
    share its memory (``COMM_TYPE_SHARED``, so the ranks of other nodes do not count) and the
    cores any of them may run on, the union of their affinities (ranks bound one to a core
    count each core once). One process: (1, its cores)."""
    mine = usable_cores()
    if comm is None or comm.Get_size() == 1:
        return 1, len(mine)
    from mpi4py import MPI

    node = comm.Split_type(MPI.COMM_TYPE_SHARED)
    try:
        here = node.Get_size(), len(frozenset().union(*node.allgather(mine)))
    finally:
        node.Free()
    return max(comm.allgather(here), key=lambda rc: rc[0] / rc[1])


def abort(comm, code: int = 1) -> None:
    """End every rank of ``comm`` (after an error on this one), so none waits forever. The
    short pause lets mpiexec's proxy forward what this rank just wrote to stderr: an immediate
    Abort was seen to lose the error message on a busy machine."""
    if comm is not None and comm.Get_size() > 1:
        time.sleep(0.5)
        comm.Abort(code)


# The collectives the front (cli, compile_ahead, warmup) needs, for a communicator or None
# (one process, MPI not loaded): the only places outside parallel/ that reach ranks.

def rank_of(comm) -> int:
    return comm.Get_rank() if comm is not None else 0


def size_of(comm) -> int:
    return comm.Get_size() if comm is not None else 1


def broadcast(comm, value):
    """Rank 0's ``value`` on every rank."""
    return comm.bcast(value, root=0) if comm is not None else value


def barrier(comm) -> None:
    if comm is not None:
        comm.Barrier()


def on_root(comm, fn, *args) -> None:
    """Run fn on rank 0; if it raises, raise the same error on every rank."""
    error = None
    if rank_of(comm) == 0:
        try:
            fn(*args)
        except Exception as e:  # re-raised on every rank below
            error = e
    error = broadcast(comm, error)
    if error is not None:
        raise error
