"""The types of the per-step ghost refresh plan and of the compiled collectives' handles.

Stage: communication. No MPI here: numba's cache index names these types in the signatures of
the compiled step loop, and reading that index (in every process, serial ones included) imports
this module; the MPI code that uses them is in ``halo.py``.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Handles(NamedTuple):
    """MPI handles and sizes for compiled collectives (int64): the communicator, MPI_DOUBLE,
    MPI_INT, the sizes (bytes) of an MPI_Request and an MPI_Status, and the number of ranks."""

    comm: int
    double: int
    int32: int
    request_size: int
    status_size: int
    size: int


class HaloConfig(NamedTuple):
    """How a plan refreshes (int64): communicator, MPI_DOUBLE and MPI_MAX handles, request size
    (bytes), ``allreduce`` (1: complete the header maxima by an Allreduce), ``shared`` (1:
    through the shared-memory window, 0: messages), ``cap`` (doubles per shared buffer),
    this rank."""

    comm: int
    double: int
    op_max: int
    request_size: int
    allreduce: int
    shared: int
    cap: int
    rank: int


class Halo(NamedTuple):
    """Plan of the per-step ghost refresh, made anew at every exchange.

    nbr [k] int64: neighbour ranks. send_idx [s] int64: local indices of owned particles sent,
    neighbour by neighbour (``send_off`` [k+1] offsets). recv_off [k+1]: the ghosts received
    from each neighbour, as offsets from the first ghost slot. sbuf, rbuf: message buffers.
    req, status: MPI request and status storage (bytes). red [6]: Allreduce buffers.
    shared [P, SEQ + 2 cap], seq (the same memory as int64): the shared-memory window, one row
    per rank (dummies without it). peer_at [k]: where neighbour q keeps this rank's block in
    its buffer. cfg: HaloConfig.
    wait [3] (s): time spent waiting for the neighbours' blocks (shared memory) or in
    MPI_Waitall, and in MPI_Allreduce, accumulated over the run (the decomposition passes the
    same array to every new plan): the exchange latency plus the wait for slower neighbours;
    then, in a timed step loop only (``core/timing.py``), the time packing and unpacking.
    """

    nbr: np.ndarray
    send_idx: np.ndarray
    send_off: np.ndarray
    recv_off: np.ndarray
    sbuf: np.ndarray
    rbuf: np.ndarray
    req: np.ndarray
    status: np.ndarray
    red: np.ndarray
    shared: np.ndarray
    seq: np.ndarray
    peer_at: np.ndarray
    cfg: HaloConfig
    wait: np.ndarray
