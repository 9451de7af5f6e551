"""The golden rounding: casts against the bit-level rule, special values, IEEE min/max; the event flags."""

import numpy as np
import pytest

from models.formats.number_format import (BF16, FP16, FP32, FpEvents, NumberFormat, ieee_maximum, ieee_minimum,
                                          parse_format)


def _same(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return ((a == b) & (np.signbit(a) == np.signbit(b))) | (np.isnan(a) & np.isnan(b))


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
def test_cast_rounding_matches_bitwise_rule(fmt: NumberFormat) -> None:
    rng = np.random.default_rng(7)
    x = rng.standard_normal(400_000) * np.exp(rng.uniform(-120, 120, 400_000))
    mn = fmt.min_normal
    edge = mn * (1 + rng.integers(-8, 9, 20_000) * 2.0 ** -(fmt.man_bits + 3))
    mx = fmt.max_finite * (1 + rng.integers(-4, 5, 1000) * 2.0 ** -(fmt.man_bits + 2))
    x = np.concatenate([x, edge, -edge, mx, -mx, [np.nan, np.inf, -np.inf, 0.0, -0.0]])
    assert np.all(_same(fmt.round(x), fmt.round_bitwise(x)))


def _cast_format_edges(fmt: NumberFormat) -> np.ndarray:
    """Every value of ``fmt``'s binade edges and rounding boundaries: each power of two of the format's range
    and beyond it, with mantissas at, just off and halfway between representable values (ties both ways)."""
    rng = np.random.default_rng(11)
    p = fmt.man_bits
    exps = np.arange(fmt.emin - p - 3, fmt.emax + 3)
    steps = np.concatenate([np.arange(-3, 4), (1 << (p + 1)) - np.arange(4), rng.integers(0, 1 << (p + 1), 24)])
    # m / 2^(p+1) in [0, 1): even m are representable mantissas, odd m halfway between two; +-2^-52 off both
    frac = np.array([s * 2.0 ** -(p + 1) + d for s in steps for d in (0.0, 2.0 ** -52, -(2.0 ** -52))])
    mags = np.ldexp(1.0 + np.abs(frac)[None, :], exps[:, None]).ravel()
    return np.concatenate([mags, -mags, [0.0, -0.0, np.inf, -np.inf, np.nan, fmt.max_finite, -fmt.min_normal]])


def _fp16_exhaustive() -> np.ndarray:
    """Every binary16 value, each one float64 ulp either side, and every midpoint between neighbours (+-1 ulp)."""
    v = np.arange(1 << 16, dtype=np.uint16).view(np.float16).astype(np.float64)
    v = np.sort(v[np.isfinite(v)])
    mid = (v[1:] + v[:-1]) / 2
    pts = np.concatenate([v, mid, 65504.0 * (1 + np.arange(-4, 5) * 2.0 ** -12)])
    return np.concatenate([pts, np.nextafter(pts, np.inf), np.nextafter(pts, -np.inf)])


@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
@pytest.mark.parametrize("chunk", [1, 7, 64])
def test_cast_rounding_chunks_match_bitwise_rule(fmt: NumberFormat, chunk: int) -> None:
    """The cast path element by element and in short arrays (most without a value near min normal, so the
    cast alone answers; some with one, so the flush applies): equal, sign and NaN included, to the rule. The
    values are shuffled (seed 5) and cut to a few thousand calls; fp16 adds its exhaustive set."""
    x = np.concatenate([_cast_format_edges(fmt)] + ([_fp16_exhaustive()] if fmt is FP16 else []))
    rng = np.random.default_rng(5)
    x = x[rng.permutation(x.shape[0])][: 6_000 * chunk]  # one call per row: a few thousand rows
    k = np.arange(-8, 9) * 2.0 ** -(fmt.man_bits + 3)  # around the flush threshold and the overflow boundary
    edges = np.concatenate([fmt.min_normal * (1 + k), fmt.max_finite * (1 + k), [0.0, np.inf, np.nan]])
    x = np.concatenate([x, edges, -edges])
    x = x[rng.permutation(x.shape[0])]
    x = x[: x.shape[0] // chunk * chunk].reshape(-1, chunk)
    got = np.stack([fmt.round(row) for row in x])
    want = fmt.round_bitwise(x)
    bad = ~_same(got, want)
    assert not bad.any(), f"{fmt.name}: {np.count_nonzero(bad)} differ, first x={x[bad][0]!r}: " \
        f"{got[bad][0]!r} against {want[bad][0]!r}"
    near_min_normal = np.abs(want) == fmt.min_normal
    assert near_min_normal.any() and (want == 0).any() and np.isinf(want).any()


def _bf16_oracle(x: np.ndarray) -> np.ndarray:
    """bfloat16 rounding by ml_dtypes (an implementation of its own: RNE from float32, its subnormals kept), with
    the format's flush: below min normal * (1 - 2^-9) a zero of the value's sign (tininess after rounding at 8
    significant bits). ``x`` must be float32 values, so that ml_dtypes's cast is the only rounding."""
    import ml_dtypes

    x32 = np.asarray(x, dtype=np.float64).astype(np.float32)
    assert np.array_equal(x32.astype(np.float64), x, equal_nan=True), "the oracle takes float32 values"
    with np.errstate(over="ignore"):
        r = x32.astype(ml_dtypes.bfloat16).astype(np.float64)
    tiny = np.abs(x) < BF16.min_normal * (1 - 2.0 ** -9)
    return np.where(tiny, np.where(np.signbit(x), -0.0, 0.0), r)


def test_bf16_rounding_against_ml_dtypes() -> None:
    """bf16, which no numpy cast rounds (the golden model uses the bit-level rule), against an independent
    bfloat16: every float32 binade edge and tie (``_cast_format_edges`` read as float32) and random float32 values
    over the whole exponent range, then +, -, x of random bf16 operands wherever the exact result is a float32 value
    (products always; sums up to an exponent gap of 16), so that ml_dtypes rounds it once."""
    rng = np.random.default_rng(13)
    edges = _cast_format_edges(BF16)
    edges = edges[np.isnan(edges) | (edges.astype(np.float32).astype(np.float64) == edges)]
    bits = rng.integers(0, 1 << 32, 300_000, dtype=np.uint64).astype(np.uint32)
    x = np.concatenate([edges, bits.view(np.float32).astype(np.float64)])
    got, want = BF16.round(x), _bf16_oracle(x)
    bad = ~_same(got, want)
    assert not bad.any(), f"{np.count_nonzero(bad)} differ, first x={x[bad][0]!r}: {got[bad][0]!r} vs {want[bad][0]!r}"
    assert (got == 0).any() and np.isinf(got).any() and (np.abs(got) == BF16.min_normal).any()
    a, b = (BF16.round(v) for v in rng.standard_normal((2, 200_000)) * np.exp2(rng.uniform(-130, 130, (2, 200_000))))
    for op in (BF16.add, BF16.sub, BF16.mul):
        exact = {BF16.add: np.add, BF16.sub: np.subtract, BF16.mul: np.multiply}[op](a, b)
        keep = exact.astype(np.float32).astype(np.float64) == exact
        assert keep.mean() > 0.5, keep.mean()  # most results are float32 values
        assert np.all(_same(op(a[keep], b[keep]), _bf16_oracle(exact[keep]))), op.__name__


@pytest.mark.filterwarnings("error")
@pytest.mark.parametrize("fmt", [FP32, FP16], ids=lambda f: f.name)
def test_cast_rounding_of_single_values(fmt: NumberFormat) -> None:
    """A Python float (as constants are given) rounds to a 0-d array equal to the rule's, without a warning."""
    k = np.arange(-8, 9) * 2.0 ** -(fmt.man_bits + 3)
    for v in np.concatenate([fmt.min_normal * (1 + k), -fmt.max_finite * (1 + k), [0.0, -0.0, np.nan, 1 / 3]]):
        got = fmt.round(float(v))
        assert got.shape == () and _same(got, fmt.round_bitwise(v)), (v, got)


def test_flush_rule_is_tininess_after_rounding() -> None:
    mn = FP16.min_normal
    # rounds up to min normal at 11 significant bits: kept
    assert FP16.round(mn * (1 - 2.0**-12)) == mn
    # just below the rounding boundary: flushed to a zero of the same sign
    below = FP16.round(-mn * (1 - 2.0**-11))
    assert below == 0.0 and np.signbit(below)
    # subnormal bit patterns read as signed zero
    assert FP32.decode(np.array([1], dtype=np.uint64))[0] == 0.0
    assert np.signbit(FP32.decode(np.array([0x80000001], dtype=np.uint64))[0])


@pytest.mark.parametrize("fmt", [FP32, FP16, BF16], ids=lambda f: f.name)
def test_encode_decode_round_trip_and_specials(fmt: NumberFormat) -> None:
    rng = np.random.default_rng(3)
    x = fmt.round(rng.standard_normal(10_000) * 10.0)
    assert np.all(_same(fmt.decode(fmt.encode(x)), x))
    assert int(fmt.encode(np.array([np.nan]))[0]) == fmt.canonical_nan_bits
    assert fmt.round(fmt.max_finite * 2) == np.inf
    assert fmt.round(-fmt.max_finite * 2) == -np.inf
    assert fmt.decode(fmt.encode(np.array([fmt.max_finite])))[0] == fmt.max_finite


def test_arithmetic_rounds_once() -> None:
    a, b = FP32.round(1.0), FP32.round(2.0**-24)
    assert FP32.add(a, b) == 1.0  # tie to even
    assert FP32.add(a, FP32.round(3 * 2.0**-25)) == 1.0 + 2.0**-23
    assert np.isnan(FP32.sub(np.inf, np.inf))
    assert np.isnan(FP32.mul(0.0, np.inf))
    assert FP32.div(1.0, 0.0) == np.inf
    assert np.signbit(FP32.sqrt(-0.0))
    assert np.isnan(FP32.sqrt(-1.0))


def test_ieee_minimum_maximum() -> None:
    assert not np.signbit(ieee_maximum(-0.0, 0.0)) and not np.signbit(ieee_maximum(0.0, -0.0))
    assert np.signbit(ieee_minimum(-0.0, 0.0)) and np.signbit(ieee_minimum(0.0, -0.0))
    assert np.isnan(ieee_maximum(np.nan, 1.0)) and np.isnan(ieee_minimum(1.0, np.nan))
    assert ieee_maximum(-1.0, 2.0) == 2.0 and ieee_minimum(-1.0, 2.0) == -1.0


def test_parse_format() -> None:
    assert parse_format("fp32") is FP32
    assert parse_format("BF16") is BF16
    custom = parse_format("e6m9")
    assert isinstance(custom, NumberFormat) and (custom.exp_bits, custom.man_bits) == (6, 9)
    with pytest.raises(ValueError, match="unknown number format"):
        parse_format("fp33")
    with pytest.raises(ValueError):
        parse_format("e1m5")


def test_op_events() -> None:
    """The event flags of models/formats/number_format.py's docstring, one operation at a time (fp16: max 65504,
    min normal 2^-14)."""
    f = FP16
    cases = [  # op, a, b, (overflow, underflow, invalid)
        ("mul", 300.0, 300.0, (1, 0, 0)),        # 90000 rounds to inf
        ("add", 65504.0, 15.0, (0, 0, 0)),        # rounds back to max finite: no overflow
        ("add", 65504.0, 16.0, (1, 0, 0)),        # half an ulp above: the tie rounds to even, up: inf
        ("div", 1.0, 0.0, (0, 0, 0)),             # division by zero is not an overflow
        ("mul", np.inf, 2.0, (0, 0, 0)),          # an infinite operand: no overflow
        ("mul", 1e-3, 1e-3, (0, 1, 0)),           # 1e-6 flushes to zero
        ("sub", 2.0 ** -14, 2.0 ** -14, (0, 0, 0)),  # an exact zero is no underflow
        ("div", 2.0 ** -14, 4.0, (0, 1, 0)),
        ("mul", 0.0, 5.0, (0, 0, 0)),
        ("sub", np.inf, np.inf, (0, 0, 1)),       # inf - inf
        ("mul", 0.0, np.inf, (0, 0, 1)),
        ("div", 0.0, 0.0, (0, 0, 1)),
        ("div", np.inf, -np.inf, (0, 0, 1)),
        ("sqrt", -1.0, None, (0, 0, 1)),
        ("sqrt", -0.0, None, (0, 0, 0)),          # sqrt(-0) = -0
        ("add", np.nan, 1.0, (0, 0, 0)),          # a propagated NaN is not invalid
    ]
    for op, a, b, want in cases:
        x, y = np.array([a]), None if b is None else np.array([b])
        r, fl = f.op_with_events(op, x, y)
        got = (int(fl.overflow[0]), int(fl.underflow[0]), int(fl.invalid[0]))
        assert got == want, f"{op}({a}, {b}) = {r[0]}: flags {got}, expected {want}"
        with np.errstate(all="ignore"):
            assert np.array_equal(r, getattr(f, op)(x) if y is None else getattr(f, op)(x, y), equal_nan=True)


def test_counting_format() -> None:
    """A counting format computes exactly what the format computes and adds up the events of every +, -, x, /,
    sqrt (min, max and constants raise none); it stays a NumberFormat of the same parameters."""
    c = FP16.counting()
    assert isinstance(c, NumberFormat) and (c.exp_bits, c.man_bits, c.width) == (5, 10, 16)
    a = np.array([300.0, 1e-3, 0.0, -1.0, 2.0])
    b = np.array([300.0, 1e-3, np.inf, 4.0, 0.5])
    with np.errstate(all="ignore"):
        assert np.array_equal(c.mul(a, b), FP16.mul(a, b), equal_nan=True)  # inf, 0, nan, -4, 1
        assert np.array_equal(c.sqrt(a), FP16.sqrt(a), equal_nan=True)  # sqrt(-1): invalid
    c.max(a, b), c.min(a, b), c.const(1e9)
    assert c.events.as_dict() == {"overflow": 1, "underflow": 1, "invalid": 2}
    total = FpEvents()
    total.add(c.events)
    total.add(c.events)
    assert total.as_dict() == {"overflow": 2, "underflow": 2, "invalid": 4}
    assert FP16.counting().events.as_dict() == {"overflow": 0, "underflow": 0, "invalid": 0}  # a fresh total
