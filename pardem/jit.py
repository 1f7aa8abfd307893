"""Numba compilation options shared by every kernel (one decision, one place).

- ``cache=True``: compiled code is stored on disk and served to later processes (warm start).
- ``error_model="numpy"``: float division by zero gives inf/nan instead of a Python exception,
  so hot loops carry no exception branches; the step loop's NaN watchdog catches the result.
- No fastmath: "nnan"/"ninf" would remove the NaN watchdog; FMA contraction breaks the exact
  antisymmetry of pair forces (a_i w_i + a_j w_j becomes fma(a_i, w_i, a_j w_j), not symmetric
  in i <-> j); and "arcp" lets LLVM round a division differently in differently specialised
  kernels, so mu = 0 no longer reproduces tangential_friction = false bit for bit. Both were
  measured (tests/test_contact_law.py, tests/test_effects.py); the speed gain was ~1-2 %.
- ``INLINE`` kernels are inlined into the step loop at numba IR level. A caller must not reuse a
  variable name of an inlined callee: that was seen to change results by 1 ulp
  (tests/test_contact_law.py compares the compiled loop with standalone kernel calls).
"""

JIT = dict(cache=True, error_model="numpy")
INLINE = dict(JIT, inline="always")
