"""The tangent basis derived from the normal in the kernel's format (models/setup/tangent_basis.py): the friction pipe
that derives it (rtl/gen pgs_friction_pipe_tb) is the golden model's twin bit for bit, the basis is Bullet's
planeSpace to rounding, and the record layout and the cycle model know the option (the resource model:
sim/tests/test_resource_model.py)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from models.kernel import stream_format as sf
from models.setup.constraints import plane_space
from models.timing.kernel_shape import KernelShape
from models.formats.number_format import FP16, FP32
from models.setup.tangent_basis import derive_tangents, plane_space_in
from models.tests.test_body_banks import pile_job
from rtl.gen.kernel_graphs import GRAPHS, SHARED_GRAPHS, friction_in
from rtl.gen.operator_schedule import schedule


def _normals(fmt, k: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    n = rng.normal(size=(k, 3))
    n[:6] = [[0, 0, 1], [0, 0, -1], [1, 0, 0], [0, -1, 0], [0.6, 0, 0.8], [0, 0.70710678, 0.70710678]]
    return fmt.round(n / np.linalg.norm(n, axis=1, keepdims=True))


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=["fp32", "fp16"])
def test_the_pipe_is_the_golden_twin(fmt) -> None:
    """pgs_friction_pipe_tb on a record without t0, t1 = pgs_friction_pipe on the record with the tangents
    plane_space_in derives, every output word equal."""
    k, seed = 4000, 7
    print(f"seed {seed}")
    rng = np.random.default_rng(seed)
    full, tb = GRAPHS["pgs_friction_pipe"](), GRAPHS["pgs_friction_pipe_tb"]()
    names, short = friction_in(), friction_in(tangents_on_chip=True)
    x = fmt.round(rng.normal(size=(k, len(names))))
    n = _normals(fmt, k, seed)
    x[:, :3] = n
    t0, t1 = plane_space_in(fmt, n)
    x[:, 6:12] = np.concatenate([t0, t1], axis=1)
    spin = rng.random((k, 1)) < 0.5
    want = full.evaluate(fmt, x, spin)
    got = tb.evaluate(fmt, x[:, [names.index(s) for s in short]], spin)
    assert np.array_equal(fmt.encode(got), fmt.encode(want))


@pytest.mark.parametrize("fmt,ulps", [(FP32, 4), (FP16, 4)], ids=["fp32", "fp16"])
def test_the_basis_is_bullets_plane_space_to_rounding(fmt, ulps: int) -> None:
    n = _normals(fmt, 5000, 3)
    t0, t1 = plane_space_in(fmt, n)
    r0, r1 = plane_space(-n)
    eps = 2.0 ** -fmt.man_bits
    assert np.abs(t0 - r0).max() <= ulps * eps and np.abs(t1 - r1).max() <= ulps * eps
    assert np.array_equal(fmt.round(t0), t0) and np.array_equal(fmt.round(t1), t1)


def test_layout_and_cycle_model_know_the_option() -> None:
    default = sf.StreamLayout(FP32, impulses_in_records=True)
    lay = sf.StreamLayout(FP32, impulses_in_records=True, tangents_on_chip=True)
    assert (default.friction_bits, default.friction_beats) == (704, 2)
    assert (lay.friction_bits, lay.friction_beats, lay.friction_lam_word, lay.friction_lamt_word) == (512, 1, 8, 12)
    # two pipes per lane: the friction pipe that derives the tangents has its own, longer latency
    shape = KernelShape.of(FP32, 512, impulses_in_records=True, tangents_on_chip=True, shared_datapath=False)
    assert shape.friction_latency == schedule(GRAPHS["pgs_friction_pipe_tb"]()).latency_for(FP32.man_bits)
    assert shape.friction_latency > KernelShape.of(FP32, 512, shared_datapath=False).friction_latency
    assert shape.friction_beats == 1
    # the shared datapath binds it within the contact pass's latency, as every other option's
    shared = KernelShape.of(FP32, 512, impulses_in_records=True, tangents_on_chip=True)
    assert shared.friction_latency == shared.contact_latency == SHARED_GRAPHS["pgs_shared_pipe_tb"]().latency_for(
        FP32.man_bits) == KernelShape.of(FP32, 512).friction_latency
    job = pile_job()
    derived = job.tangents_derived()
    assert derived.tangents_on_chip and derived.stream_layout(512).friction_beats == 1
    assert np.array_equal(derived.cons.tangent, derive_tangents(job.cons, FP32).tangent)
    assert not np.array_equal(derived.cons.tangent, job.cons.tangent)  # rounding differs from the host's


def test_the_stream_omits_the_tangents() -> None:
    """The packer writes the friction record without t0, t1 for the kernel that derives them: n, c, f_jac_inv, then
    the impulses, one 512-bit beat in fp32; the contact records are unchanged."""
    job = pile_job().impulses_travelling().tangents_derived()
    lay = job.stream_layout(512)
    slots = job.slots
    stream = sf.pack_constraint_stream(FP32, job.cons, job.schedule, job.params, 512, job.start_impulses, True)
    streamed = sf.pack_constraint_stream(FP32, job.cons, job.schedule, job.params, 512, job.start_impulses)
    m, iters = len(slots), job.params.iterations  # contact passes first, then the friction passes
    assert stream.num_beats == m * iters * (lay.contact_beats + lay.friction_beats)
    assert streamed.num_beats == stream.num_beats + m * iters  # two beats per friction record there
    contact_beats = m * iters * lay.contact_beats
    assert np.array_equal(stream.data[:contact_beats], streamed.data[:contact_beats])
    _, words = sf.unpack_records(stream.data[contact_beats:contact_beats + m], lay.friction_record_words, 32, 512,
                                 header=True)
    want = np.concatenate([job.cons.normal[slots], job.cons.center[slots], job.cons.f_jac_inv[slots]], axis=1)
    assert np.array_equal(words[:, :lay.friction_lam_word], FP32.encode(want))
    assert np.array_equal(words[:, lay.friction_lam_word:], np.zeros((m, 6), np.uint64))  # cold start: zeros


def test_the_window_kernel_refuses_derived_tangents() -> None:
    with pytest.raises(ValueError, match="no tangents derived on chip"):
        dataclasses.replace(pile_job(), impulses_in_records=False).tangents_derived().windowed(1024)
