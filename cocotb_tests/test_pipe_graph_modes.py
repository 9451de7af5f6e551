"""The contact and friction datapath graphs in every inverse-inertia mode (1, 3, 6 words per body) and with a
per-manifold friction word, interpreted in Python (``Graph.evaluate``, the software twin of the emitted RTL),
against the golden model bit for bit, on the vectors of golden solves of a frame in the full mode (a rotated
non-cube box on a slope in the ``bullet2`` convention, mixed friction) and of synthetic tables. No RTL needed."""

from __future__ import annotations

import numpy as np
import pytest

from models.kernel import kernel_vectors as kv
from models import scenes
from models.setup.constraints import BodyTable, ConstraintSet, body_table, setup_constraints
from models.formats.frame import BulletConvention
from models.setup.inertia import InertiaMode, world_inverse_inertia
from models.formats.number_format import FP16, FP32, NumberFormat
from rtl.gen.kernel_graphs import (GRAPHS, contact_graph, contact_in, friction_graph, friction_in, inertia_ports,
                                   pipe_module)
from rtl.gen.operator_schedule import schedule


def _check(graph_out: np.ndarray, golden: np.ndarray, fmt: NumberFormat, what: str) -> None:
    bad = np.argwhere(fmt.encode(graph_out) != fmt.encode(golden))
    assert not len(bad), f"{what}: the graph differs from the golden model at {bad[:8].tolist()}"


def _twin(graph, fmt: NumberFormat, words: np.ndarray, flags: np.ndarray | None = None) -> np.ndarray:  # noqa: ANN001
    with np.errstate(all="ignore"):
        return graph.evaluate(fmt, words, None if flags is None else flags[:, None])


@pytest.fixture(scope="module")
def incline_frame():  # noqa: ANN201
    frame = scenes.load_or_capture("incline", angle_deg=30.0, box_half_extents=(0.6, 0.15, 0.35))
    frame.meta["bullet_convention"] = BulletConvention.BULLET2.value
    frame.friction = np.array([0.9, 0.5, 1.1])  # ground, slope, box: the pairs' combined friction varies
    return frame


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
def test_full_mode_graphs_match_the_golden_on_a_rotated_box(incline_frame, fmt: NumberFormat) -> None:  # noqa: ANN001
    bodies = body_table(incline_frame)
    cons = setup_constraints(incline_frame, bodies)
    assert bodies.inertia_mode is InertiaMode.FULL and cons.num_manifolds > 0
    b, c = bodies.rounded(fmt), cons.rounded(fmt)
    vec = kv.scene_vectors(b, c, fmt, inertia_words=6)
    assert vec.contact.shape[1] == kv.contact_n_in(6) == len(contact_in(6)) == 59
    _check(_twin(contact_graph(6), fmt, vec.contact), kv.contact_golden(fmt, vec.contact, 6), fmt, "contact, full")
    _check(_twin(friction_graph(inertia_words=6), fmt, vec.friction, vec.spin_damp),
           kv.friction_golden(fmt, vec.friction, vec.spin_damp, inertia_words=6), fmt, "friction, full")
    # the frame's friction varies from pair to pair: the friction pipe takes it as a word
    per = setup_constraints(incline_frame, bodies, friction_coeff=0.7).rounded(fmt)
    assert per.friction_words == 1
    vec_mu = kv.scene_vectors(b, per, fmt, inertia_words=6)
    assert vec_mu.friction.shape[1] == kv.friction_n_in(6, True) == len(friction_in(6, True))
    _check(_twin(friction_graph(inertia_words=6, manifold_friction=True), fmt, vec_mu.friction, vec_mu.spin_damp),
           kv.friction_golden(fmt, vec_mu.friction, vec_mu.spin_damp, inertia_words=6, manifold_friction=True),
           fmt, "friction, full, mu word")
    # the full product matters: the same words through the diagonal pipe (the unrotated diagonal) differ
    diag = np.concatenate([vec.contact[:, :47], vec.contact[:, 47:50], vec.contact[:, 53:56]], axis=1)
    assert np.any(fmt.encode(_twin(contact_graph(), fmt, diag)) != fmt.encode(kv.contact_golden(fmt, vec.contact, 6)))


def _synthetic(rng: np.random.Generator, n: int, mode: InertiaMode) -> BodyTable:
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    local = rng.uniform(0.2, 2.0, (n, 3))
    if mode is InertiaMode.SCALAR:
        local[:] = local[:, :1]
    if mode is not InertiaMode.FULL:
        q[:] = (0.0, 0.0, 0.0, 1.0)
    inv_mass = rng.uniform(0.1, 3.0, n)
    inv_mass[0] = 0.0
    inertia = world_inverse_inertia(q, local)
    inertia[0] = 0.0
    return BodyTable(position=rng.normal(size=(n, 3)), orientation=q, linear_velocity=rng.normal(size=(n, 3)),
                     angular_velocity=rng.normal(size=(n, 3)), inv_mass=inv_mass,
                     inv_inertia=inertia if mode is InertiaMode.FULL else inertia[:, :3].copy())


def _synthetic_cons(rng: np.random.Generator, m: int, n: int, bodies: BodyTable) -> ConstraintSet:
    a = rng.integers(0, n - 1, m)
    b = a + 1 + rng.integers(0, n - 1 - a)
    normal = rng.normal(size=(m, 3))
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    t0 = np.cross(normal, rng.normal(size=(m, 3)))
    t0 /= np.linalg.norm(t0, axis=1, keepdims=True)
    return ConstraintSet(
        body_a=a, body_b=b, num_points=np.full(m, 4), normal=normal, points=rng.normal(size=(m, 4, 3)),
        jac_inv=-rng.uniform(0.01, 0.2, (m, 4)), bias=rng.normal(size=(m, 4)), center=rng.normal(size=(m, 3)),
        tangent=np.stack([t0, np.cross(normal, t0)], axis=1), f_jac_inv=-rng.uniform(0.01, 0.2, (m, 2)),
        spin_damp=rng.integers(0, 2, m).astype(bool), friction=rng.uniform(0.1, 1.5, (m, 1)))


@pytest.mark.parametrize("mode", list(InertiaMode), ids=lambda m: m.value)
def test_every_mode_matches_the_golden_on_synthetic_tables(mode: InertiaMode) -> None:
    rng = np.random.default_rng(list(InertiaMode).index(mode) + 11)
    bodies = _synthetic(rng, 40, mode).rounded(FP32)
    assert bodies.inertia_mode is mode
    cons = _synthetic_cons(rng, 60, 40, bodies).rounded(FP32)
    vec = kv.scene_vectors(bodies, cons, FP32, inertia_words=mode.words)
    assert np.all(np.isfinite(vec.contact)) and np.all(np.isfinite(vec.friction))
    _check(_twin(contact_graph(mode.words), FP32, vec.contact), kv.contact_golden(FP32, vec.contact, mode.words),
           FP32, f"contact, {mode.value}")
    _check(_twin(friction_graph(inertia_words=mode.words, manifold_friction=True), FP32, vec.friction, vec.spin_damp),
           kv.friction_golden(FP32, vec.friction, vec.spin_damp, inertia_words=mode.words, manifold_friction=True),
           FP32, f"friction, {mode.value}")
    # a narrower pipe than the table's mode is refused rather than fed a truncated inertia
    if mode is not InertiaMode.SCALAR:
        with pytest.raises(ValueError, match="words per body"):
            kv.scene_vectors(bodies, cons, FP32, inertia_words=1)


def test_kernel_build_graphs_and_names_are_unchanged() -> None:
    """The 3-word graphs without a friction word are the generated kernel's; the variants are named apart."""
    assert [pipe_module("pgs_contact_pipe", w) for w in (1, 3, 6)] == [
        "pgs_contact_pipe_scalar", "pgs_contact_pipe", "pgs_contact_pipe_full"]
    assert pipe_module("pgs_friction_pipe", 6, True) == "pgs_friction_pipe_full_mu"
    assert GRAPHS["pgs_contact_pipe"]().name == contact_graph(3).name == "pgs_contact_pipe"
    assert inertia_ports(6)[:6] == [f"IInvA_{c}" for c in ("xx", "yy", "zz", "xy", "xz", "yz")]
    with pytest.raises(ValueError, match="1, 3 or 6"):
        contact_graph(4)
    # the symmetric product (two more adds per component) is off the critical path: every mode has the kernel's
    # pipe latencies, so the cycle model (which reads those) counts only the body record's beats per mode
    for man_bits in (5, 10, 23):
        assert {schedule(contact_graph(w)).latency_for(man_bits) for w in (1, 3, 6)} == {
            schedule(GRAPHS["pgs_contact_pipe"]()).latency_for(man_bits)}
        assert {schedule(friction_graph(inertia_words=w, manifold_friction=f)).latency_for(man_bits)
                for w in (1, 3, 6) for f in (False, True)} == {
            schedule(GRAPHS["pgs_friction_pipe"]()).latency_for(man_bits)}
