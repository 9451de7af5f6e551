"""Stream format: pack/unpack round trips, bit positions and sizes."""

from __future__ import annotations

import numpy as np
import pytest

from models.kernel import stream_format as sf
from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS, Impulses, SolverParams
from models.formats.number_format import BF16, FP16, FP32, NumberFormat
from models.kernel import record_window
from models.order import manifold_schedule

FORMATS = [FP32, FP16, BF16, NumberFormat("e6m9", 6, 9)]


def _bodies(rng: np.random.Generator, n: int) -> BodyTable:
    inv_mass = rng.uniform(0.1, 2.0, n)
    inv_mass[0] = 0.0
    return BodyTable(position=rng.normal(size=(n, 3)), orientation=rng.normal(size=(n, 4)),
                     linear_velocity=rng.normal(size=(n, 3)), angular_velocity=rng.normal(size=(n, 3)),
                     inv_mass=inv_mass, inv_inertia=rng.uniform(0, 3, (n, 3)))


def _cons(rng: np.random.Generator, m: int, n: int) -> ConstraintSet:
    return ConstraintSet(
        body_a=rng.integers(0, n, m), body_b=rng.integers(0, n, m), num_points=rng.integers(1, 5, m),
        normal=rng.normal(size=(m, 3)), points=rng.normal(size=(m, 4, 3)), jac_inv=-rng.uniform(0, 2, (m, 4)),
        bias=rng.normal(size=(m, 4)), center=rng.normal(size=(m, 3)), tangent=rng.normal(size=(m, 2, 3)),
        f_jac_inv=-rng.uniform(0, 2, (m, 2)), spin_damp=rng.integers(0, 2, m).astype(bool))


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("fmt", FORMATS, ids=lambda f: f.name)
@pytest.mark.parametrize("beat", [128, 512, 64])
def test_body_round_trip(fmt: NumberFormat, beat: int) -> None:
    rng = np.random.default_rng(1)
    bodies = _bodies(rng, 37).rounded(fmt)
    stream = sf.pack_body_table(fmt, bodies, beat)
    layout = sf.StreamLayout(fmt, body_beat_bits=beat)
    assert stream.data.shape == (37 * layout.body_in_beats, beat // 8)
    assert stream.last.sum() == 1 and stream.last[-1]
    back = sf.unpack_body_table(fmt, stream.data, beat)
    for name in ("position", "orientation", "linear_velocity", "angular_velocity", "inv_mass", "inv_inertia"):
        assert _same(getattr(back, name), getattr(bodies, name)), name
    out = sf.pack_body_out(fmt, bodies, beat)
    assert out.data.shape[0] == 37 * layout.body_out_beats
    applied = sf.apply_body_out(fmt, bodies, out.data, beat)
    assert _same(applied.position, bodies.position) and _same(applied.angular_velocity, bodies.angular_velocity)


@pytest.mark.parametrize("fmt", FORMATS, ids=lambda f: f.name)
@pytest.mark.parametrize("interleaved", [False, True])
def test_constraint_stream_round_trip(fmt: NumberFormat, interleaved: bool) -> None:
    rng = np.random.default_rng(2)
    cons = _cons(rng, 29, 50).rounded(fmt)
    schedule = np.concatenate([rng.permutation(29), [-1, -1]])
    rng.shuffle(schedule)
    params = SolverParams(iterations=3, interleaved=interleaved)
    layout = sf.StreamLayout(fmt)
    stream = sf.pack_constraint_stream(fmt, cons, schedule, params)
    idx = manifold_schedule.schedule_manifolds(schedule)
    kinds = [CONTACT_PASS] * 3 + [FRICTION_PASS] * 3 if not interleaved else [CONTACT_PASS, FRICTION_PASS] * 3
    pos = 0
    for kind in kinds:
        nb = layout.contact_beats if kind == CONTACT_PASS else layout.friction_beats
        beats = stream.data[pos:pos + 29 * nb]
        assert stream.last[pos + 29 * nb - 1] and not stream.last[pos:pos + 29 * nb - 1].any()
        pos += 29 * nb
        rec = sf.unpack_constraint_records(fmt, beats, kind)
        assert np.array_equal(rec["body_a"], cons.body_a[idx])
        assert np.array_equal(rec["body_b"], cons.body_b[idx])
        assert np.array_equal(rec["spin_damp"], cons.spin_damp[idx])
        assert _same(rec["normal"], cons.normal[idx])
        if kind == CONTACT_PASS:
            assert _same(rec["points"], cons.points[idx]) and _same(rec["jac_inv"], cons.jac_inv[idx])
            assert _same(rec["bias"], cons.bias[idx])
        else:
            assert _same(rec["center"], cons.center[idx]) and _same(rec["tangent"], cons.tangent[idx])
            assert _same(rec["f_jac_inv"], cons.f_jac_inv[idx])
    assert pos == stream.num_beats
    assert stream.data.nbytes == 29 * layout.bytes_per_manifold(params)


def test_bit_positions_fp32() -> None:
    """Header in bits 63:0, word k at bits 64 + 32k: check raw bytes."""
    cons = _cons(np.random.default_rng(3), 1, 10)
    cons.body_a[:] = 0x1234
    cons.body_b[:] = 0x5678
    cons.spin_damp[:] = True
    cons.normal[:] = [1.0, -2.0, 0.5]
    stream = sf.pack_constraint_stream(FP32, cons, np.array([0]), SolverParams(iterations=1))
    raw = stream.data[:2].tobytes()  # the contact record: 2 beats of 64 bytes
    assert int.from_bytes(raw[0:8], "little") == 0x1234 | (0x5678 << 32) | (1 << 63)
    assert int.from_bytes(raw[8:12], "little") == 0x3F800000
    assert int.from_bytes(raw[12:16], "little") == 0xC0000000
    assert int.from_bytes(raw[16:20], "little") == 0x3F000000
    assert raw[8 + 23 * 4:].count(0) == len(raw) - 8 - 23 * 4  # padding is zero


def test_sizes() -> None:
    l32, l16 = sf.StreamLayout(FP32), sf.StreamLayout(FP16)
    assert (l32.contact_bits, l32.friction_bits) == (800, 512)
    assert (l32.contact_bytes, l32.friction_bytes, l32.body_in_bytes, l32.body_out_bytes) == (128, 64, 80, 64)
    assert (l16.contact_bits, l16.friction_bits) == (432, 288)
    assert (l16.contact_bytes, l16.friction_bytes, l16.body_in_bytes, l16.body_out_bytes) == (64, 64, 48, 32)
    p = SolverParams(iterations=4)
    assert l32.bytes_per_manifold(p) == 4 * 128 + 4 * 64
    assert l32.bytes_per_step(10, 3, p) == {"constraints": 3 * 768, "body_in": 800, "body_out": 640}


def test_header_range() -> None:
    cons = _cons(np.random.default_rng(4), 2, 10)
    cons.body_b[0] = 1 << 31
    with pytest.raises(ValueError):
        sf.constraint_header(cons, np.arange(2))


def test_large_streams_pack_in_chunks() -> None:
    """Streams longer than one packing chunk round-trip and match record-by-record packing."""
    rng = np.random.default_rng(5)
    n = 20000
    words = rng.integers(0, 1 << 32, size=(n, 23), dtype=np.uint64)
    header = rng.integers(0, 1 << 63, size=n, dtype=np.uint64)
    beats = sf.pack_records(header, words, 32, 512)
    hdr, back = sf.unpack_records(beats, 23, 32, 512, header=True)
    assert np.array_equal(back, words) and np.array_equal(hdr, header)
    k = 12345
    one = sf.pack_records(header[k:k + 1], words[k:k + 1], 32, 512)
    assert np.array_equal(beats[2 * k:2 * k + 2], one)


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
@pytest.mark.parametrize("fetch_passes", [1, 3, 6, 8])
def test_window_stream(fmt: NumberFormat, fetch_passes: int) -> None:
    """The window kernel's stream: ceil(6 / fetch_passes) fetches, each the contact then the friction words of every
    slot's manifold behind the header (an empty lane, -1: all-ones header and zero words), TLAST on each fetch's
    last beat."""
    rng = np.random.default_rng(3)
    cons = _cons(rng, 17, 30).rounded(fmt)
    slots = np.insert(rng.permutation(17), 5, -1)
    params = SolverParams(iterations=3)
    layout = sf.StreamLayout(fmt)
    stream = sf.pack_window_stream(fmt, cons, slots, params, fetch_passes)
    fetches = -(-6 // fetch_passes)
    assert record_window.window_fetches(params, fetch_passes) == fetches
    per_fetch = 18 * layout.window_beats
    assert stream.num_beats == fetches * per_fetch and stream.data.nbytes == fetches * 18 * layout.window_bytes
    assert np.flatnonzero(stream.last).tolist() == [(f + 1) * per_fetch - 1 for f in range(fetches)]
    real = slots >= 0
    hdr, words = sf.unpack_records(stream.data[:per_fetch], sf.WINDOW_WORDS, fmt.width, 512, header=True)
    assert np.array_equal(hdr[real], sf.constraint_header(cons, slots[real])) and hdr[5] == sf.EMPTY_HEADER
    assert np.array_equal(words[real, :sf.CONTACT_WORDS], sf.contact_words(fmt, cons, slots[real]))
    assert np.array_equal(words[real, sf.CONTACT_WORDS:], sf.friction_words(fmt, cons, slots[real]))
    assert not words[5].any()
    assert np.array_equal(stream.data[per_fetch:], np.tile(stream.data[:per_fetch], (fetches - 1, 1)))
    with pytest.raises(ValueError):
        record_window.window_fetches(params, 0)


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
def test_body_record_per_inertia_mode(fmt: NumberFormat) -> None:
    """The body-in record carries 1, 3 or 6 inverse-inertia words; each mode round-trips, a table whose mode
    needs more words than the record carries is refused."""
    from models.setup.inertia import world_inverse_inertia

    rng = np.random.default_rng(7)
    n = 11
    base = _bodies(rng, n)
    q = rng.normal(size=(n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    scalar = BodyTable(**{**base.__dict__, "inv_inertia": np.repeat(rng.uniform(0.1, 3, (n, 1)), 3, axis=1)})
    full = BodyTable(**{**base.__dict__, "inv_inertia": world_inverse_inertia(q, rng.uniform(0.1, 3, (n, 3)))})
    assert [sf.body_in_word_count(w) for w in (1, 3, 6)] == [15, 17, 20] and sf.BODY_IN_WORDS == 17
    for table, words in ((scalar, 1), (scalar, 3), (base, 3), (base, 6), (full, 6)):
        t = table.rounded(fmt)
        stream = sf.pack_body_table(fmt, t, 128, inertia_words=words)
        layout = sf.StreamLayout(fmt, inertia_words=words)
        assert stream.data.shape[0] == n * layout.body_in_beats
        back = sf.unpack_body_table(fmt, stream.data, 128, inertia_words=words)
        want = t.inv_inertia if words != 6 or t.inv_inertia.shape[1] == 6 else \
            np.concatenate([t.inv_inertia, np.zeros((n, 3))], axis=1)
        assert _same(back.inv_inertia, want) and _same(back.angular_velocity, t.angular_velocity)
    # the default record is today's: 17 words, bit for bit the diagonal mode's
    assert np.array_equal(sf.pack_body_table(fmt, base.rounded(fmt)).data,
                          sf.pack_body_table(fmt, base.rounded(fmt), inertia_words=3).data)
    for table, words, mode in ((base, 1, "diagonal"), (full, 3, "full"), (full, 1, "full")):
        with pytest.raises(ValueError, match=f"in the {mode} mode"):
            sf.pack_body_table(fmt, table.rounded(fmt), inertia_words=words)
    with pytest.raises(ValueError, match="1, 3 or 6"):
        sf.StreamLayout(fmt, inertia_words=4).body_in_beats
    # the kernel build for each table: the 6-word build for the full mode only, the default build otherwise
    assert [sf.kernel_inertia_words(t) for t in (scalar, base, full)] == [3, 3, 6]
    # as few as each table's mode needs (make sim INERTIA=scene): the scalar table's 1-word build
    assert [sf.kernel_inertia_words(t, scene=True) for t in (scalar, base, full)] == [1, 3, 6]



@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
def test_friction_record_with_the_coefficient_word(fmt: NumberFormat) -> None:
    """A manifold's own friction coefficient is the friction record's last word (14 + 1 words); the stream's
    friction records grow by it, the contact records do not; the kernel build takes it (MU_W = 1)."""
    rng = np.random.default_rng(7)
    cons = _cons(rng, 9, 12)
    assert cons.friction_words == 0
    cons.friction = rng.uniform(0.1, 1.2, (9, 1))
    cons = cons.rounded(fmt)
    assert cons.friction_words == 1
    params = SolverParams(iterations=2)
    layout = sf.StreamLayout(fmt, friction_words=1)
    assert layout.friction_bits == sf.StreamLayout(fmt).friction_bits + fmt.width
    assert layout.window_bits == sf.StreamLayout(fmt).window_bits + fmt.width
    schedule = rng.permutation(9)
    stream = sf.pack_constraint_stream(fmt, cons, schedule, params)
    assert stream.data.nbytes == 9 * layout.bytes_per_manifold(params)
    start = 2 * 9 * layout.contact_beats
    rec = sf.unpack_constraint_records(fmt, stream.data[start:start + 9 * layout.friction_beats], FRICTION_PASS,
                                       friction_words=1)
    assert _same(rec["friction"], cons.friction[schedule]) and _same(rec["f_jac_inv"], cons.f_jac_inv[schedule])
    words = sf.friction_words(fmt, cons, schedule)
    assert words.shape == (9, sf.FRICTION_WORDS + 1)
    assert np.array_equal(words[:, -1], fmt.encode(cons.friction[schedule, 0]))


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
@pytest.mark.parametrize("fetch_passes", [1, 3])
def test_window_stream_with_impulses(fmt: NumberFormat, fetch_passes: int) -> None:
    """The window kernel whose impulses travel with the records: each fetch serves passes of one kind and streams
    that kind's record with the impulses the step starts from (the streaming kernel's records with their
    impulses), every record padded to the longer kind's beats, TLAST on each fetch's last beat; an empty lane
    all-ones header and zero words."""
    rng = np.random.default_rng(5)
    cons = _cons(rng, 17, 30).rounded(fmt)
    slots = np.insert(rng.permutation(17), 5, -1)
    params = SolverParams(iterations=3)
    initial = Impulses(fmt.round(rng.uniform(0, 1, (17, 4))), fmt.round(rng.uniform(-0.1, 0.1, (17, 2))))
    layout = sf.StreamLayout(fmt, impulses_in_records=True)
    assert layout.window_bits == max(layout.contact_bits, layout.friction_bits) == 64 + 27 * fmt.width
    stream = sf.pack_window_stream(fmt, cons, slots, params, fetch_passes, impulses=initial)
    kinds = record_window.window_fetch_kinds(params, fetch_passes, one_kind=True)
    assert kinds == [CONTACT_PASS] * (3 // fetch_passes) + [FRICTION_PASS] * (3 // fetch_passes)
    per_fetch = 18 * layout.window_beats
    assert stream.num_beats == len(kinds) * per_fetch
    assert np.flatnonzero(stream.last).tolist() == [(f + 1) * per_fetch - 1 for f in range(len(kinds))]
    real = slots >= 0
    for f, kind in enumerate(kinds):
        beats = stream.data[f * per_fetch:(f + 1) * per_fetch]
        nwords = layout.contact_record_words if kind == CONTACT_PASS else layout.friction_record_words
        hdr, words = sf.unpack_records(beats, nwords, fmt.width, 512, header=True)
        assert hdr[5] == sf.EMPTY_HEADER and not words[5].any()
        assert np.array_equal(hdr[real], sf.constraint_header(cons, slots[real]))
        lam = fmt.encode(initial.normal[slots[real]])
        if kind == CONTACT_PASS:
            want = np.concatenate([sf.contact_words(fmt, cons, slots[real]), lam], axis=1)
        else:
            want = np.concatenate([sf.friction_words(fmt, cons, slots[real]), lam,
                                   fmt.encode(initial.friction[slots[real]])], axis=1)
        assert np.array_equal(words[real], want)


def test_window_fetch_kinds_and_read_share() -> None:
    """Fetches of one kind: fetch_passes must divide the iterations (or be 1 with the kinds interleaved); the DDR
    read share counts each fetch's records read and its one kind's impulses written, per slot."""
    four = SolverParams(iterations=4)
    assert record_window.window_fetch_kinds(four, 4) == [CONTACT_PASS, FRICTION_PASS]
    assert record_window.window_fetch_kinds(four, 3) == [CONTACT_PASS, None, FRICTION_PASS]
    assert record_window.window_fetch_kinds(SolverParams(iterations=2, interleaved=True), 2) == [None, None]
    for params, fetch in ((four, 3), (four, 8), (SolverParams(iterations=2, interleaved=True), 2)):
        with pytest.raises(ValueError, match="one kind"):
            record_window.window_fetch_kinds(params, fetch, one_kind=True)
    lay = sf.StreamLayout(FP32, impulses_in_records=True)
    reads, writes = 2 * lay.window_bytes, 16 + 8  # a contact fetch writes lam[4], a friction fetch lamT[2]
    assert lay.window_bytes == 128
    assert lay.ddr_read_share(four, 4) == pytest.approx(reads / (reads + writes))
    assert sf.StreamLayout(FP32).ddr_read_share(four, 4) == 1.0  # on-chip impulses: nothing written
    assert sf.unpack_impulse_out(FP16, bytes(range(32)), lanes=2).shape == (4, 4)
