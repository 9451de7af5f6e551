"""The order in which a pass visits the manifolds (``manifold_schedule.py``): the schedule the golden model and the
kernel share, from pybullet's order to the hazard, banded and sweep orders the kernels need."""
