"""Lock-step scoreboard: every retired manifold-pass on the kernel's trace port against the golden model.

The golden model runs the same step (same schedule, passes and number format) and yields one expected record
per manifold-pass in retire order. The monitor samples ``trace_valid``/``trace_data`` every cycle and compares
each record as it appears, bit for bit; the first mismatch raises with the cycle, slot, manifold, pass,
iteration, body, field and both values in hex and decimal.

:class:`BatchTraceScoreboard` is its transaction-level form: the records come from the bench's trace batches
(``tb.burst_streams.TraceBatches``, each record stamped with the cycle it retired in) and are compared a chunk at a
time, vectorised, every record and every field still; the first differing record raises the same message, with
the cycle it retired in. ``sink`` receives every record in the compiled harness's ``trace.bin`` layout.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Optional

import numpy as np
from cocotb.triggers import RisingEdge

from models.golden.contact_solver import CONTACT_PASS, PassRecord
from models.formats.number_format import NumberFormat
from models.kernel.stream_format import trace_record_bytes
from sim.compare.trace_bits import read_trace

FIELDS = ["impulse0", "impulse1", "impulse2", "impulse3", "vA.x", "vA.y", "vA.z", "wA.x", "wA.y", "wA.z",
          "vB.x", "vB.y", "vB.z", "wB.x", "wB.y", "wB.z"]


@dataclass
class ExpectedTrace:
    kind: np.ndarray  # (R,) 0 contact, 1 friction
    iteration: np.ndarray  # (R,)
    slot: np.ndarray  # (R,) record index within the pass
    manifold: np.ndarray  # (R,)
    body_a: np.ndarray
    body_b: np.ndarray
    words: np.ndarray  # (R, 16) uint64 bit patterns


def expected_trace(fmt: NumberFormat, records: list[PassRecord], body_a: np.ndarray,
                   body_b: np.ndarray) -> ExpectedTrace:
    """Flatten the golden PassRecords (one per pass, in schedule order) into per-retire expectations."""
    kinds: list[np.ndarray] = [np.zeros(0, np.int64)]
    its, slots, mans = list(kinds), list(kinds), list(kinds)
    words: list[np.ndarray] = [np.zeros((0, 16), np.uint64)]
    for rec in records:
        k = rec.manifold.shape[0]
        imp = rec.impulses if rec.impulses.shape[1] == 4 else np.concatenate([rec.impulses, np.zeros((k, 2))], 1)
        vals = np.concatenate([imp, rec.lin_a, rec.ang_a, rec.lin_b, rec.ang_b], axis=1)
        words.append(fmt.encode(vals))
        kinds.append(np.full(k, 0 if rec.kind == CONTACT_PASS else 1))
        its.append(np.full(k, rec.iteration))
        slots.append(np.arange(k))
        mans.append(rec.manifold)
    man = np.concatenate(mans)
    return ExpectedTrace(np.concatenate(kinds), np.concatenate(its), np.concatenate(slots), man, body_a[man],
                         body_b[man], np.concatenate(words))


class TraceScoreboard:
    def __init__(self, dut: Any, fmt: NumberFormat, expected: ExpectedTrace):
        self.dut = dut
        self.fmt = fmt
        self.exp = expected
        self.w = fmt.width
        self.compared = 0
        self.cycle = 0

    def _decode(self, value: int) -> tuple[list[int], int, int, int]:
        mask = (1 << self.w) - 1
        words = [(value >> (i * self.w)) & mask for i in range(16)]
        base = 16 * self.w
        return words, (value >> base) & 0xFFFFFFFF, (value >> (base + 32)) & 0xFFFF, (value >> (base + 48)) & 1

    def _describe(self, k: int) -> str:
        e = self.exp
        kind = "contact" if e.kind[k] == 0 else "friction"
        return (f"cycle {self.cycle}: retire #{k}: {kind} pass, iteration {e.iteration[k]}, slot {e.slot[k]}, "
                f"manifold {e.manifold[k]} (bodies A={e.body_a[k]}, B={e.body_b[k]})")

    def check(self, value: int) -> None:
        k = self.compared
        if k >= self.exp.words.shape[0]:
            raise AssertionError(f"cycle {self.cycle}: unexpected extra trace record #{k}")
        words, slot, iteration, kind = self._decode(value)
        e = self.exp
        for name, got, want in (("pass kind", kind, e.kind[k]), ("iteration", iteration, e.iteration[k]),
                                ("slot", slot, e.slot[k])):
            if got != want:
                raise AssertionError(f"{self._describe(k)}: {name} is {got}, expected {want}")
        for i, (got, want) in enumerate(zip(words, e.words[k].tolist())):
            if got != want:
                g = float(self.fmt.decode(np.array([got], dtype=np.uint64))[0])
                x = float(self.fmt.decode(np.array([want], dtype=np.uint64))[0])
                body = "A" if FIELDS[i][1] == "A" else ("B" if FIELDS[i][1] == "B" else "-")
                raise AssertionError(f"{self._describe(k)}: body {body} field {FIELDS[i]}: got {got:#x} ({g!r}), "
                                     f"expected {want:#x} ({x!r})")
        self.compared += 1

    async def monitor(self) -> None:
        valid, data = self.dut.trace_valid, self.dut.trace_data
        while True:
            await RisingEdge(self.dut.ap_clk)
            self.cycle += 1
            if int(valid.value):
                self.check(int(data.value))

    @property
    def complete(self) -> bool:
        return self.compared == self.exp.words.shape[0]


class _RawTrace:
    """Trace records already in memory, read by ``sim.compare.trace_bits.read_trace`` as if from a ``trace.bin``."""

    def __init__(self, raw: bytes):
        self.raw = raw

    def read_bytes(self) -> bytes:
        return self.raw


class BatchTraceScoreboard(TraceScoreboard):
    """Checks the trace a chunk of ``chunk`` records at a time (see the module's docstring); :meth:`take` receives
    the bench's raw records (trace record, then the 64-bit retire cycle), :meth:`flush` checks the rest."""

    def __init__(self, fmt: NumberFormat, expected: ExpectedTrace, chunk: int = 4096,
                 sink: Optional[Callable[[bytes], None]] = None):
        super().__init__(None, fmt, expected)
        self.chunk, self.sink = chunk, sink
        self.trace_bytes = trace_record_bytes(fmt)
        self._pending: list[np.ndarray] = []
        self._pending_records = 0

    def take(self, raw: bytes, records: int) -> None:
        bench = np.frombuffer(raw, np.uint8).reshape(records, self.trace_bytes + 8)
        rec = np.concatenate([bench[:, self.trace_bytes:], bench[:, :self.trace_bytes]], axis=1)  # cycle first
        if self.sink is not None:
            self.sink(rec.tobytes())
        self._pending.append(rec)
        self._pending_records += records
        if self._pending_records >= self.chunk:
            self.flush()

    def flush(self) -> None:
        """Compare every record received and not yet compared; the first mismatch raises (see ``check``)."""
        if not self._pending:
            return
        raw = np.concatenate(self._pending)
        self._pending, self._pending_records = [], 0
        got = read_trace(_RawTrace(raw.tobytes()), self.fmt, self.trace_bytes)  # type: ignore[arg-type]
        e, k0 = self.exp, self.compared
        n = raw.shape[0]
        m = max(0, min(n, e.words.shape[0] - k0))  # records that have an expectation
        sl = slice(k0, k0 + m)
        bad = ((got.kind[:m] != e.kind[sl]) | (got.iteration[:m] != e.iteration[sl]) | (got.slot[:m] != e.slot[sl])
               | np.any(got.words[:m] != e.words[sl], axis=1))
        first = int(np.argmax(bad)) if bad.any() else m
        if first < n:  # a differing record, or one past the expected trace: check() names it and raises
            self.compared, self.cycle = k0 + first, int(got.cycle[first])
            self.check(int.from_bytes(raw[first, 8:].tobytes(), "little"))
        self.compared, self.cycle = k0 + n, int(got.cycle[-1])
