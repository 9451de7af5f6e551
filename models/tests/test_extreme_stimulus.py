"""The extreme-magnitude step (``models/kernel/extreme_stimulus.py``): good input over the format's whole range, the
step's structure kept, reproducible from its seed."""

from __future__ import annotations

import numpy as np
import pytest

from models import scenes
from models.golden.contact_solver import SolverParams
from models.kernel.extreme_stimulus import extreme_magnitudes
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32, NumberFormat
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.setup.inertia import InertiaMode


def pile_job(fmt: NumberFormat) -> KernelJob:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    return KernelJob.from_frame(frame, fmt, SolverParams(4), "hazard", 64)


def words(job: KernelJob) -> np.ndarray:
    b, c, ip = job.bodies, job.cons, job.iparams
    parts = [b.position, b.orientation, b.linear_velocity, b.angular_velocity, b.inv_mass, b.inv_inertia,
             *(getattr(c, n) for n in c._REAL_FIELDS), np.array([ip.dt, ip.damping, *ip.gravity])]
    return np.concatenate([np.ravel(p) for p in parts])


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
def test_values_span_the_format_and_stay_good_input(fmt: NumberFormat) -> None:
    job = pile_job(fmt)
    out = extreme_magnitudes(job, seed=3)
    w = words(out)
    assert np.all(np.isfinite(w)) and np.array_equal(fmt.round(w), w)
    mag = np.abs(w[w != 0])
    assert mag.max() >= fmt.max_finite / 4 and mag.min() < 4 * fmt.min_normal  # the top and the bottom binades
    assert np.count_nonzero(w == 0) > 0  # draws below the smallest normal: flushed to zero
    assert np.count_nonzero(w < 0) > w.size // 4 and np.count_nonzero(w > 0) > w.size // 4
    b = out.bodies
    assert np.array_equal(b.dynamic, job.bodies.dynamic)  # the same bodies move: no static pair is made
    assert np.all(b.inv_mass[b.dynamic] >= fmt.min_normal) and np.all(b.inv_inertia[b.dynamic] >= fmt.min_normal)
    assert np.all(b.inv_mass[~b.dynamic] == 0) and np.all(b.inv_inertia[~b.dynamic] == 0)
    assert out.iparams.dt > 0 and out.iparams.damping > 0
    for name in ("body_a", "body_b", "num_points", "spin_damp"):
        assert np.array_equal(getattr(out.cons, name), getattr(job.cons, name))
    assert np.array_equal(out.schedule, job.schedule)


def test_reproducible_from_the_seed() -> None:
    job = pile_job(FP32)
    assert np.array_equal(words(extreme_magnitudes(job, 7)), words(extreme_magnitudes(job, 7)))
    assert not np.array_equal(words(extreme_magnitudes(job, 7)), words(extreme_magnitudes(job, 8)))


def test_impulses_in_the_records_start_at_extremes_too() -> None:
    out = extreme_magnitudes(pile_job(FP16).impulses_travelling(), seed=1)
    assert out.initial is not None
    start = np.concatenate([out.initial.normal, out.initial.friction], axis=1)
    assert np.all(np.isfinite(start)) and np.abs(start).max() >= FP16.max_finite / 4


def test_derived_tangents_are_refused() -> None:
    with pytest.raises(ValueError, match="before the tangents are derived"):
        extreme_magnitudes(pile_job(FP32).impulses_travelling().tangents_derived(), seed=1)


def test_the_one_word_build_keeps_its_bodies_isotropic() -> None:
    """A job on the 1-word build (the pile's cubes with ``with_inertia(True)``) draws one inverse-inertia value per
    body, so the drawn table stays in the scalar mode its body record carries; the 3-word build's draws differ per
    axis."""
    scalar = extreme_magnitudes(pile_job(FP32).with_inertia(True), seed=3)
    assert scalar.inertia_words == 1 and scalar.bodies.inertia_mode is InertiaMode.SCALAR
    diagonal = extreme_magnitudes(pile_job(FP32), seed=3)
    dyn = diagonal.bodies.dynamic
    assert np.any(diagonal.bodies.inv_inertia[dyn, 0] != diagonal.bodies.inv_inertia[dyn, 1])
