"""Number formats and the bit-accurate arithmetic of the kernel.

A :class:`NumberFormat` is a binary floating-point format with ``exp_bits`` exponent bits and
``man_bits`` stored mantissa bits (binary32 = (8, 23), binary16 = (5, 10), bfloat16 = (8, 7)).
The arithmetic rules below are the contract between the Python golden model and the RTL operators
in ``rtl/fp``; both sides implement exactly these rules:

* Inputs: subnormal operands are read as zero with their sign kept (flush to zero, FTZ).
* Rounding: the exact result is rounded to ``man_bits + 1`` significant bits, round to nearest,
  ties to even, with an unbounded exponent.
* Underflow: a rounded result whose magnitude is below the smallest normal number becomes a zero
  with the sign of the exact result (tininess is detected after rounding, as the Xilinx
  Floating-Point Operator flushes denormal results).
* Overflow: a rounded result above the largest finite number becomes an infinity of that sign.
* NaN: every NaN result is the canonical quiet NaN (sign 0, exponent all ones, mantissa MSB 1);
  invalid operations follow IEEE 754: inf - inf, 0 * inf, 0 / 0, inf / inf and sqrt of a negative
  number give NaN.
* Zero signs: x + (-x) = +0; -0 + -0 = -0; products and quotients take the XOR of the signs;
  sqrt(-0) = -0.
* min/max are IEEE 754-2019 ``minimum``/``maximum``: a NaN operand gives NaN, and -0 < +0.

Every +, -, x, /, sqrt is computed in float64 and rounded once to the format. For significands up to
25 bits (53 >= 2p + 2) and exponents up to 10 bits (exact results stay normal float64 values) this
double rounding is innocuous, so the result is the correctly rounded one.
Float64 mode (``FLOAT64``) performs the same operations without any rounding.

Events (the exception flags of ``rtl/fp``, counted by the kernel): each +, -, x, /, sqrt result may raise

* **overflow**: the exact result is finite and the rounded one is an infinity (IEEE overflow; a division
  of a non-zero number by zero and infinite operands do not count);
* **underflow**: the exact result is non-zero and finite and the rounded one is a zero (flushed: tininess
  after rounding, as above; an exact zero and subnormal inputs read as zero do not count);
* **invalid**: the result is NaN and no operand is (inf - inf, 0 * inf, 0 / 0, inf / inf, sqrt of a
  negative number); a NaN propagated from an operand does not count.

min, max and the comparisons raise none. :meth:`NumberFormat.op_with_events` returns a result with its
per-element flags; :class:`CountingFormat` (``fmt.counting()``) is a format whose +, -, x, /, sqrt add
their flags to a running :class:`FpEvents` total, so any model run with it counts its events.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, field
from typing import Optional, Union

import numpy as np

ArrayLike = Union[np.ndarray, float]

_F64_MAN = 52
_F64_BIAS = 1023
_SIGN64 = np.uint64(1 << 63)
_MAG64 = np.uint64((1 << 63) - 1)
_EXP64 = np.uint64(0x7FF << 52)
# (exp_bits, man_bits) -> the numpy float type whose cast rounds like the format
_NUMPY_CASTS: dict[tuple[int, int], type[np.floating]] = {(8, 23): np.float32, (5, 10): np.float16}


@dataclass(frozen=True)
class _CastRule:
    """A format's rounding by a numpy cast: the float type, the format's min normal, and the magnitude below which
    a float64 value flushes to zero."""

    dtype: type[np.floating]
    min_normal: float
    flush_below: float


def _flush_below(x: np.ndarray, rounded: np.ndarray, flush_below: float) -> np.ndarray:
    """``rounded`` with a zero of ``x``'s sign wherever ``|x| < flush_below``."""
    return np.where(np.abs(x) < flush_below, np.where(np.signbit(x), -0.0, 0.0), rounded)


EVENT_NAMES = ("overflow", "underflow", "invalid")


@dataclass
class FpEvents:
    """Event totals over operation results (see the module docstring)."""

    overflow: int = 0
    underflow: int = 0
    invalid: int = 0

    def add(self, flags: "EventFlags | FpEvents") -> None:
        """Add an operation's flags (counted) or another total."""
        for name in EVENT_NAMES:
            v = getattr(flags, name)
            setattr(self, name, getattr(self, name) + (v if isinstance(v, int) else int(np.count_nonzero(v))))

    def as_dict(self) -> dict[str, int]:
        return {name: getattr(self, name) for name in EVENT_NAMES}


@dataclass
class EventFlags:
    """Per-element event flags of one operation (boolean arrays of the result's shape)."""

    overflow: np.ndarray
    underflow: np.ndarray
    invalid: np.ndarray


def _exact(op: str, a: ArrayLike, b: Optional[ArrayLike]) -> np.ndarray:
    """The float64 result of ``op`` (exact in finiteness and sign for the formats' operands)."""
    with np.errstate(all="ignore"):
        if op == "sqrt":
            return np.sqrt(np.asarray(a, dtype=np.float64))
        fn = {"add": np.add, "sub": np.subtract, "mul": np.multiply, "div": np.divide}[op]
        return fn(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))


def _operands(a: ArrayLike, b: Optional[ArrayLike]) -> list[np.ndarray]:
    return [np.asarray(a, dtype=np.float64)] + ([] if b is None else [np.asarray(b, dtype=np.float64)])


def _event_flags(exact: np.ndarray, r: np.ndarray, operands: list[np.ndarray]) -> EventFlags:
    """The event flags of results ``r`` rounded from ``exact`` (see the module docstring)."""
    nan_in = np.zeros(r.shape, dtype=bool)
    for x in operands:
        nan_in = nan_in | np.isnan(x)
    finite = np.isfinite(exact)
    return EventFlags(overflow=finite & np.isinf(r), underflow=finite & (exact != 0.0) & (r == 0.0),
                      invalid=np.isnan(r) & ~nan_in)


MAX_MAN_BITS = 24  # the widest mantissa of a format (a significand of at most 25 bits)


@dataclass(frozen=True)
class NumberFormat:
    """A binary floating-point format (sign, ``exp_bits``, ``man_bits``)."""

    name: str
    exp_bits: int
    man_bits: int

    def __post_init__(self) -> None:
        # At most 10 exponent bits: products and quotients of normal numbers of the format must be
        # normal float64 values. With 11 (float64's own range) they can be float64 subnormals,
        # already rounded on a coarser grid, and the flush decision near min normal goes wrong.
        if not (2 <= self.exp_bits <= 10):
            raise ValueError(f"exponent width {self.exp_bits} out of range 2..10")
        if not (1 <= self.man_bits <= MAX_MAN_BITS):
            raise ValueError(f"mantissa width {self.man_bits} out of range 1..{MAX_MAN_BITS} (significand <= "
                             f"{MAX_MAN_BITS + 1} bits)")

    # --- format constants -------------------------------------------------------------------
    @property
    def width(self) -> int:
        return 1 + self.exp_bits + self.man_bits

    @property
    def bias(self) -> int:
        return (1 << (self.exp_bits - 1)) - 1

    @property
    def emin(self) -> int:
        return 1 - self.bias

    @property
    def emax(self) -> int:
        return self.bias

    @property
    def min_normal(self) -> float:
        return float(np.ldexp(1.0, self.emin))

    @property
    def max_finite(self) -> float:
        return float(np.ldexp(2.0 - np.ldexp(1.0, -self.man_bits), self.emax))

    @property
    def unit_roundoff(self) -> float:
        return float(np.ldexp(1.0, -(self.man_bits + 1)))

    @property
    def canonical_nan_bits(self) -> int:
        return (((1 << self.exp_bits) - 1) << self.man_bits) | (1 << (self.man_bits - 1))

    @property
    def is_rounding(self) -> bool:
        return True

    # --- rounding ---------------------------------------------------------------------------
    def round(self, x: ArrayLike) -> np.ndarray:
        """Round float64 values to this format (RNE, FTZ, overflow to inf, canonical NaN).

        binary32 and binary16 use numpy's correctly rounded casts plus the flush threshold (a value
        rounds to at least the smallest normal number iff its magnitude is at least
        min_normal * (1 - 2^-(man_bits+2))); other formats use the bit-level rounding, which the
        test suite checks against the casts.

        The cast alone is the answer unless an element casts to a non-zero magnitude of at most min normal
        (numpy's cast rounds those on the subnormal grid): only then is the flush threshold applied, to the
        whole array. A value below the threshold that casts to zero already has the zero of its sign.
        """
        rule = self._cast_rule
        if rule is None:
            return self.round_bitwise(x)
        x = np.asarray(x, dtype=np.float64)
        with np.errstate(over="ignore", invalid="ignore"):
            r = x.astype(rule.dtype).astype(np.float64)
        # more magnitudes of at most min normal than zeros: some element needs the flush threshold (the check
        # reads float64, which numpy computes natively; float16 arithmetic is emulated)
        if np.count_nonzero(np.abs(r) <= rule.min_normal) > r.size - np.count_nonzero(r):
            return _flush_below(x, r, rule.flush_below)
        return r

    @functools.cached_property
    def _cast_rule(self) -> Optional["_CastRule"]:
        """The numpy cast that rounds like this format, with its flush constants (None: no such cast)."""
        dtype = _NUMPY_CASTS.get((self.exp_bits, self.man_bits))
        if dtype is None:
            return None
        return _CastRule(dtype, self.min_normal,
                         self.min_normal * (1.0 - float(np.ldexp(1.0, -(self.man_bits + 2)))))

    def round_bitwise(self, x: ArrayLike) -> np.ndarray:
        """The rounding rule written out on float64 bit patterns (works for every format)."""
        x = np.asarray(x, dtype=np.float64)
        bits = np.ascontiguousarray(x).view(np.uint64).reshape(x.shape)
        sign = bits & _SIGN64
        mag = bits & _MAG64
        shift = np.uint64(_F64_MAN - self.man_bits)
        half_minus_one = np.uint64((1 << (_F64_MAN - self.man_bits - 1)) - 1)
        lsb = (mag >> shift) & np.uint64(1)
        mask = ~np.uint64((1 << (_F64_MAN - self.man_bits)) - 1)
        finite = mag < _EXP64
        mag_r = np.where(finite, (mag + half_minus_one + lsb) & mask, mag)
        exp_unbiased = (mag_r >> np.uint64(_F64_MAN)).astype(np.int64) - _F64_BIAS
        out = (sign | mag_r).view(np.float64)
        tiny = exp_unbiased < self.emin
        huge = finite & (exp_unbiased > self.emax)
        out = np.where(tiny, np.where(sign != 0, -0.0, 0.0), out)
        out = np.where(huge, np.where(sign != 0, -np.inf, np.inf), out)
        out = np.where(np.isnan(x), np.nan, out)
        return out

    # --- bit patterns -------------------------------------------------------------------------
    def encode(self, x: ArrayLike) -> np.ndarray:
        """Bit patterns (uint64) of float64 values, rounded to this format first."""
        r = self.round(x)
        bits = np.ascontiguousarray(r).view(np.uint64).reshape(r.shape)
        sign = (bits >> np.uint64(63)).astype(np.uint64)
        exp64 = ((bits >> np.uint64(52)) & np.uint64(0x7FF)).astype(np.int64)
        frac = (bits & np.uint64((1 << 52) - 1)) >> np.uint64(_F64_MAN - self.man_bits)
        e = np.where(exp64 == 0, 0, exp64 - _F64_BIAS + self.bias)
        e = np.where(exp64 == 0x7FF, (1 << self.exp_bits) - 1, e).astype(np.uint64)
        out = (sign << np.uint64(self.exp_bits + self.man_bits)) | (e << np.uint64(self.man_bits)) | frac
        return np.where(np.isnan(r), np.uint64(self.canonical_nan_bits), out).astype(np.uint64)

    def decode(self, bits: ArrayLike) -> np.ndarray:
        """float64 values of bit patterns; subnormal patterns read as signed zero (FTZ)."""
        b = np.asarray(bits, dtype=np.uint64)
        man_mask = np.uint64((1 << self.man_bits) - 1)
        exp_all = (1 << self.exp_bits) - 1
        sign = (b >> np.uint64(self.exp_bits + self.man_bits)) & np.uint64(1)
        e = ((b >> np.uint64(self.man_bits)) & np.uint64(exp_all)).astype(np.int64)
        frac = b & man_mask
        e64 = (e - self.bias + _F64_BIAS).astype(np.uint64)
        normal = (sign << np.uint64(63)) | (e64 << np.uint64(52)) | (frac << np.uint64(_F64_MAN - self.man_bits))
        out = np.ascontiguousarray(normal).view(np.float64).reshape(normal.shape).copy()
        zero = np.where(sign != 0, -0.0, 0.0)
        out = np.where(e == 0, zero, out)
        inf = np.where(sign != 0, -np.inf, np.inf)
        out = np.where(e == exp_all, np.where(frac == 0, inf, np.nan), out)
        return out

    # --- arithmetic (each result rounded once) --------------------------------------------------
    def add(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return self.round(np.add(a, b))

    def sub(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return self.round(np.subtract(a, b))

    def mul(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return self.round(np.multiply(a, b))

    def div(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return self.round(np.divide(a, b))

    def sqrt(self, a: ArrayLike) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            return self.round(np.sqrt(a))

    def max(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return ieee_maximum(a, b)

    def min(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return ieee_minimum(a, b)

    def const(self, x: ArrayLike) -> np.ndarray:
        """A constant of the datapath (rounded once to the format)."""
        return self.round(x)

    # --- events -------------------------------------------------------------------------------------
    def op_with_events(self, op: str, a: ArrayLike, b: Optional[ArrayLike] = None) -> tuple[np.ndarray, EventFlags]:
        """``op`` ('add', 'sub', 'mul', 'div' or 'sqrt') of format values, and its per-element event flags."""
        exact = _exact(op, a, b)
        r = self.round(exact)
        return r, _event_flags(exact, r, _operands(a, b))

    def counting(self) -> "CountingFormat":
        """This format, counting the events of every +, -, x, /, sqrt into a fresh ``events`` total."""
        return CountingFormat(self.name, self.exp_bits, self.man_bits)


@dataclass(frozen=True)
class CountingFormat(NumberFormat):
    """A :class:`NumberFormat` whose arithmetic adds its event flags to ``events`` (results are identical)."""

    events: FpEvents = field(default_factory=FpEvents, compare=False, repr=False)

    def _counted(self, op: str, a: ArrayLike, b: Optional[ArrayLike] = None) -> np.ndarray:
        exact = _exact(op, a, b)
        r = self.round(exact)
        odd = ~np.isfinite(r) | (r == 0.0)  # only an infinite, NaN or zero result can raise an event
        if odd.any():
            operands = [np.broadcast_to(x, r.shape)[odd] for x in _operands(a, b)]
            self.events.add(_event_flags(np.broadcast_to(exact, r.shape)[odd], r[odd], operands))
        return r

    def add(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return self._counted("add", a, b)

    def sub(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return self._counted("sub", a, b)

    def mul(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return self._counted("mul", a, b)

    def div(self, a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return self._counted("div", a, b)

    def sqrt(self, a: ArrayLike) -> np.ndarray:
        return self._counted("sqrt", a)


class Float64Arithmetic:
    """The same operations without rounding: the float64 reference mode."""

    name = "float64"
    width = 64
    is_rounding = False

    @staticmethod
    def round(x: ArrayLike) -> np.ndarray:
        return np.asarray(x, dtype=np.float64)

    const = round

    @staticmethod
    def add(a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return np.add(a, b)

    @staticmethod
    def sub(a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return np.subtract(a, b)

    @staticmethod
    def mul(a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return np.multiply(a, b)

    @staticmethod
    def div(a: ArrayLike, b: ArrayLike) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.divide(a, b)

    @staticmethod
    def sqrt(a: ArrayLike) -> np.ndarray:
        with np.errstate(invalid="ignore"):
            return np.sqrt(a)

    @staticmethod
    def max(a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return ieee_maximum(a, b)

    @staticmethod
    def min(a: ArrayLike, b: ArrayLike) -> np.ndarray:
        return ieee_minimum(a, b)


Arithmetic = Union[NumberFormat, Float64Arithmetic]


def ieee_maximum(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """IEEE 754-2019 maximum: NaN if either is NaN, +0 > -0."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    pick_a = (a > b) | ((a == b) & ~np.signbit(a))
    out = np.where(pick_a, a, b)
    return np.where(np.isnan(a) | np.isnan(b), np.nan, out)


def ieee_minimum(a: ArrayLike, b: ArrayLike) -> np.ndarray:
    """IEEE 754-2019 minimum: NaN if either is NaN, -0 < +0."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    pick_a = (a < b) | ((a == b) & np.signbit(a))
    out = np.where(pick_a, a, b)
    return np.where(np.isnan(a) | np.isnan(b), np.nan, out)


FP32 = NumberFormat("fp32", 8, 23)
FP16 = NumberFormat("fp16", 5, 10)
BF16 = NumberFormat("bf16", 8, 7)
FLOAT64 = Float64Arithmetic()

# The formats the kernel is generated, linted and tested in, by name (add new formats here). The first one is the
# RTL modules' default parameter set (EXP_BITS = 8, MAN_BITS = 23); every other format is a parameter set of the
# same sources (rtl/gen emits one source for every MAN_BITS).
KERNEL_FORMATS: dict[str, NumberFormat] = {fmt.name: fmt for fmt in (FP32, FP16, BF16)}

NAMED_FORMATS: dict[str, Arithmetic] = {**KERNEL_FORMATS, "float64": FLOAT64}


def parse_format(name: str) -> Arithmetic:
    """A format from its name ('fp32', 'fp16', 'bf16', 'float64') or 'eXmY' (e.g. 'e6m9')."""
    key = name.strip().lower()
    if key in NAMED_FORMATS:
        return NAMED_FORMATS[key]
    if key.startswith("e") and "m" in key:
        try:
            e_str, m_str = key[1:].split("m", 1)
            return NumberFormat(key, int(e_str), int(m_str))
        except ValueError as exc:
            raise ValueError(f"unknown number format {name!r}: {exc}") from None
    raise ValueError(f"unknown number format {name!r} (expected fp32, fp16, bf16, float64 or eXmY)")
