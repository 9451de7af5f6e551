"""A step whose every real word is drawn over the whole range of the job's format: the stimulus of the kernel's
floating-point exception paths.

The scenes make values of a few orders of magnitude around 1, so an operator's overflow, underflow and invalid
flags rise only where an edit forces one value (``sim/coverage/input_edits.py``: the largest finite velocity).
:func:`extreme_magnitudes` keeps a step's structure (bodies, manifolds, schedule, window plan, which bodies are
dynamic, the inverse-inertia words its build carries: one value per body on the 1-word build) and replaces its
numbers: each word of the constraint records, the body records, the integration
operands and, where the impulses travel with the records, the start impulses takes a random sign and a magnitude
``2**e`` with ``e`` uniform from the smallest subnormal's exponent to the format's largest, rounded to the format
(the top binade's values above the largest finite are clamped to it; the formats flush subnormals to zero, so the
draws below the smallest normal become zeros of either sign). Records differ in which operator first
overflows or underflows and where an infinity first meets another, so across a step most operators of every pipe
raise each flag. The result is good input by the kernel's rules (``rtl/README.md``, "Bad input"): every word
finite, inverse masses and inertias of dynamic bodies positive and normal (a subnormal or zero one would make the
body static, and a manifold of two static bodies is rejected), static bodies untouched.

It is reproducible from ``seed``, and the golden model solves the same step bit for bit as the kernel does
(``cocotb_tests/test_kernel_extremes.py``).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import Impulses
from models.golden.integrator import IntegrationParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import NumberFormat


class _Draw:
    """Values of ``fmt`` of random sign and log-uniform magnitude over its whole range, from one seeded stream."""

    def __init__(self, fmt: NumberFormat, seed: int):
        self.fmt, self.rng = fmt, np.random.default_rng(seed)
        self.lowest = fmt.emin - fmt.man_bits  # the smallest subnormal's exponent

    def magnitudes(self, shape: tuple[int, ...], lowest: int | None = None) -> np.ndarray:
        e = self.rng.uniform(self.lowest if lowest is None else lowest, self.fmt.emax + 1, shape)
        return np.minimum(self.fmt.round(np.exp2(e)), self.fmt.max_finite)

    def signed(self, shape: tuple[int, ...]) -> np.ndarray:
        return self.magnitudes(shape) * self.rng.choice(np.array([-1.0, 1.0]), shape)

    def positive_normal(self, shape: tuple[int, ...]) -> np.ndarray:
        return self.magnitudes(shape, lowest=self.fmt.emin)


def _constraints(cons: ConstraintSet, draw: _Draw) -> ConstraintSet:
    return dataclasses.replace(cons, **{name: draw.signed(getattr(cons, name).shape)
                                        for name in ConstraintSet._REAL_FIELDS})


def _bodies(bodies: BodyTable, draw: _Draw, isotropic: bool = False) -> BodyTable:
    """``isotropic``: one inverse-inertia value per body, repeated (the job's build carries one word per body)."""
    dyn = bodies.dynamic
    inertia = draw.positive_normal((bodies.num_bodies, 1) if isotropic else bodies.inv_inertia.shape)
    return BodyTable(position=draw.signed(bodies.position.shape), orientation=draw.signed(bodies.orientation.shape),
                     linear_velocity=draw.signed(bodies.linear_velocity.shape),
                     angular_velocity=draw.signed(bodies.angular_velocity.shape),
                     inv_mass=np.where(dyn, draw.positive_normal(bodies.inv_mass.shape), 0.0),
                     inv_inertia=np.where(dyn[:, None], np.broadcast_to(inertia, bodies.inv_inertia.shape), 0.0))


def _integration(draw: _Draw) -> IntegrationParams:
    gravity = draw.signed((3,))
    return IntegrationParams(dt=float(draw.positive_normal((1,))[0]), gravity=(float(gravity[0]), float(gravity[1]),
                             float(gravity[2])), damping=float(draw.positive_normal((1,))[0]))


def extreme_magnitudes(job: KernelJob, seed: int) -> KernelJob:
    """``job`` with every real word drawn over its format's whole range (module docstring), from ``seed``."""
    if job.tangents_on_chip:
        raise ValueError("draw the extremes before the tangents are derived (the kernel derives them from the "
                         "normals): extreme_magnitudes(job).tangents_derived()")
    draw = _Draw(job.fmt, seed)
    out = dataclasses.replace(job, cons=_constraints(job.cons, draw),
                              bodies=_bodies(job.bodies, draw, isotropic=job.inertia_words == 1),
                              iparams=_integration(draw))
    if not job.impulses_in_records:
        return out
    m = job.cons.num_manifolds
    return dataclasses.replace(out, initial=Impulses(draw.signed((m, 4)), draw.signed((m, 2))))
