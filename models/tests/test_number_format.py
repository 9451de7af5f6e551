"""The golden rounding: casts against the bit-level rule, special values, IEEE min/max."""

import numpy as np
import pytest

from models.number_format import BF16, FP16, FP32, NumberFormat, ieee_maximum, ieee_minimum, parse_format


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
