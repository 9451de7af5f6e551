"""A frame's bodies and contacts as the kernel sees them, set up on the host once per step in float64: the body table
and the constraint rows of Bullet's GPU solver (``constraints.py``), the inverse inertia in each convention
(``inertia.py``), and the friction tangent basis derived from the normal (``tangent_basis.py``)."""
