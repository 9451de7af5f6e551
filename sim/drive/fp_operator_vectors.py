"""Operand vectors for the rtl/fp operators and their golden results (``models/formats/number_format.py``).

Vectors per format: random bit patterns (2^20 pairs; all classes appear), every pair of a list of
special values (zeros, subnormals, min normal, max finite, infinities, NaNs, ones, tie makers,
boundary values), directed boundary cases (products / quotients / sums landing on ties, on the
min-normal flush boundary and on overflow, cancellation, every alignment distance), and for the
16-bit formats every sqrt input. binary32 also gets 2^18 random pairs with nearby exponents.
``SEED=<int>`` overrides the base of the random seed (:func:`seed_for`).

The golden result of each operator is ``encode(golden_op(decode(a), decode(b)))``: a + b, a - b, a * b, a / b,
sqrt(a), minimum, maximum, the compare flags lt / eq / unordered (IEEE quiet comparisons of the decoded, flushed
values), and the event flags (overflow, underflow, invalid) of add, sub, mul, div and sqrt from
``NumberFormat.op_with_events``. Used by the operator test (``cocotb_tests/test_fp_operators.py``), the coverage
regression and the HLS operator stand-ins' test.

    vec, counts = make_vectors("fp16", seed_for("fp16"))
    expected = golden(FP16, vec[:, 0], vec[:, 1])  # {"add": ..., "flags": ...}
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from models.formats.number_format import BF16, EVENT_NAMES, FP16, FP32, NumberFormat
from sim.drive.seed import run_seed

# the operator results of one vector, in the order the harness writes them
OPS = ("add", "sub", "mul", "div", "sqrt", "min", "max", "flags")
FORMATS = {"fp32": FP32, "fp16": FP16, "bf16": BF16}


def seed_for(fmt_name: str) -> int:
    """The vector seed of a format: the run seed (``sim.drive.seed.run_seed``) plus its index."""
    base = run_seed()
    return base + {"fp32": 0, "fp16": 1, "bf16": 2}[fmt_name]


# ------------------------------------------------------------------------------------------------
# Bit-pattern helpers
# ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Fields:
    fmt: NumberFormat

    @property
    def man_mask(self) -> int:
        return (1 << self.fmt.man_bits) - 1

    @property
    def exp_ones(self) -> int:
        return (1 << self.fmt.exp_bits) - 1

    @property
    def sign_bit(self) -> int:
        return 1 << (self.fmt.exp_bits + self.fmt.man_bits)

    def pack(self, sign: np.ndarray | int, exp: np.ndarray | int, man: np.ndarray | int) -> np.ndarray:
        s = np.asarray(sign, dtype=np.int64)
        e = np.asarray(exp, dtype=np.int64)
        m = np.asarray(man, dtype=np.int64)
        return ((s << (self.fmt.exp_bits + self.fmt.man_bits)) | (e << self.fmt.man_bits) | m).astype(np.uint32)

    def exp_of(self, bits: np.ndarray) -> np.ndarray:
        return ((bits.astype(np.int64) >> self.fmt.man_bits) & self.exp_ones).astype(np.int64)

    def bits(self, values: np.ndarray | list[float]) -> np.ndarray:
        """Bit patterns of float64 values (rounded to the format by the golden encoder)."""
        with np.errstate(all="ignore"):
            return self.fmt.encode(np.asarray(values, dtype=np.float64)).astype(np.uint32)


def special_values(fmt: NumberFormat) -> np.ndarray:
    """Bit patterns of the special classes and the tie / boundary makers (both signs)."""
    f = Fields(fmt)
    p = fmt.man_bits + 1
    m = f.man_mask
    pos = [
        0,                                   # +0
        1,                                   # min subnormal
        m,                                   # max subnormal
        1 << fmt.man_bits,                   # min normal
        (1 << fmt.man_bits) | 1,             # min normal + ulp
        (2 << fmt.man_bits),                 # 2 * min normal
        (2 << fmt.man_bits) | m,             # just below 4 * min normal
        ((f.exp_ones - 1) << fmt.man_bits) | m,        # max finite
        ((f.exp_ones - 1) << fmt.man_bits) | (m - 1),  # max finite - ulp
        ((f.exp_ones - 1) << fmt.man_bits),            # 2^emax
        ((f.exp_ones - 2) << fmt.man_bits) | m,        # max finite / 2
        f.exp_ones << fmt.man_bits,          # inf
        (f.exp_ones << fmt.man_bits) | (1 << (fmt.man_bits - 1)),  # quiet NaN
        (f.exp_ones << fmt.man_bits) | 1,    # signalling NaN
        (f.exp_ones << fmt.man_bits) | m,    # NaN with all mantissa bits
    ]
    floats = [
        1.0, 1.0 + 2.0 ** -(p - 1), 2.0 - 2.0 ** -(p - 1), 1.5, 2.0, 3.0, 0.5, 0.75, 1.25,
        2.0 ** -p,                    # half an ulp of 1: 1 + 2^-p is a tie (to even: 1)
        3 * 2.0 ** -(p + 1),          # 1.5 half-ulps
        2.0 ** -(p - 1),              # one ulp of 1
        2.0 ** -(p + 1),
        np.sqrt(fmt.min_normal), np.sqrt(fmt.max_finite), np.sqrt(2.0), 1 / 3,
        fmt.min_normal * 1.5, fmt.max_finite / 3, 2.0 ** fmt.emin * (2 - 2.0 ** -(p - 1)),
    ]
    fb = Fields(fmt).bits(floats).astype(np.int64)
    fb = np.concatenate([fb, fb - 1, fb + 1])           # neighbours (ulp below / above)
    allpos = np.unique(np.concatenate([np.asarray(pos, dtype=np.int64), fb]))
    return np.concatenate([allpos, allpos | f.sign_bit]).astype(np.uint32)


def factor_pair(k: int, limit: int) -> tuple[int, int] | None:
    """k = f1 * f2 with 1 < f1 <= f2 < limit, or None."""
    d = 3
    while d * d <= k:
        if k % d == 0 and k // d < limit:
            return d, k // d
        d += 2
    return None


def directed_pairs(fmt: NumberFormat, rng: np.random.Generator, n: int) -> np.ndarray:
    """Boundary cases: ties, flush / overflow boundaries, cancellation, alignment distances."""
    f = Fields(fmt)
    p = fmt.man_bits + 1
    out: list[np.ndarray] = []

    def rand_normal(count: int, exp_lo: int = 1, exp_hi: int | None = None) -> np.ndarray:
        hi = f.exp_ones - 1 if exp_hi is None else exp_hi
        return f.pack(rng.integers(0, 2, count), rng.integers(exp_lo, hi + 1, count),
                      rng.integers(0, f.man_mask + 1, count))

    def with_neighbours(a: np.ndarray, b_target: np.ndarray, k: int = 2) -> None:
        bb = f.bits(b_target).astype(np.int64)
        for d in range(-k, k + 1):
            out.append(np.stack([a, np.clip(bb + d, 0, (1 << fmt.width) - 1).astype(np.uint32)], axis=1))

    da = lambda bits: fmt.decode(bits)  # noqa: E731
    with np.errstate(all="ignore"):
        # Products and quotients that land around the min-normal flush boundary and overflow.
        a = rand_normal(n)
        with_neighbours(a, fmt.min_normal / np.abs(da(a)) * np.sign(da(a)))
        a = rand_normal(n)
        with_neighbours(a, fmt.max_finite / np.abs(da(a)))
        a = rand_normal(n)
        with_neighbours(a, np.abs(da(a)) / fmt.min_normal)
        a = rand_normal(n)
        with_neighbours(a, -np.abs(da(a)) / fmt.max_finite)
        a = rand_normal(n)
        with_neighbours(a, 1.0 / da(a))          # a * b around 1, a / b around a^2
        # Cancellation: b = -a (+- a few ulps) for add, b = a for sub.
        a = rand_normal(n)
        with_neighbours(a, -da(a), k=3)
        with_neighbours(a, da(a), k=3)
        # Sums near the min normal and near overflow.
        out.append(np.stack([rand_normal(n, 1, 3), rand_normal(n, 1, 3)], axis=1))
        big = f.pack(0, rng.integers(f.exp_ones - 3, f.exp_ones, n), rng.integers(0, f.man_mask + 1, n))
        big2 = f.pack(0, rng.integers(f.exp_ones - 3, f.exp_ones, n), rng.integers(0, f.man_mask + 1, n))
        out.append(np.stack([big, big2], axis=1))
        # Every alignment distance 0 .. p+4, with round-number and random small operands (ties).
        a = rand_normal(n, p + 6, f.exp_ones - 2)
        dist = rng.integers(0, p + 5, n)
        man_kind = rng.integers(0, 4, n)
        bman = np.where(man_kind == 0, 0, np.where(man_kind == 1, f.man_mask, np.where(
            man_kind == 2, 1 << (fmt.man_bits - 1), rng.integers(0, f.man_mask + 1, n))))
        b = f.pack(rng.integers(0, 2, n), f.exp_of(a) - dist, bman)
        out.append(np.stack([a, b], axis=1))
        out.append(np.stack([b, a], axis=1))
        # Products of odd significands with p+1 .. p+2 bits: exact ties and near-ties of mul.
        m1 = rng.integers(2, p, n)
        lo1 = 1 << (m1 - 1)
        ia = rng.integers(lo1, lo1 * 2) | 1
        m2 = p + 2 - m1 - rng.integers(0, 2, n)
        lo2 = 1 << (m2 - 1)
        ib = rng.integers(lo2, lo2 * 2) | 1
        sa = rng.integers(-6, 7, n)
        va = ia.astype(np.float64) * np.ldexp(1.0, sa - m1 + 1)
        vb = ib.astype(np.float64) * np.ldexp(1.0, -sa - m2 + 1) * rng.choice([-1.0, 1.0], n)
        out.append(np.stack([f.bits(va), f.bits(vb)], axis=1))
        # Exact products K * 2^s on the flush boundary (K odd, just below 2^(p+1): ties and
        # near-ties against min normal) and on the overflow boundary.
        rows = []
        for k in range((1 << (p + 1)) - 1, (1 << (p + 1)) - 80, -2):
            fp_ = factor_pair(k, 1 << p)
            if fp_ is None:
                continue
            f1, f2 = fp_
            for target in (fmt.emin - p - 1, fmt.emin - p, fmt.emax - p, fmt.emax - p - 1):
                s1 = target // 2
                s2 = target - s1
                x, y = np.ldexp(float(f1), s1), np.ldexp(float(f2), s2)
                for sx, sy in ((1, 1), (-1, 1), (1, -1)):
                    rows.append((sx * x, sy * y))
        arr = np.asarray(rows, dtype=np.float64)
        ok = (fmt.decode(f.bits(arr[:, 0])) == arr[:, 0]) & (fmt.decode(f.bits(arr[:, 1])) == arr[:, 1])
        exact = np.stack([f.bits(arr[ok, 0]), f.bits(arr[ok, 1])], axis=1)
        out.append(exact)
        out.append(exact[:, ::-1])
        # Perfect squares and their neighbours for sqrt (operand a), even and odd exponents.
        r = rng.integers(1 << (p // 2 - 1), 1 << (p // 2), n).astype(np.float64)   # r^2 < 2^p: exact
        k = rng.integers(-((-fmt.emin) // 2), (fmt.emax - p) // 2 + 1, n)
        sq = r * r * np.ldexp(1.0, 2 * k)
        sqb = f.bits(sq).astype(np.int64)
        for d in (-1, 0, 1):
            out.append(np.stack([(sqb + d).astype(np.uint32), rand_normal(n)], axis=1))
    return np.concatenate(out).astype(np.uint32)


def make_vectors(fmt_name: str, seed: int) -> tuple[np.ndarray, dict[str, int]]:
    """The (N, 2) operand pairs of ``fmt_name`` (every set below, concatenated) and the size of each set."""
    fmt = FORMATS[fmt_name]
    f = Fields(fmt)
    rng = np.random.default_rng(seed)
    sets: dict[str, np.ndarray] = {}
    sets["random"] = rng.integers(0, 1 << fmt.width, size=(1 << 20, 2), dtype=np.uint64).astype(np.uint32)
    sp = special_values(fmt)
    ga, gb = np.meshgrid(sp, sp, indexing="ij")
    sets["special_pairs"] = np.stack([ga.ravel(), gb.ravel()], axis=1)
    sets["directed"] = directed_pairs(fmt, rng, 4096)
    if fmt.width <= 16:
        allv = np.arange(1 << fmt.width, dtype=np.uint32)
        sets["sqrt_exhaustive"] = np.stack([allv, rng.permutation(allv)], axis=1)
    else:
        n = 1 << 18
        e = rng.integers(1, f.exp_ones, n)
        sets["random_near_exp"] = np.stack([
            f.pack(rng.integers(0, 2, n), e, rng.integers(0, f.man_mask + 1, n)),
            f.pack(rng.integers(0, 2, n), np.clip(e + rng.integers(-(fmt.man_bits + 3), fmt.man_bits + 4, n),
                                                  1, f.exp_ones - 1), rng.integers(0, f.man_mask + 1, n)),
        ], axis=1)
    vec = np.concatenate(list(sets.values())).astype(np.uint32)
    return vec, {k: len(v) for k, v in sets.items()}


# bit position of each arithmetic operator's event flags {invalid, underflow, overflow} in the flags word
EVENT_SHIFT = {"add": 3, "sub": 6, "mul": 9, "div": 12, "sqrt": 15}


def event_bits(fmt: NumberFormat, a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, dict[tuple[str, str], int]]:
    """The event-flag bits of the flags word, and how often each (operator, event) occurs."""
    word = np.zeros(a.shape, dtype=np.uint32)
    seen = {}
    for op, shift in EVENT_SHIFT.items():
        _, fl = fmt.op_with_events(op, a, None if op == "sqrt" else b)
        for k, name in enumerate(EVENT_NAMES):
            bit = getattr(fl, name)
            word |= bit.astype(np.uint32) << np.uint32(shift + k)
            seen[(op, name)] = int(np.count_nonzero(bit))
    return word, seen


def golden(fmt: NumberFormat, a_bits: np.ndarray, b_bits: np.ndarray) -> dict[str, np.ndarray]:
    """The expected result of every operator of :data:`OPS` (bit patterns; ``flags``: the compare and event bits)."""
    a = fmt.decode(a_bits.astype(np.uint64))
    b = fmt.decode(b_bits.astype(np.uint64))
    with np.errstate(all="ignore"):
        enc = lambda x: fmt.encode(x).astype(np.uint32)  # noqa: E731
        flags = ((a < b).astype(np.uint32) | ((a == b).astype(np.uint32) << 1)
                 | ((np.isnan(a) | np.isnan(b)).astype(np.uint32) << 2)) | event_bits(fmt, a, b)[0]
        return {
            "add": enc(fmt.add(a, b)), "sub": enc(fmt.sub(a, b)), "mul": enc(fmt.mul(a, b)),
            "div": enc(fmt.div(a, b)), "sqrt": enc(fmt.sqrt(a)), "min": enc(fmt.min(a, b)),
            "max": enc(fmt.max(a, b)), "flags": flags,
        }
