"""The streaming kernel whose impulses travel with the records (no impulse RAM): record layouts, DDR read share,
the step's initial impulses, the cycle model's read-after-write rule across passes (no Verilator; the RTL runs are
in ``cocotb_tests/test_kernel_impulses_in_records.py``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from models import scenes
from models.timing import cycle_model
from models.kernel import stream_format as sf
from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS, Impulses, SolverParams, solve
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape
from models.formats.number_format import FP16, FP32
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.timing import stream_cycle_model
from models.order import manifold_schedule


def _job(fmt=FP16, scene: str = "stack") -> KernelJob:
    frame = scenes.load_or_capture(scene, **KERNEL_TEST_SCENES[scene])
    return KernelJob.from_frame(frame, fmt, SolverParams(4), "hazard")


def independent_stack_job(fmt=FP16) -> KernelJob:
    """The stack's 10 manifolds re-pointed at the ground and one cube each (no two share a dynamic body): no
    hazard holds a pass back, so each pass waits only for its predecessor's impulse writes (the read-after-write
    rule across passes)."""
    base = _job(fmt)
    m = base.cons.num_manifolds
    cons = dataclasses.replace(base.cons, body_a=np.zeros(m, np.int64), body_b=np.arange(1, m + 1, dtype=np.int64))
    return dataclasses.replace(base, cons=cons, schedule=np.arange(m, dtype=np.int64))


@pytest.mark.parametrize("fmt,contact_bits,friction_bits,contact_beats,friction_beats",
                         [(FP16, 496, 384, 1, 1), (FP32, 928, 704, 2, 2)])
def test_record_sizes_with_impulses(fmt, contact_bits, friction_bits, contact_beats, friction_beats) -> None:
    """Contact records carry lam[4] (fp16 432 -> 496 bits: still one 512-bit beat), friction records lam[4] and
    lamT[2] (fp16 288 -> 384: one beat; fp32 512 -> 704: two beats instead of one)."""
    lay = sf.StreamLayout(fmt, impulses_in_records=True)
    base = sf.StreamLayout(fmt)
    assert (lay.contact_bits, lay.friction_bits) == (contact_bits, friction_bits)
    assert (lay.contact_beats, lay.friction_beats) == (contact_beats, friction_beats)
    assert lay.contact_bits - base.contact_bits == 4 * fmt.width
    assert (lay.impulse_write_bytes(CONTACT_PASS), lay.impulse_write_bytes(FRICTION_PASS)) == (fmt.width // 2,
                                                                                               fmt.width // 4)
    assert base.ddr_read_share(SolverParams(4)) == 1.0
    # fp16, 4 iterations: 8 x 64 bytes read, 4 x 8 + 4 x 4 written per manifold and step
    if fmt is FP16:
        assert lay.ddr_read_share(SolverParams(4)) == pytest.approx(512 / (512 + 48))


def test_records_carry_the_initial_impulses() -> None:
    """Every pass's records carry the impulses the step starts from, in their last words (the DMA replaces those
    an earlier pass wrote)."""
    job = _job(FP32)
    rng = np.random.default_rng(3)
    m = job.cons.num_manifolds
    init = Impulses(FP32.round(rng.uniform(0, 1, (m, 4))), FP32.round(rng.uniform(-0.1, 0.1, (m, 2))))
    stream = sf.pack_constraint_stream(FP32, job.cons, job.schedule, job.params, impulses=init)
    lay = sf.StreamLayout(FP32, impulses_in_records=True)
    idx = manifold_schedule.schedule_manifolds(job.schedule)
    rec_bytes = lay.contact_bytes
    contact = stream.data[:len(idx) * lay.contact_beats].reshape(len(idx), rec_bytes)
    _, words = sf.unpack_records(contact, lay.contact_record_words, 32, rec_bytes * 8, header=True)
    assert np.array_equal(FP32.decode(words[:, sf.CONTACT_LAM_WORD:]), init.normal[idx])
    friction = stream.data[-len(idx) * lay.friction_beats:].reshape(len(idx), lay.friction_bytes)
    _, words = sf.unpack_records(friction, lay.friction_record_words, 32, lay.friction_bytes * 8, header=True)
    assert np.array_equal(FP32.decode(words[:, sf.FRICTION_LAM_WORD:sf.FRICTION_LAMT_WORD]), init.normal[idx])
    assert np.array_equal(FP32.decode(words[:, sf.FRICTION_LAMT_WORD:]), init.friction[idx])


def test_initial_impulses_are_checked() -> None:
    """Initial impulses only on the kernel whose impulses travel with the records, of the right shape, finite and
    already values of the format."""
    job = _job()
    m = job.cons.num_manifolds
    good = Impulses.zeros(m)
    with pytest.raises(ValueError, match="travel with the records"):
        dataclasses.replace(job, initial=good)
    with pytest.raises(ValueError, match="must be"):
        job.impulses_travelling(Impulses.zeros(m + 1))
    bad = Impulses.zeros(m)
    bad.normal[0, 0] = np.nan
    with pytest.raises(ValueError, match="finite"):
        job.impulses_travelling(bad)
    bad.normal[0, 0] = 0.1  # not an fp16 value
    with pytest.raises(ValueError, match="values of fp16"):
        job.impulses_travelling(bad)
    with pytest.raises(ValueError, match="one kind"):  # the window kernel's fetches each serve passes of one kind
        job.impulses_travelling().windowed(1024, fetch_passes=3)


def test_warm_start_changes_the_solve() -> None:
    """The golden model starts from the given impulses (so a kernel that ignored them would differ)."""
    job = _job()
    m = job.cons.num_manifolds
    init = Impulses(FP16.round(np.full((m, 4), 0.5)), Impulses.zeros(m).friction)
    cold = solve(job.bodies, job.cons, job.schedule, job.fmt, job.params)
    warm = solve(job.bodies, job.cons, job.schedule, job.fmt, job.params, initial=init)
    assert not np.array_equal(cold.impulses.normal, warm.impulses.normal)


def test_read_after_write_rule_bites_on_a_short_pass() -> None:
    """On 10 independent manifolds (far fewer than the pipe's depth) every pass waits for its predecessor's impulse
    writes plus the DMA's turnaround: the cycle model counts it (the RTL runs check that it counts it exactly); on
    the thesis-sized pile the rule costs nothing."""
    preset = get_preset("zcu102")
    for job, bites in ((independent_stack_job().impulses_travelling(), True),
                       (_job(FP16, "pile").impulses_travelling(), False)):
        shape = KernelShape.of(FP16, preset.stream_bits, impulses_in_records=True)
        dma = DmaTiming.of(preset, read_share=job.stream_layout().ddr_read_share(job.params))
        step = StepShape.of_job(job)
        full = stream_cycle_model.predict(shape, dma, step).cycles
        free = stream_cycle_model.predict(shape, dataclasses.replace(dma, turnaround=1), step).cycles
        assert dma.turnaround == 2 * preset.startup_cycles
        assert (full > free) == bites, (job.cons.num_manifolds, full, free)
        assert cycle_model.predict_job(job, preset).cycles == full


def test_on_chip_configuration_unchanged() -> None:
    """The default build's records, beats and DDR rate are today's."""
    job = _job(FP32)
    assert not job.impulses_in_records
    lay = job.stream_layout()
    assert (lay.contact_bits, lay.friction_bits) == (64 + 23 * 32, 64 + 14 * 32)
    assert DmaTiming.of(get_preset("zcu102")) == DmaTiming.of(get_preset("zcu102"), read_share=1.0)


def test_record_checks_follow_the_reads() -> None:
    """The passes at which the kernel reads the impulse words back with the records: every pass of the streaming
    kernel, the first pass of each window fetch, none where the impulses stay on chip."""
    job = _job(FP32, "pile")
    assert job.record_checks() is None
    assert job.impulses_travelling().record_checks() == [True] * 8
    window = job.impulses_travelling().windowed(1024, fetch_passes=2)
    assert window.record_checks() == [True, False] * 4


def test_nonfinite_carried_impulse_rejects_the_manifold_for_the_rest_of_the_step() -> None:
    """A manifold whose friction record carries a non-finite impulse word (here the start's lamT, which the contact
    passes do not use) is rejected from the first friction pass on: no trace record, no update, and no other
    manifold rejected; the contact passes solve it (the kernel does not check a contact record's impulse words)."""
    job = _job(FP32, "pile").impulses_travelling()
    m, bad = job.cons.num_manifolds, 5
    start = Impulses(np.zeros((m, 4)), np.zeros((m, 2)))
    start.friction[bad, 1] = np.nan
    records: list = []
    res = solve(job.bodies, job.cons, job.schedule, job.fmt, job.params, records.append, initial=start,
                record_checks=job.record_checks())
    assert res.rejected_passes == 4  # the four friction passes
    for rec in records:
        assert (bad in rec.manifold) == (rec.kind == CONTACT_PASS)
    with pytest.raises(ValueError, match="record_checks has 3 flags for 8 passes"):
        solve(job.bodies, job.cons, job.schedule, job.fmt, job.params, record_checks=[True] * 3)
