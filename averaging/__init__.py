"""Micro-to-macro averaging of pardem runs (ring sums, derived continuum fields). Filled in by the [AVG] issue."""
