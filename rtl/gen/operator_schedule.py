"""ASAP schedule of a dataflow graph (:mod:`rtl.gen.dataflow`): ready and issue times, delay lines.

Scheduling is ASAP: an operation issues as soon as its last operand is ready; every other operand
is delayed to that cycle by a tapped delay line (``rtl/pgs_delay.sv``; one line per value, one tap
per distinct consumer delay). All outputs are delayed to the common ``LATENCY``. The pipeline
carries one valid bit (``fp_valid_pipe``, reset) and a pass-through tag (``pgs_delay``).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from rtl.gen.dataflow import FLOAT, OP_SIGNATURES, Graph, Value
from rtl.gen.operator_timing import Time, operator_latencies


@dataclass
class _Line:
    """The delay line of one value: its distinct taps (delays) in first-use order."""

    taps: list[Time] = field(default_factory=list)

    def tap(self, d: Time) -> int:
        if d not in self.taps:
            self.taps.append(d)
        return self.taps.index(d)


class Schedule:
    """ASAP schedule of a graph: ready time of every value, issue time of every operation."""

    def __init__(self, graph: Graph, lat: dict[str, Time]):
        self.graph, self.lat = graph, lat
        self.nodes = graph.live_nodes()
        self.ready: dict[int, Time] = {}   # cycle the value is available (relative to the input)
        self.issue: dict[int, Time] = {}   # cycle an operation takes its operands
        zero = Time.const(0)
        for v in self.nodes:
            if v.op in ("input", "bool_input"):
                self.ready[v.id] = zero
                continue
            if v.op == "const":
                continue
            src = [self.ready[a.id] for a in v.args if a.op != "const"]
            start = Time.max(src) if src else zero
            self.issue[v.id] = start
            mod = OP_SIGNATURES[v.op][2]
            self.ready[v.id] = start + lat[mod] if mod else start
        outs = [self.ready[o.value.id] for o in graph.outputs if o.value.op != "const"]
        self.latency = Time.max(outs) if outs else zero
        # delay lines: (value id) -> taps, and (consumer id, operand position) -> (value id, tap index)
        self.lines: dict[int, _Line] = {}
        self.operand_tap: dict[tuple[int, int], int] = {}
        for v in self.nodes:
            if v.id not in self.issue:
                continue
            for pos, a in enumerate(v.args):
                if a.op == "const":
                    continue
                self.operand_tap[(v.id, pos)] = self._line(a).tap(self._delay_key(self.issue[v.id], a))
        self.output_tap: dict[int, int] = {}
        for k, o in enumerate(graph.outputs):
            if o.value.op != "const":
                self.output_tap[k] = self._line(o.value).tap(self._delay_key(self.latency, o.value))

    def _line(self, v: Value) -> _Line:
        return self.lines.setdefault(v.id, _Line())

    def _delay_key(self, at: Time, v: Value) -> Time:
        # a delay is the symbolic pair (consumer time, producer time); store the consumer time
        return at

    def delay(self, v: Value, at: Time, man_bits: int) -> int:
        return at.eval(man_bits) - self.ready[v.id].eval(man_bits)

    # reports ---------------------------------------------------------------------------------------
    def latency_for(self, man_bits: int) -> int:
        return self.latency.eval(man_bits)

    def stats(self, man_bits: int) -> dict[str, int]:
        """Operator counts and delay-line register bits (in words) for one MAN_BITS."""
        ops: dict[str, int] = {}
        for v in self.nodes:
            ops[v.op] = ops.get(v.op, 0) + 1
        words = 0
        for vid, line in self.lines.items():
            v = self.graph.nodes[vid]
            depth = max(t.eval(man_bits) for t in line.taps) - self.ready[vid].eval(man_bits)
            words += depth if v.type == FLOAT else 0
        ops["delay_words"] = words
        return ops


def schedule(graph: Graph, lat: dict[str, Time] | None = None) -> Schedule:
    """The ASAP schedule of ``graph`` with the operators' latencies (default: read from ``rtl/fp``)."""
    return Schedule(graph, lat or operator_latencies())
