"""The kernel's floating-point event counters as the golden model predicts them.

The kernel counts the overflow, underflow and invalid (NaN) flags of every operator result of its three
datapaths, for every issued manifold-pass and every dynamic body's integration (``rtl/README.md``). The
prediction evaluates the datapaths' graphs (``rtl/gen``, the software twin of the generated RTL, proven equal
to the golden model by ``test_kernel_pipes.py``) with a counting format on the inputs each manifold-pass and
body really sees in the golden step (``models.kernel_vectors.scene_vectors`` in the job's schedule order).
"""

from __future__ import annotations

import numpy as np

from models.kernel_vectors import scene_vectors
from models.number_format import FpEvents
from rtl.gen.kernel_graphs import GRAPHS
from models.kernel_job import KernelJob


def predicted_events(job: KernelJob) -> FpEvents:
    """The event totals of one kernel step (every manifold-pass accepted)."""
    ip = job.iparams
    sv = scene_vectors(job.bodies, job.cons, job.fmt, job.params, dt=ip.dt, gravity=ip.gravity, damping=ip.damping,
                       schedule=job.schedule)
    total = FpEvents()
    with np.errstate(all="ignore"):
        for module, words, flags in (("pgs_contact_pipe", sv.contact, None),
                                     ("pgs_friction_pipe", sv.friction, sv.spin_damp[:, None]),
                                     ("pgs_integrate_pipe", sv.integrate, None)):
            total.add(GRAPHS[module]().count_events(job.fmt, words, flags))
    return total
