"""The kernel's floating-point event counters as the golden model predicts them.

The kernel counts the overflow, underflow and invalid (NaN) flags of every operator result of its three
datapaths, for every issued manifold-pass and every dynamic body's integration (``rtl/README.md``). The
prediction evaluates the datapaths' graphs (``rtl/gen``, the software twin of the generated RTL, proven equal
to the golden model by ``test_kernel_pipes.py``) with a counting format on the inputs each issued manifold-pass
and each body really sees in the golden step (``models.kernel.kernel_vectors.scene_vectors`` in the job's schedule
order), the contact and friction graphs in the inverse-inertia mode of the job's kernel build
(``KernelJob.inertia_words``), the friction graph with the coefficient word where the build has it
(``KernelJob.friction_words``).
"""

from __future__ import annotations

import numpy as np

from models.kernel.kernel_vectors import scene_vectors
from models.formats.number_format import FpEvents
from rtl.gen.kernel_graphs import GRAPHS, contact_graph, friction_graph
from models.kernel.kernel_job import KernelJob


def predicted_events(job: KernelJob) -> FpEvents:
    """The event totals of one kernel step: every manifold-pass the golden model does not reject (with the
    impulses in the records, from the job's start impulses, without the manifold-passes rejected for non-finite
    impulse words: ``KernelJob.record_checks``) and every dynamic body's integration."""
    ip = job.iparams
    words_per_body = job.inertia_words
    sv = scene_vectors(job.bodies, job.cons, job.fmt, job.params, dt=ip.dt, gravity=ip.gravity, damping=ip.damping,
                       schedule=job.schedule, inertia_words=words_per_body, initial=job.initial,
                       record_checks=job.record_checks())
    total = FpEvents()
    with np.errstate(all="ignore"):
        for graph, words, flags in ((contact_graph(words_per_body), sv.contact, None),
                                    (friction_graph(inertia_words=words_per_body, manifold_friction=job.friction_words == 1),
                                     sv.friction, sv.spin_damp[:, None]),
                                    (GRAPHS["pgs_integrate_pipe"](), sv.integrate, None)):
            total.add(graph.count_events(job.fmt, words, flags))
    return total
