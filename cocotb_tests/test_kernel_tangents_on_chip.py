"""The fp32 records design (impulses in the records, two body banks) with the tangent basis derived on chip
(``TANGENTS_ON_CHIP = 1``): the friction record carries no t0, t1 (512 bits, one 512-bit beat instead of two) and
``pgs_friction_pipe_tb`` derives them from the normal (``models/setup/tangent_basis.py``). One Verilator build
(``pgs_kernel_e8m23_c512_ir_bk2_tb_dl65``, the zcu102 preset's 512-bit beats) for every test here;
``sim.drive.kernel_step`` compares bit for bit the trace, the body-out stream and the impulse-out stream with the golden
model of the same step, which solves with the derived tangents (``KernelJob.tangents_derived``):

* the pile and the 10-cube stack with random stream gaps and backpressure on every stream (the seed is printed,
  ``SEED=<int>`` overrides it): bit-exact, never faster than the cycle model's lower bound;
* deterministic streams: every retire cycle, the total and the stall and bubble counters equal the cycle model's
  (the deeper friction pipe's latency, the one-beat friction record);
* the fp16 records design with the option (its own build, ``pgs_kernel_e5m10_c512_ir_tb``): the pile bit-exact with
  random stalls and cycle-exact with deterministic streams;
* the pile turned a quarter about x (a z-up world, as pybullet's own examples are): its normals lie along z, so the
  pipe takes the basis's other branch (|n_z| above the split), which the y-up scenes never reach.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.timing import cycle_model
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.setup.constraints import BodyTable
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32, NumberFormat
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.setup.tangent_basis import PLANE_SPACE_SPLIT
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import run_kernel_step
from sim.compare import retire_cycles
from sim.drive.seed import run_seed

GAP_PERMILLE, BP_PERMILLE = 100, 200
PRESET = get_preset("zcu102")


def _seed() -> int:
    return run_seed()


def streamed_job(scene: str, fmt: NumberFormat = FP32) -> KernelJob:
    """The records design's step of ``scene`` with the tangents in the records (the host's float64 basis)."""
    frame = scenes.load_or_capture(scene, **KERNEL_TEST_SCENES[scene])
    return KernelJob.from_frame(frame, fmt, SolverParams(4), "hazard",
                                default_window(fmt, PRESET.stream_bits)).impulses_travelling()


def scene_job(scene: str, fmt: NumberFormat = FP32) -> KernelJob:
    return streamed_job(scene, fmt).tangents_derived()


def _turn_x(v: np.ndarray) -> np.ndarray:
    """Vectors (..., 3) turned a quarter about x: (x, y, z) -> (x, -z, y), exact in floating point."""
    return np.stack([v[..., 0], -v[..., 2], v[..., 1]], axis=-1)


def quarter_turn_x(job: KernelJob) -> KernelJob:
    """``job``'s world turned a quarter about x (y up becomes z up): every position, velocity, normal, point and the
    gravity turned (exactly), the orientations composed with the turn and rounded to the format, the world-frame
    inverse inertia's diagonal with y and z exchanged; the solver's coefficients kept (those of the host's turned
    basis: the kernel derives another basis of the same plane, so this is a check of the bits, not of physics)."""
    b, c = job.bodies, job.cons
    s = np.sqrt(0.5)
    qx, qy, qz, qw = b.orientation.T
    orientation = np.stack([s * (qx + qw), s * (qy - qz), s * (qz + qy), s * (qw - qx)], axis=1)
    bodies = BodyTable(_turn_x(b.position), orientation, _turn_x(b.linear_velocity), _turn_x(b.angular_velocity),
                       b.inv_mass, b.inv_inertia[:, [0, 2, 1]]).rounded(job.fmt)
    cons = dataclasses.replace(c, normal=_turn_x(c.normal), points=_turn_x(c.points), center=_turn_x(c.center),
                               tangent=_turn_x(c.tangent))
    gravity = tuple(float(g) for g in _turn_x(np.array(job.iparams.gravity)))
    return dataclasses.replace(job, bodies=bodies, cons=cons,
                               iparams=dataclasses.replace(job.iparams, gravity=gravity))


def test_the_build_derives_the_tangents() -> None:
    kb = KernelBuild.for_job(scene_job("stack"), PRESET)
    assert kb.name == "pgs_kernel_e8m23_c512_ir_bk2_tb_dl65"
    assert kb.parameters["TANGENTS_ON_CHIP"] == 1 and kb.parameters["IMPULSES_IN_RECORDS"] == 1
    assert kb.layout.friction_beats == 1 and kb.defines["FRICTION_BEATS"] == 1
    assert KernelBuild.for_job(streamed_job("stack"), PRESET).layout.friction_beats == 2


def test_the_derived_basis_differs_from_the_host_one() -> None:
    """The bit-exact runs below can tell the two bases apart: the derived tangents (in fp32) are not the host's."""
    derived, streamed = scene_job("pile"), streamed_job("pile")
    assert not np.array_equal(derived.cons.tangent, streamed.cons.tangent)
    np.testing.assert_allclose(derived.cons.tangent, streamed.cons.tangent, atol=1e-6)


@pytest.mark.parametrize("scene", ["pile", "stack"])
def test_bit_exact_with_random_backpressure(scene: str, tmp_path: Path) -> None:
    job, seed = scene_job(scene), _seed()
    print(f"\nseed {seed} (SEED={seed} reproduces)")
    res = run_kernel_step(job, PRESET, tmp_path, seed, GAP_PERMILLE, BP_PERMILLE)
    bound = cycle_model.lower_bound(job, PRESET)
    print(f"[{scene}/fp32/impulses in records/tangents on chip] {res.cycles:,} cycles, model lower bound {bound:,}")
    assert res.bit_exact, res.comparison.first_mismatch
    assert int(res.registers["impulse_out_records"]) == job.manifold_passes
    assert res.cycles >= bound


@pytest.mark.parametrize("scene", ["pile", "stack"])
def test_cycles_match_model(scene: str, tmp_path: Path) -> None:
    job = scene_job(scene)
    pred = cycle_model.predict_job(job, PRESET)
    res = run_kernel_step(job, PRESET, tmp_path, seed=1, keep_trace=True)
    assert res.bit_exact, res.comparison.first_mismatch
    agree = retire_cycles.compare_run(pred, res, job.slots)
    streamed = cycle_model.predict_job(streamed_job(scene), PRESET).cycles
    print(f"\n[{scene}/fp32/impulses in records/tangents on chip] {agree.describe()}; stalls {pred.stalls:,}, "
          f"bubbles {pred.bubbles:,}; streamed tangents {streamed:,} cycles (model)")
    assert agree.ok, agree.first_mismatch


def test_fp16_pile_bit_exact_and_cycle_exact(tmp_path: Path) -> None:
    """fp16: the friction record is one beat with or without t0, t1; the option changes the pipe and the layout."""
    job, seed = scene_job("pile", FP16), _seed()
    assert KernelBuild.for_job(job, PRESET).name == "pgs_kernel_e5m10_c512_ir_tb"
    print(f"\nseed {seed} (SEED={seed} reproduces)")
    res = run_kernel_step(job, PRESET, tmp_path / "random", seed, GAP_PERMILLE, BP_PERMILLE)
    assert res.bit_exact, res.comparison.first_mismatch
    assert res.cycles >= cycle_model.lower_bound(job, PRESET)
    pred = cycle_model.predict_job(job, PRESET)
    det = run_kernel_step(job, PRESET, tmp_path / "deterministic", seed=1, keep_trace=True)
    assert det.bit_exact, det.comparison.first_mismatch
    agree = retire_cycles.compare_run(pred, det, job.slots)
    print(f"[pile/fp16/impulses in records/tangents on chip] random stalls {res.cycles:,} cycles; {agree.describe()}")
    assert agree.ok, agree.first_mismatch


def test_z_up_world_takes_the_other_branch(tmp_path: Path) -> None:
    """The pile turned z-up: nearly every normal has |n_z| above the split (the basis's z branch), the derived basis
    is still not the host's (the run can tell them apart), and the kernel is bit-exact with random stalls and
    cycle-exact with deterministic streams."""
    job, seed = quarter_turn_x(streamed_job("pile")).tangents_derived(), _seed()
    assert job.bodies.inv_inertia.shape[1] == 3 and job.iparams.gravity[2] < 0
    assert (np.abs(job.cons.normal[:, 2]) > PLANE_SPACE_SPLIT).mean() > 0.9
    host = quarter_turn_x(streamed_job("pile"))
    assert not np.array_equal(job.cons.tangent, host.cons.tangent)
    print(f"\nseed {seed} (SEED={seed} reproduces)")
    res = run_kernel_step(job, PRESET, tmp_path / "random", seed, GAP_PERMILLE, BP_PERMILLE)
    assert res.bit_exact, res.comparison.first_mismatch
    det = run_kernel_step(job, PRESET, tmp_path / "deterministic", seed=1, keep_trace=True)
    assert det.bit_exact, det.comparison.first_mismatch
    agree = retire_cycles.compare_run(cycle_model.predict_job(job, PRESET), det, job.slots)
    print(f"[pile z-up/fp32/impulses in records/tangents on chip] random stalls {res.cycles:,} cycles; "
          f"{agree.describe()}")
    assert agree.ok, agree.first_mismatch
