"""The step's core: the state arrays (``state.py``), the compiled time-step loop (``step.py``:
``integrate.py``, ``forces.py``), the neighbour lists and their rebuild (``neighbors.py``,
``rebuild.py``), the time step and its limits (``timestep.py``, ``stability.py``,
``scales.py``), the run's watchdogs and diagnostics, and numba's options (``jit.py``,
``static.py``) and memory (``memory.py``)."""
