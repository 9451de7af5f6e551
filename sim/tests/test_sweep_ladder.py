"""models.golden.iteration_ladder: one contact run with snapshots, and a friction phase from each, gives every iteration
count's step bit for bit as a separate golden run (sim.drive.kernel_step.golden_step) does, in both pass orders and in a
rounding format; bad counts are refused."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from models import scenes
from models.golden.contact_solver import SolverParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FLOAT64, FP16, FP32
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.golden.iteration_ladder import solve_ladder
from sim.drive.kernel_step import golden_step

COUNTS = (1, 2, 3, 4, 8)


@pytest.fixture(scope="module")
def frame():  # type: ignore[no-untyped-def]
    return scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])


@pytest.mark.parametrize("fmt", [FP32, FP16, FLOAT64], ids=lambda f: f.name)
@pytest.mark.parametrize("interleaved", [False, True], ids=["contact-first", "interleaved"])
def test_ladder_is_bit_identical_to_separate_runs(frame, fmt, interleaved: bool) -> None:  # type: ignore[no-untyped-def]
    base = KernelJob.from_frame(frame, FP32 if fmt is FLOAT64 else fmt, SolverParams(1), window=64)
    job = dataclasses.replace(base, fmt=fmt)
    params = SolverParams(interleaved=interleaved)
    finals = solve_ladder(job.bodies, job.cons, job.schedule, fmt, COUNTS[::-1], job.iparams, params)
    assert sorted(finals) == sorted(COUNTS)
    moved = 0
    for n in COUNTS:
        alone = golden_step(dataclasses.replace(job, params=dataclasses.replace(params, iterations=n))).final
        for field in ("linear_velocity", "angular_velocity", "position", "orientation"):
            ours, ref = getattr(finals[n], field), getattr(alone, field)
            assert ours.tobytes() == ref.tobytes(), f"{fmt.name} {n} iterations: {field} differs"
        moved += int(not np.array_equal(finals[n].linear_velocity, finals[1].linear_velocity))
    assert moved == len(COUNTS) - 1  # every count is its own step (the counts do not collapse into one)


@pytest.mark.parametrize("counts", [(), (0, 2), (-1,)])
def test_ladder_refuses_bad_counts(frame, counts) -> None:  # type: ignore[no-untyped-def]
    job = KernelJob.from_frame(frame, FP32, SolverParams(1))
    with pytest.raises(ValueError, match="positive integers"):
        solve_ladder(job.bodies, job.cons, job.schedule, FP32, counts, job.iparams)
