"""The exact limit of the scheme the kernel iterates, in float64, and the errors measured against it.

``reference.py`` is the entry point (the contact and friction phases as QPs); ``assembly.py`` builds their rows;
``damped_friction.py``, ``interleaved.py``, ``large_island.py`` and ``body_space.py`` solve the cases the dual QPs do
not (with ``body_space_ipm.py``, ``mprgp.py`` and ``sparse_spd_factor.py``); ``bound.py`` certifies a distance;
``cache.py`` keeps a reference beside its frame; ``solution_error.py`` and ``residual.py`` measure a step against it."""
