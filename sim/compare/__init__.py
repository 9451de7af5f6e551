"""A run against its oracles: the trace and body-out bits against the golden model (``trace_bits.py``), every retire
cycle against the cycle model (``retire_cycles.py``), the velocities against the exact reference
(``exact_error.py``)."""
