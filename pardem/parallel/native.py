"""libmpi called from compiled code: the MPI functions the per-step ghost refresh and the
exchange need, declared as external symbols, and atomic loads and stores for the shared-memory
refresh.

Stage: communication. Importing this module loads the libmpi that mpi4py linked against
(``pardem.parallel`` imports it only on more than one rank). External symbols, unlike ctypes
pointers, keep numba's on-disk cache usable: the address is resolved when the cached code is
loaded, not baked into it. Handles: MPICH's are C ``int``; an MPI-ABI build uses pointers. Both
are passed in registers on x86-64 and AArch64, so the handle width is chosen from mpi4py's
``MPI._sizeof(MPI.Comm)``.
"""

from __future__ import annotations

import llvmlite.binding as llvm
from mpi4py import MPI
from numba.core import cgutils, types
from numba.extending import intrinsic


def _libmpi_path() -> str:
    """The libmpi mpi4py linked against (already mapped into this process)."""
    with open("/proc/self/maps") as maps:
        for line in maps:
            path = line.split()[-1]
            name = path.rsplit("/", 1)[-1]
            if name.startswith(("libmpi.so", "libmpi_abi.so", "libmpich.so")):
                return path
    raise RuntimeError("pardem: cannot find the MPI library that mpi4py loaded")


llvm.load_library_permanently(_libmpi_path())
_H = types.int32 if MPI._sizeof(MPI.Comm) == 4 else types.intp
_I, _P = types.int32, types.intp
mpi_irecv = types.ExternalFunction("MPI_Irecv", _I(_P, _I, _H, _I, _I, _H, _P))
mpi_isend = types.ExternalFunction("MPI_Isend", _I(_P, _I, _H, _I, _I, _H, _P))
mpi_waitall = types.ExternalFunction("MPI_Waitall", _I(_I, _P, _P))
mpi_allreduce = types.ExternalFunction("MPI_Allreduce", _I(_P, _P, _I, _H, _H, _H))
mpi_wtime = types.ExternalFunction("MPI_Wtime", types.float64())
sched_yield = types.ExternalFunction("sched_yield", _I())  # libc
mpi_alltoall = types.ExternalFunction("MPI_Alltoall", _I(_P, _I, _H, _P, _I, _H, _H))
mpi_alltoallv = types.ExternalFunction("MPI_Alltoallv", _I(_P, _P, _P, _H, _P, _P, _P, _H, _H))


@intrinsic
def load_acquire(typingctx, arr, idx):
    """arr[idx] (int64) read with acquire order: later reads see what the writer stored before
    its matching ``store_release``, and the compiler can neither drop nor hoist the read."""
    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, sig.args[0], ary, [args[1]])
        return builder.load_atomic(ptr, "acquire", 8)
    return types.int64(arr, idx), codegen


@intrinsic
def store_release(typingctx, arr, idx, value):
    """arr[idx] = value (int64) with release order: every earlier store is visible first."""
    def codegen(context, builder, sig, args):
        ary = context.make_array(sig.args[0])(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, sig.args[0], ary, [args[1]])
        builder.store_atomic(args[2], ptr, "release", 8)
        return context.get_dummy_value()
    return types.void(arr, idx, types.int64), codegen
