"""The HLS kernel's binary32 operations (hls_export/pgs_fp.h, as C simulation compiles them) against the golden
arithmetic of models/formats/number_format.py, bit for bit: every pair of special operands, random bit patterns,
ordinary magnitudes, and products whose exact value lies in the flush window just below the smallest normal number
(where the host's own float arithmetic, with gradual underflow, rounds to 2^-126 and the golden flushes to zero).
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

from hls_export.csim import BUILD_ROOT, HLS_DIR, compile_cpp
import pytest

from models.formats.number_format import BF16, FP16, FP32, NumberFormat
from sim.drive.seed import run_seed

OPS = ("add", "sub", "mul", "div", "sqrt", "min", "max")
MIN_NORMAL = 2.0**-126
SPECIALS = np.array([0x00000000, 0x80000000, 0x00800000, 0x80800000, 0x00000001, 0x807FFFFF, 0x3F800000, 0xBF800000,
                     0x3FC00000, 0xC0000000, 0x7F7FFFFF, 0xFF7FFFFF, 0x7F800000, 0xFF800000, 0x7FC00000, 0xFFC00001,
                     0x7F800001, 0x00FFFFFF, 0x33800000, 0x0C000000], dtype=np.uint32)


def _golden(op: str, a_bits: np.ndarray, b_bits: np.ndarray) -> np.ndarray:
    a, b = FP32.decode(a_bits), FP32.decode(b_bits)
    with np.errstate(all="ignore"):
        r = FP32.sqrt(a) if op == "sqrt" else getattr(FP32, op)(a, b)
    return FP32.encode(r).astype(np.uint32)


def _window_products(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Operand pairs whose exact product lies in [2^-126 (1 - 2^-24), 2^-126 (1 - 2^-25)).

    Only products can: a quotient y / x of normal binary32 numbers there would need significands with
    m_x - m_y = m_x * eps, eps in (2^-25, 2^-24], less than one unit in the last place (2^-23); sums and
    differences below 2^-126 are exact multiples of 2^-149; square roots are never that small.
    """
    lo, hi = MIN_NORMAL * (1 - 2.0**-24), MIN_NORMAL * (1 - 2.0**-25)
    target = (lo + hi) / 2
    a_list, b_list = [], []
    while len(a_list) < n:
        a = np.float32(rng.uniform(1.0, 2.0) * 2.0**-63)
        b0 = np.float32(target / float(a))
        for b in (b0, np.nextafter(b0, np.float32(0)), np.nextafter(b0, np.float32(np.inf))):
            if lo <= float(a) * float(b) < hi:
                a_list.append(a)
                b_list.append(b)
    return np.array(a_list, np.float32).view(np.uint32), np.array(b_list, np.float32).view(np.uint32)


def test_fp_ops_match_golden(tmp_path: Path) -> None:
    exe = compile_cpp([HLS_DIR / "tests" / "fp_ops_main.cpp"], BUILD_ROOT / "fp_ops" / "fp_ops")
    seed = run_seed()
    rng = np.random.default_rng(seed)
    rows = []
    sa, sb = np.meshgrid(SPECIALS, SPECIALS)
    rand_a = rng.integers(0, 2**32, 20000, dtype=np.uint64).astype(np.uint32)
    rand_b = rng.integers(0, 2**32, 20000, dtype=np.uint64).astype(np.uint32)
    near = np.float32(rng.uniform(-4, 4, 20000)).view(np.uint32)  # ordinary magnitudes: cancellation, rounding
    window_a, window_b = _window_products(rng, 200)
    for k, op in enumerate(OPS):
        pairs = [(sa.ravel(), sb.ravel()), (rand_a, rand_b), (near, np.roll(near, 1))]
        if op == "mul":
            pairs.append((window_a, window_b))
        for a, b in pairs:
            rows.append(np.stack([np.full(a.shape, k, np.uint32), a, b], axis=1))
    vectors = np.concatenate(rows).astype("<u4")
    (tmp_path / "in.bin").write_bytes(vectors.tobytes())
    subprocess.run([str(exe), str(tmp_path / "in.bin"), str(tmp_path / "out.bin")], check=True)
    got = np.frombuffer((tmp_path / "out.bin").read_bytes(), dtype="<u4")
    assert got.shape[0] == vectors.shape[0]
    mismatches = 0
    for k, op in enumerate(OPS):
        sel = vectors[:, 0] == k
        want = _golden(op, vectors[sel, 1], vectors[sel, 2])
        bad = np.flatnonzero(got[sel] != want)
        mismatches += bad.size
        if bad.size:
            i = bad[0]
            print(f"{op}: 0x{vectors[sel][i, 1]:08x}, 0x{vectors[sel][i, 2]:08x} -> 0x{got[sel][i]:08x}, "
                  f"golden 0x{want[i]:08x}")
    # the window products are where plain float arithmetic would differ from the golden: the host rounds them to
    # 2^-126 (gradual underflow), the golden flushes them (tininess after rounding with an unbounded exponent)
    host = window_a.view(np.float32) * window_b.view(np.float32)
    assert np.all(host.view(np.uint32) & 0x7FFFFFFF == 0x00800000)
    assert np.all(_golden("mul", window_a, window_b) & 0x7FFFFFFF == 0)
    print(f"\n{vectors.shape[0]:,} vectors over {', '.join(OPS)} (seed {seed}; SEED= overrides): {mismatches} "
          f"mismatches; {len(window_a)} products in the flush window, where host float differs")
    assert mismatches == 0


def _specials(fmt: NumberFormat) -> np.ndarray:
    """Zeros, the smallest normal, subnormal patterns, one, the largest finite, infinities, NaNs of ``fmt``."""
    w, m = fmt.width, fmt.man_bits
    sign, exp_all = 1 << (w - 1), ((1 << fmt.exp_bits) - 1) << m
    one = fmt.bias << m
    base = [0, 1 << m, 1, (1 << m) - 1, one, one | (1 << (m - 1)), one + (1 << m), exp_all - 1, exp_all,
            exp_all | (1 << (m - 1)), exp_all | 1]
    return np.array(base + [b | sign for b in base], dtype=np.uint32)


@pytest.mark.parametrize("fmt", [FP16, BF16], ids=["fp16", "bf16"])
def test_fp_ops_other_formats_match_golden(fmt: NumberFormat, tmp_path: Path) -> None:
    """The C simulation's other formats (PGS_EXP_BITS / PGS_MAN_BITS: the values held in a float, every result
    rounded to the format): every pair of special operands, random bit patterns and ordinary magnitudes, bit for bit
    against models/formats/number_format.py."""
    exe = compile_cpp([HLS_DIR / "tests" / "fp_ops_main.cpp"], BUILD_ROOT / f"fp_ops_{fmt.name}" / "fp_ops",
                      [f"-DPGS_EXP_BITS={fmt.exp_bits}", f"-DPGS_MAN_BITS={fmt.man_bits}"])
    seed = run_seed()
    rng = np.random.default_rng(seed)
    sa, sb = np.meshgrid(_specials(fmt), _specials(fmt))
    rand = rng.integers(0, 1 << fmt.width, (2, 20000), dtype=np.uint64).astype(np.uint32)
    near = fmt.encode(rng.uniform(-4, 4, 20000)).astype(np.uint32)
    rows = [np.stack([np.full(a.shape, k, np.uint32), a, b], axis=1) for k in range(len(OPS))
            for a, b in ((sa.ravel(), sb.ravel()), (rand[0], rand[1]), (near, np.roll(near, 1)))]
    vectors = np.concatenate(rows).astype("<u4")
    (tmp_path / "in.bin").write_bytes(vectors.tobytes())
    subprocess.run([str(exe), str(tmp_path / "in.bin"), str(tmp_path / "out.bin")], check=True)
    got = np.frombuffer((tmp_path / "out.bin").read_bytes(), dtype="<u4")
    mismatches = 0
    for k, op in enumerate(OPS):
        sel = vectors[:, 0] == k
        a, b = fmt.decode(vectors[sel, 1]), fmt.decode(vectors[sel, 2])
        with np.errstate(all="ignore"):
            want = fmt.encode(fmt.sqrt(a) if op == "sqrt" else getattr(fmt, op)(a, b)).astype(np.uint32)
        bad = np.flatnonzero(got[sel] != want)
        mismatches += bad.size
        if bad.size:
            i = bad[0]
            print(f"{op}: 0x{vectors[sel][i, 1]:04x}, 0x{vectors[sel][i, 2]:04x} -> 0x{got[sel][i]:04x}, "
                  f"golden 0x{want[i]:04x}")
    print(f"\n{fmt.name}: {vectors.shape[0]:,} vectors over {', '.join(OPS)} (seed {seed}): {mismatches} mismatches")
    assert mismatches == 0
