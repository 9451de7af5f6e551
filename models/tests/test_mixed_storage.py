"""Mixed storage with fp32 arithmetic: the budget, the search, the record layout, the cycle and resource models."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

from models.sizing import mixed_layout as ml
from models.sizing import mixed_storage as ms
from models import scenes
from models.kernel import stream_format as sf
from models.setup.constraints import body_table, setup_constraints
from models.golden.contact_solver import SolverParams
from models.timing.cycle_model import predict_job
from models.timing.platforms import get_preset
from models.golden.integrator import IntegrationParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP32, NumberFormat
from models.order.manifold_schedule import make_schedule
from sim.fit import resource_model as rm
from sim.drive.harness_run import write_inputs
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import golden_step
from sim.studies.mixed_storage_report import main as report_main
from sim.studies.mixed_storage_report import parse_storage
from models.timing import platforms

ZCU102 = get_preset("zcu102")


@pytest.fixture(scope="module")
def pile() -> ms.MixedStepProblem:
    frame = scenes.capture_frame("pile", nx=4, ny=3, nz=4, seed=2)
    bodies = body_table(frame)
    cons = setup_constraints(frame, bodies)
    schedule = make_schedule("hazard", cons, bodies.dynamic, default_window(FP32, 512))
    problem = ms.MixedStepProblem(bodies, cons, schedule, SolverParams(iterations=4),
                                  IntegrationParams(dt=frame.dt, gravity=tuple(frame.gravity)))
    problem.budget = ms.Budget(problem.state_error(problem.step(FP32)))
    return problem


def job_of(p: ms.MixedStepProblem) -> KernelJob:
    return KernelJob(FP32, p.bodies.rounded(FP32), p.cons.rounded(FP32), p.schedule, p.params,
                     p.iparams).impulses_travelling()


def same_bits(a: np.ndarray, b: np.ndarray) -> bool:
    return a.tobytes() == b.tobytes()


def test_no_narrower_storage_is_the_kernels_golden_step(pile: ms.MixedStepProblem) -> None:
    golden = golden_step(job_of(pile)).final
    fp32_everywhere = {g: FP32 for g in ml.STORED_GROUPS}
    for storage in ({}, fp32_everywhere):
        got = pile.step(FP32, storage)
        for f in ("position", "orientation", "linear_velocity", "angular_velocity"):
            assert same_bits(getattr(got, f), getattr(golden, f)), (storage, f)


def test_budget_is_the_factor_times_fp32s_own_error(pile: ms.MixedStepProblem) -> None:
    assert pile.budget is not None
    assert pile.budget.ratio(pile.budget.own) == pytest.approx(1 / ms.DEFAULT_FACTOR)
    assert pile.error(pile.step(FP32)) == pytest.approx(0.1)
    assert min(pile.budget.own.as_dict().values()) > 0  # every gated part has a limit


def test_stored_impulses_are_rounded_every_pass(pile: ms.MixedStepProblem) -> None:
    narrow = NumberFormat("e8m10", 8, 10)
    stored = pile.step(FP32, {ml.IMPULSES: narrow})
    assert not same_bits(stored.linear_velocity, pile.step(FP32).linear_velocity)
    assert pile.error(stored) > pile.error(pile.step(FP32, {ml.IMPULSES: NumberFormat("e8m20", 8, 20)}))


def test_search_keeps_the_error_within_the_budget(pile: ms.MixedStepProblem) -> None:
    found = ms.search_storage(pile, FP32)
    assert found.chosen and all(f.width < FP32.width for f in found.chosen.values())
    assert found.ratio <= 1.0
    assert pile.error(pile.step(FP32, found.chosen)) == pytest.approx(found.ratio)
    for group, (fmt, ratio) in found.alone.items():
        assert ratio <= 1.0 and fmt.man_bits <= FP32.man_bits, group
    # the budget binds: four bits fewer on every group leaves it
    narrower = {g: NumberFormat("n", f.exp_bits, max(f.man_bits - 4, 1)) for g, f in found.chosen.items()}
    assert pile.error(pile.step(FP32, narrower)) > 1.0


@pytest.mark.parametrize("tangents_on_chip", [False, True])
def test_record_bits_add_up_to_the_layout(tangents_on_chip: bool) -> None:
    shape = ml.RecordShape(impulses_in_records=True, tangents_on_chip=tangents_on_chip)
    lay = sf.StreamLayout(FP32, impulses_in_records=True, tangents_on_chip=tangents_on_chip)
    words = {r: sum(ml.group_words(r, shape).values()) for r in ml.RECORDS}
    assert words["contact"] == lay.contact_record_words and words["friction"] == lay.friction_record_words
    assert words["body-in"] == lay.body_in_words and words["body-out"] == sf.BODY_OUT_WORDS
    uniform = ml.record_bits({}, FP32, shape)
    assert (uniform.contact, uniform.friction) == (lay.contact_bits, lay.friction_bits)
    storage = {ml.GEOMETRY: NumberFormat("e7m20", 7, 20), ml.IMPULSES: NumberFormat("e6m15", 6, 15)}
    rb = ml.record_bits(storage, FP32, shape)
    assert rb.contact == sf.HEADER_BITS + 15 * 28 + 8 * 32 + 4 * 22
    assert rb.friction == sf.HEADER_BITS + (6 if tangents_on_chip else 12) * 28 + 2 * 32 + 6 * 22
    assert (rb.impulse_out_contact, rb.impulse_out_friction) == (4 * 22, 2 * 22)
    mixed = sf.StreamLayout(FP32, impulses_in_records=True, tangents_on_chip=tangents_on_chip, record_bits=rb)
    assert mixed.contact_beats == -(-rb.contact // 512) and mixed.impulse_write_bytes(0) == 11


def test_the_cycle_model_takes_the_record_bits(pile: ms.MixedStepProblem) -> None:
    job = job_of(pile)
    shape = ml.RecordShape(True, False, job.inertia_words, job.friction_words)
    same = job.stored_as(ml.record_bits({}, FP32, shape))
    assert predict_job(same, ZCU102).cycles == predict_job(job, ZCU102).cycles
    narrow = {g: NumberFormat("e6m18", 6, 18) for g in (ml.POSITIONS, ml.ORIENTATIONS, ml.VELOCITIES, ml.MASS)}
    mixed = job.stored_as(ml.record_bits(narrow, FP32, shape))
    lay = mixed.stream_layout()
    assert (lay.body_in_beats, lay.body_out_beats) == (4, 3)  # 17 x 25 = 425 bits, 13 x 25 = 325 bits
    assert predict_job(mixed, ZCU102).cycles < predict_job(job, ZCU102).cycles
    with pytest.raises(ValueError, match="window"):
        _ = lay.window_bits


def test_converters_are_counted_and_cost_luts(pile: ms.MixedStepProblem) -> None:
    shape = ml.RecordShape()
    storage = {ml.VELOCITIES: NumberFormat("e6m18", 6, 18), ml.IMPULSES: NumberFormat("e8m15", 8, 15)}
    conv = {(c.direction, c.stored.name): c.count for c in ml.converters(storage, FP32, shape)}
    # unpack: body-in v, w (6) and the records' impulses (4 + 6); pack: body-out v, w (6) and lam (4)
    assert conv == {("unpack", "e6m18"): 6, ("unpack", "e8m15"): 10, ("pack", "e6m18"): 6, ("pack", "e8m15"): 4}
    cfg = rm.config_for_job(job_of(pile))
    plain = rm.estimate(cfg, platforms.get_platform("zcu102")).total
    with_conv = rm.estimate(dataclasses.replace(cfg, converters=ml.converters(storage, FP32, shape)),
                            platforms.get_platform("zcu102")).total
    assert with_conv.lut > plain.lut and with_conv.ff > plain.ff


def test_bad_input_is_refused(pile: ms.MixedStepProblem) -> None:
    with pytest.raises(ValueError, match="unknown field groups"):
        pile.step(FP32, {"speeds": FP32})
    with pytest.raises(ValueError, match="expected <group>=<format>"):
        parse_storage("speeds=e6m18")
    with pytest.raises(ValueError, match="a stored format is"):
        parse_storage("velocities=float64")
    with pytest.raises(ValueError):
        sf.RecordBits(0, 1, 1, 1, 1, 1)
    with pytest.raises(ValueError, match="unknown record"):
        ml.group_words("trace", ml.RecordShape())


def test_no_rtl_run_takes_a_mixed_layout(pile: ms.MixedStepProblem, tmp_path: Path) -> None:
    job = job_of(pile)
    bits = ml.record_bits({ml.VELOCITIES: NumberFormat("e6m18", 6, 18)}, FP32, ml.RecordShape())
    mixed = job.stored_as(bits)
    with pytest.raises(ValueError, match="no RTL kernel"):
        write_inputs(tmp_path, mixed, KernelBuild(FP32, impulses_in_records=True))
    with pytest.raises(ValueError, match="streaming kernel"):
        dataclasses.replace(job, impulses_in_records=False).windowed(64).stored_as(bits)


def test_the_report_command(tmp_path: Path) -> None:
    args = ["--scene", "pile", "--scene-args", "nx=3 ny=2 nz=3", "--storage",
            "positions=e6m21,velocities=e6m19,impulses=e6m16", "--exact-budget", "30", "--out", str(tmp_path)]
    assert report_main(args) == 0
    out = json.loads(next(tmp_path.glob("*/report.json")).read_text())
    assert out["storage formats (arithmetic fp32)"]["stored format: impulses"] == "e6m16 (23 bits)"
    mixed = out["design: mixed storage (impulses in the records, 2 body banks)"]
    # body-in 3 x 28 + 4 x 32 + 6 x 26 + 4 x 32 = 496 bits, body-out 368 (fp32: 544 and 416)
    assert mixed["body-in / body-out beats (128-bit)"] == "4 / 3"
    assert report_main(["--scene", "pile", "--storage", "bogus=e5m10", "--out", str(tmp_path)]) == 2
