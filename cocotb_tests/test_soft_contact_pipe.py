"""The soft contact pipe (``pgs_contact_pipe_soft``, the kernel's SOFT_CONTACT = 1) interpreted in Python
(``Graph.evaluate``, the software twin of the emitted RTL) against the golden model's soft row
(``models.golden.contact_solver.contact_solve`` with ``soft_keep``) bit for bit, in every kernel format, on the
vectors of a golden solve of a stack with speculative points, static and dynamic rows and impulses from earlier
passes; with ``in_soft`` clear it is the rigid pipe bit for bit; its latency is the rigid pipe's. No RTL needed."""

from __future__ import annotations

import numpy as np
import pytest

from models.kernel import kernel_vectors as kv
from models import scenes
from models.setup.constraints import body_table, setup_constraints
from models.golden.contact_solver import SolverParams
from models.formats.number_format import BF16, FP16, FP32, NumberFormat
from models.golden.soft_contact import SoftContact
from rtl.gen.kernel_graphs import GRAPHS, SOFT_KEEP_WORDS, contact_graph, contact_in
from rtl.gen.operator_schedule import schedule

SOFT = SoftContact(hertz=15.0, damping_ratio=1.0)


@pytest.fixture(scope="module")
def stack_frame():  # noqa: ANN201
    return scenes.load_or_capture("stack")


def _vectors(frame, fmt: NumberFormat) -> np.ndarray:  # noqa: ANN001
    """Contact-pipe inputs of a 4-iteration golden solve of the stack, a third of the points made speculative
    (bias > 0: the soft row keeps their impulse whole) and one in ten biases -0 (not speculative)."""
    bodies = body_table(frame).rounded(fmt)
    cons = setup_constraints(frame, bodies).rounded(fmt)
    words = kv.scene_vectors(bodies, cons, fmt, SolverParams(iterations=4)).contact.copy()
    rng = np.random.default_rng(7)
    bias = words[:, 19:23]
    flip = rng.random(bias.shape) < 1.0 / 3.0
    bias[flip] = np.abs(bias[flip]) + fmt.round(np.float64(0.01))
    bias[rng.random(bias.shape) < 0.1] = -0.0
    return words


def _keeps(fmt: NumberFormat) -> tuple[float, float]:
    keep = SOFT.keep(1.0 / 120.0)
    return float(fmt.round(np.float64(keep[0]))), float(fmt.round(np.float64(keep[1])))


def _soft_words(words: np.ndarray, keep: tuple[float, float]) -> np.ndarray:
    return np.concatenate([words, np.broadcast_to(np.asarray(keep), (words.shape[0], 2))], axis=1)


def _same(a: np.ndarray, b: np.ndarray, fmt: NumberFormat, what: str) -> None:
    bad = np.argwhere(fmt.encode(a) != fmt.encode(b))
    assert not len(bad), f"{what}: differs at {bad[:8].tolist()}"


@pytest.mark.parametrize("fmt", [FP32, FP16, BF16], ids=lambda f: f.name)
def test_soft_pipe_is_the_golden_soft_row(stack_frame, fmt: NumberFormat) -> None:  # noqa: ANN001
    words = _vectors(stack_frame, fmt)
    keep = _keeps(fmt)
    assert keep[0] != 1.0 and keep[1] != 1.0 and keep[0] != keep[1]
    lam = words[:, 23:27]
    assert np.count_nonzero(lam) > lam.size // 4, "the vectors must carry impulses from earlier passes"
    mass = words[:, 45:47]
    assert np.any(mass == 0.0) and np.any(np.all(mass != 0.0, axis=1)), "static and dynamic rows both"
    g = contact_graph(soft=True)
    with np.errstate(all="ignore"):
        out = g.evaluate(fmt, _soft_words(words, keep), np.ones((len(words), 1), dtype=bool))
        golden = kv.contact_golden(fmt, words, soft_keep=keep)
        rigid = kv.contact_golden(fmt, words)
    _same(out, golden, fmt, f"soft pipe against the golden soft row ({fmt.name})")
    # the test can fail: the soft row changes the impulses of the non-speculative points
    assert np.count_nonzero(fmt.encode(golden[:, :4]) != fmt.encode(rigid[:, :4])) > len(words) // 4


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
def test_soft_pipe_with_soft_clear_is_the_rigid_pipe(stack_frame, fmt: NumberFormat) -> None:  # noqa: ANN001
    words = _vectors(stack_frame, fmt)
    with np.errstate(all="ignore"):
        out = contact_graph(soft=True).evaluate(fmt, _soft_words(words, _keeps(fmt)),
                                                np.zeros((len(words), 1), dtype=bool))
        rigid = GRAPHS["pgs_contact_pipe"]().evaluate(fmt, words)
    _same(out, rigid, fmt, "soft pipe, in_soft clear, against the rigid pipe")
    _same(out, kv.contact_golden(fmt, words), fmt, "soft pipe, in_soft clear, against the golden rigid row")


def test_soft_pipe_layout_and_latency() -> None:
    assert contact_in(soft=True) == contact_in() + list(SOFT_KEEP_WORDS)
    g = contact_graph(soft=True)
    assert g.name == "pgs_contact_pipe_soft" and [v.name for v in g.bool_inputs] == ["in_soft"]
    # the multiply lam * keep is off the critical path: the rigid pipe's latency in every format, so the cycle
    # model (which reads the rigid pipe's latency) is the soft kernel's too
    for man_bits in (5, 7, 10, 23):
        assert schedule(g).latency_for(man_bits) == schedule(GRAPHS["pgs_contact_pipe"]()).latency_for(man_bits)
    with pytest.raises(ValueError, match="3 inverse-inertia words"):
        contact_graph(6, soft=True)
