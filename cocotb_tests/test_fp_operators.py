"""Bit-exact tests of the rtl/fp operators against the golden arithmetic (models/formats/number_format.py).

For each format (fp32, fp16, bf16) the harness of ``sim/drive/fp_operator_harness.py`` (every operator for that
format, ``sim/harness/fp_ops_tb.sv`` driven by ``sim/harness/fp_ops_main.cpp``, one operand pair per cycle with
random idle cycles) is compiled once with Verilator; ``sim/drive/fp_operator_vectors.py`` generates the vectors and the
golden results, and every result of every operator must match ``encode(golden_op(decode(a), decode(b)))`` bit
for bit: a + b, a - b, a * b, a / b, sqrt(a), minimum, maximum, the compare flags lt / eq / unordered, and the
event flags (overflow, underflow, invalid) of add, sub, mul, div and sqrt (every flag that can occur must occur
in the vectors). Each format is run twice: with fp_add's fabric form and with its DSP48E2 form (``SHIFT_DSP = 1``:
the alignment and normalization shifts as multiplications, the add in the DSP's post-adder), which must give the
same bits. ``SEED=<int>`` overrides the random seed (printed by each test).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

from sim.drive.fp_operator_harness import MINMAX_LATENCY, build_fp_operator_harness, run_fp_operator_harness
from sim.drive.fp_operator_vectors import FORMATS, OPS, event_bits, golden, make_vectors, seed_for

# Expected LATENCY of each operator as documented in rtl/fp/README.md.
EXPECTED_LATENCY = {
    "fp32": {"add": 4, "sub": 4, "mul": 3, "div": 28, "sqrt": 27, "minmax": MINMAX_LATENCY},
    "fp16": {"add": 4, "sub": 4, "mul": 3, "div": 15, "sqrt": 14, "minmax": MINMAX_LATENCY},
    "bf16": {"add": 4, "sub": 4, "mul": 3, "div": 12, "sqrt": 11, "minmax": MINMAX_LATENCY},
}


@dataclass
class Harness:
    fmt_name: str
    exe: Path
    build_s: float
    add_dsp: bool = False


@pytest.fixture(scope="module", params=[(f, dsp) for f in ("fp32", "fp16", "bf16") for dsp in (False, True)],
                ids=lambda p: p[0] + ("-add_dsp" if p[1] else ""))
def harness(request: pytest.FixtureRequest) -> Harness:
    fmt_name, add_dsp = request.param
    t0 = time.monotonic()
    exe = build_fp_operator_harness(fmt_name, add_dsp=add_dsp)
    return Harness(fmt_name, exe, time.monotonic() - t0, add_dsp)


def run_harness(h: Harness, vec: np.ndarray, tmp: Path, seed: int) -> tuple[np.ndarray, str]:
    res, proc = run_fp_operator_harness(h.exe, vec, tmp, seed)
    assert proc.returncode == 0, f"harness failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    assert res.size % len(OPS) == 0
    return res.reshape(-1, len(OPS)), proc.stdout


def test_fp_operators_bit_exact(harness: Harness, tmp_path: Path) -> None:
    fmt = FORMATS[harness.fmt_name]
    seed = seed_for(harness.fmt_name)
    form = "DSP48E2 adders" if harness.add_dsp else "fabric adders"
    print(f"\n[{harness.fmt_name}, {form}] SEED={seed} (override the base with SEED=...); "
          f"build {harness.build_s:.1f} s")
    t0 = time.monotonic()
    vec, counts = make_vectors(harness.fmt_name, seed)
    t1 = time.monotonic()
    res, log = run_harness(harness, vec, tmp_path, seed)
    t2 = time.monotonic()
    exp = golden(fmt, vec[:, 0], vec[:, 1])
    t3 = time.monotonic()
    print(f"[{harness.fmt_name}] vectors {len(vec)} {counts}; gen {t1 - t0:.1f} s, sim {t2 - t1:.1f} s, "
          f"golden {t3 - t2:.1f} s\n{log.strip()}")

    # Not vacuous: one result record per vector, for every operator.
    assert res.shape == (len(vec), len(OPS)), f"{res.shape[0]} results for {len(vec)} vectors"
    assert f"vectors={len(vec)} " in log
    assert f"results={','.join([str(len(vec))] * 6)} " in log
    lat = dict(kv.split("=") for kv in log.splitlines()[0].split()[1:])
    assert {k: int(v) for k, v in lat.items()} == EXPECTED_LATENCY[harness.fmt_name]

    failures = []
    compared = 0
    for i, op in enumerate(OPS):
        got = res[:, i]
        want = exp[op]
        assert len(got) == len(want) == len(vec)
        compared += len(got)
        bad = np.flatnonzero(got != want)
        if len(bad):
            w = (fmt.width + 3) // 4
            lines = [f"  {op}: a=0x{vec[j, 0]:0{w}x} b=0x{vec[j, 1]:0{w}x} got=0x{got[j]:0{w}x} "
                     f"expected=0x{want[j]:0{w}x}" for j in bad[:8]]
            failures.append(f"{op}: {len(bad)} mismatches of {len(vec)}\n" + "\n".join(lines))
    assert compared == len(vec) * len(OPS)
    # not vacuous: every event an operator can raise occurs (sqrt can neither overflow nor underflow)
    _, seen = event_bits(fmt, fmt.decode(vec[:, 0].astype(np.uint64)), fmt.decode(vec[:, 1].astype(np.uint64)))
    print(f"[{harness.fmt_name}] events in the vectors: " + ", ".join(f"{op} {ev} {n}" for (op, ev), n in seen.items()))
    assert all(n > 0 for (op, ev), n in seen.items() if not (op == "sqrt" and ev != "invalid")), seen
    assert not failures, f"[{harness.fmt_name}] bit mismatches (seed {seed}):\n" + "\n".join(failures)
