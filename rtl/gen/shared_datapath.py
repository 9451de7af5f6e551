"""One datapath for two graphs: the contact and the friction pass of a lane bound onto one set of operators.

A lane of the kernel takes a contact record or a friction record in any cycle (one record a cycle at most). Two
pipes, one per kind, leave half the operators idle in every cycle; this module *binds* the two graphs
(:mod:`rtl.gen.kernel_graphs`) onto one pipelined datapath, the *shared datapath*, whose record carries its kind
(``in_kind``: 0 contact, 1 friction) down the pipe:

* **Schedule and binding.** The first graph (contact, the deeper) keeps its ASAP schedule
  (:mod:`rtl.gen.operator_schedule`); its operators are the datapath's. The second graph's operations are then
  placed in dependency order: an operation whose operands are ready at ``E`` takes an operator of the first graph of
  the same RTL module (``fp_add`` for add and sub, ``fp_mul``, ``fp_minmax`` for max, min and lt, ``fp_div``,
  ``fp_sqrt``) that is not taken yet and issues at ``T >= E`` (for every mantissa width up to
  ``models.formats.number_format.MAX_MAN_BITS``: a time is kept in MAN_BITS, :class:`rtl.gen.operator_timing.Time`),
  the operation then issuing at ``T``. Because a record enters at most once a cycle and both operations of an operator
  issue at the same stage after their record's entry, two records never meet at an operator. Of the candidates the
  cheapest wins (:func:`_binding_cost`: the cycles the operation waits and the operand multiplexers it needs); where
  waiting costs more than an operator of its own (:data:`OPERATOR_COST`), or no operator is free from ``E`` on, the
  operation gets its own operator, used by that kind only. Combinational nodes (select, sign flip, the zero and
  positive tests) stay each kind's own.
* **Operands.** Each operand of a shared operator is read, per kind, from a delay line tap; where the two kinds read
  different taps a multiplexer selects by the kind of the record at the issue stage (``kind_q``), and ``fp_add``'s
  ``sub`` bit is the kind's. Commutative operations (add, mul, max, min) take their operands in the order that needs
  fewer multiplexers.
* **Delay lines** belong to physical sources (an input word, an operator's output port, a combinational node), not
  to values: the two kinds' values of a shared operator share its output's line, and the kinds' input words share a
  word of ``in_data`` where the layout (:class:`SharedLayout`) puts them in one place. A line is written with the
  valid bits of the kinds that read it (``valid_q``, ``valid_c_q``, ``valid_f_q``).
* **Outputs** are delayed to the common ``LATENCY`` (the latest output of either kind) and selected by the kind of the
  record leaving (``out_kind``) where the two kinds' outputs are different taps; an output a kind does not produce
  is zero for it.
* **Events**: a shared operator's flags belong to whichever record it computed, a one-kind operator's to its kind's
  records only; ``ev_*`` count them for inputs taken with ``in_count``, as the two pipes did together.

The result, :class:`SharedDatapath`, is what :mod:`rtl.gen.shared_emit` writes as SystemVerilog, what the
resource model counts (:meth:`SharedDatapath.stats`) and what the cycle model's latency file records.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from models.formats.number_format import MAX_MAN_BITS

from rtl.gen.dataflow import BOOL, FLOAT, OP_SIGNATURES, Graph, Value, apply
from rtl.gen.operator_schedule import schedule
from rtl.gen.operator_timing import Time, operator_latencies

CONTACT, FRICTION = 0, 1
KINDS = (CONTACT, FRICTION)
KIND_NAMES = ("contact", "friction")
_PREFIX = ("c_", "f_")
_COMMUTATIVE = {"add", "mul", "max", "min"}
_PORT = {"min": "min", "max": "max", "lt": "lt"}  # fp_minmax's output port of each operation (others: y)

# What the binder weighs, in LUT-like units of an fp32 build (rtl/fp operators synthesized by Yosys,
# sim/fit/generated/resource_figures.json): an operator of one kind's own, a W-bit operand multiplexer, and a cycle
# an operation waits for a shared operator (its operands' delay line taps read one cycle later: a RAM64M8 holds 7
# bit-reads of 64 words in 8 LUTs, a W-bit tap about 37 LUTs per 64 cycles, plus the later results of what follows)
OPERATOR_COST = {"fp_add": 443, "fp_mul": 133 + 2 * 60, "fp_minmax": 165, "fp_div": 1800, "fp_sqrt": 1200}
MUX_COST = 32
WAIT_COST = 2


@dataclass(frozen=True)
class SharedLayout:
    """The shared datapath's ports: ``inputs``, the words of ``in_data``, with ``slot[kind][j]`` the word that input
    word ``j`` of the kind's graph is fed in; ``outputs``, the words of ``out_data``, with ``out_of[kind][k]`` the
    index of the kind's graph output in word ``k`` (None: the kind leaves the word zero)."""

    inputs: tuple[str, ...]
    slot: tuple[tuple[int, ...], tuple[int, ...]]
    outputs: tuple[str, ...]
    out_of: tuple[tuple[Optional[int], ...], tuple[Optional[int], ...]]

    def check(self, graphs: tuple[Graph, Graph]) -> None:
        for kind, g in zip(KINDS, graphs):
            if len(self.slot[kind]) != len(g.inputs):
                raise ValueError(f"{g.name}: {len(g.inputs)} input words, the layout maps {len(self.slot[kind])}")
            if len(set(self.slot[kind])) != len(self.slot[kind]) or not all(
                    0 <= s < len(self.inputs) for s in self.slot[kind]):
                raise ValueError(f"{g.name}: the layout's input words of the kind are not distinct words of in_data")
            if len(self.out_of[kind]) != len(self.outputs):
                raise ValueError(f"{g.name}: the layout names {len(self.out_of[kind])} outputs, not "
                                 f"{len(self.outputs)}")
            produced = sorted(k for k in self.out_of[kind] if k is not None)
            if produced != list(range(len(g.outputs))):
                raise ValueError(f"{g.name}: every output of the graph must be in exactly one output word")


@dataclass(eq=False)
class Source:
    """A physical word (or bit) of the datapath: an input word, an operator's output port, a combinational node, or a
    bool input port; one delay line of its own, with a tap per distinct consumer time."""

    name: str
    type: str
    ready: Time
    kinds: set[int]
    taps: list[Time] = field(default_factory=list)

    def tap(self, at: Time) -> int:
        if at not in self.taps:
            self.taps.append(at)
        return self.taps.index(at)


@dataclass(frozen=True, eq=False)
class Ref:
    """An operand: ``source`` read at ``at`` (its delay line's tap), or a constant node."""

    source: Optional[Source] = None
    at: Optional[Time] = None
    const: Optional[Value] = None

    def same(self, other: "Ref") -> bool:
        if self.const is not None or other.const is not None:
            return (self.const is not None and other.const is not None
                    and _const_key(self.const) == _const_key(other.const))
        return self.source is other.source and self.at == other.at


def _const_key(v: Value) -> int:
    return int(np.float64(v.const).view(np.uint64))


@dataclass(eq=False)
class Operator:
    """One operator instance (an ``rtl/fp`` module) and the operation it performs for each kind that uses it."""

    name: str
    module: str
    issue: Time
    ops: dict[int, Value]  # kind -> the kind's operation (a node of its graph)
    operands: dict[int, list[Ref]]  # kind -> operand refs in the operator's port order
    outputs: dict[str, Source]  # port ("y", or fp_minmax's "min" / "max" / "lt") -> its source

    @property
    def kinds(self) -> set[int]:
        return set(self.ops)

    def operand_muxes(self) -> int:
        """Operand ports whose two kinds read different taps (a multiplexer each)."""
        if len(self.ops) < 2:
            return 0
        a, b = self.operands[CONTACT], self.operands[FRICTION]
        return sum(not x.same(y) for x, y in zip(a, b))


@dataclass(eq=False)
class Comb:
    """A combinational node of one kind (select, sign flip, zero / positive test)."""

    kind: int
    node: Value
    operands: list[Ref]
    out: Source


def _at_least(t: Time, e: Time) -> bool:
    """t >= e for every mantissa width of a format."""
    return all(t.eval(mb) >= e.eval(mb) for mb in range(1, MAX_MAN_BITS + 1))


def _key(t: Time) -> int:
    return t.eval(MAX_MAN_BITS)


class SharedDatapath:
    """The binding of two graphs (``graphs[CONTACT]``, ``graphs[FRICTION]``) onto one datapath (module docstring).

    ``inputs`` / ``bool_ports``: the sources of ``in_data``'s words and of the bool input ports; ``operators``,
    ``combs``: the instances; ``outputs[kind][k]``: the ref of output word ``k`` for the kind (None: zero);
    ``latency``: LATENCY, the latest output of either kind."""

    def __init__(self, name: str, doc: str, graphs: tuple[Graph, Graph], layout: SharedLayout,
                 lat: Optional[dict[str, Time]] = None):
        layout.check(graphs)
        self.name, self.doc, self.graphs, self.layout = name, doc, graphs, layout
        self.lat = lat or operator_latencies()
        self.operators: list[Operator] = []
        self.combs: list[Comb] = []
        self.consts: dict[int, Value] = {}
        zero = Time.const(0)
        self.inputs = [Source(f"in_{n}", FLOAT, zero, set()) for n in layout.inputs]
        self.bool_ports: dict[str, Source] = {}
        self._value: tuple[dict[int, Source | Value], ...] = ({}, {})
        self._names: set[str] = {s.name for s in self.inputs}
        self._bind_first(CONTACT)
        self._bind_second(FRICTION)
        outs = [self._value[k][o.value.id] for k, g in zip(KINDS, graphs) for o in g.outputs]
        self.latency = Time.max([s.ready for s in outs if isinstance(s, Source)] or [zero])
        self.outputs: list[list[Optional[Ref]]] = [[None] * len(layout.outputs) for _ in KINDS]
        for kind, g in zip(KINDS, graphs):
            for k, j in enumerate(layout.out_of[kind]):
                if j is not None:
                    self.outputs[kind][k] = self._ref(kind, g.outputs[j].value, self.latency)

    # --- construction ---------------------------------------------------------------------------------------------
    def _unique(self, name: str) -> str:
        cand, i = name, 1
        while cand in self._names:
            cand = f"{name}_{i}"
            i += 1
        self._names.add(cand)
        return cand

    def _ref(self, kind: int, v: Value, at: Time) -> Ref:
        if v.op == "const":
            self.consts.setdefault(_const_key(v), v)
            return Ref(const=v)
        src = self._value[kind][v.id]
        assert isinstance(src, Source)
        src.tap(at)
        return Ref(source=src, at=at)

    def _source_of_leaf(self, kind: int, v: Value) -> Source:
        g = self.graphs[kind]
        if v.op == "input":
            src = self.inputs[self.layout.slot[kind][v.index]]
        else:  # a bool input port, shared by name
            port = v.name
            src = self.bool_ports.setdefault(port, Source(port, BOOL, Time.const(0), set()))
        src.kinds.add(kind)
        assert v.graph is g
        return src

    def _ready(self, kind: int, v: Value) -> Time:
        src = [self._value[kind][a.id].ready for a in v.args if a.op != "const"]
        return Time.max(src) if src else Time.const(0)

    def _comb(self, kind: int, v: Value) -> None:
        at = self._ready(kind, v)
        out = Source(self._unique(_PREFIX[kind] + v.name), v.type, at, {kind})
        operands = [self._ref(kind, a, at) for a in v.args]
        self.combs.append(Comb(kind, v, operands, out))
        self._value[kind][v.id] = out

    def _new_operator(self, kind: int, v: Value, issue: Time) -> Operator:
        mod = OP_SIGNATURES[v.op][2]
        assert mod is not None
        op = Operator(self._unique(_PREFIX[kind] + v.name), mod, issue, {}, {}, {})
        ports = ("min", "max", "lt") if mod == "fp_minmax" else ("y",)
        ready = issue + self.lat[mod]
        for p in ports:
            typ = BOOL if p == "lt" else FLOAT
            op.outputs[p] = Source(op.name if p == "y" else f"{op.name}_{p}", typ, ready, set())
        self.operators.append(op)
        return op

    def _use(self, op: Operator, kind: int, v: Value, operands: list[Ref]) -> None:
        op.ops[kind] = v
        op.operands[kind] = operands
        port = _PORT.get(v.op, "y")
        out = op.outputs[port]
        out.kinds.add(kind)
        self._value[kind][v.id] = out

    def _leaf_or_const(self, kind: int, v: Value) -> bool:
        if v.op in ("input", "bool_input"):
            self._value[kind][v.id] = self._source_of_leaf(kind, v)
            return True
        return v.op == "const"

    def _bind_first(self, kind: int) -> None:
        """The first graph: its ASAP schedule, an operator per operation."""
        g = self.graphs[kind]
        sch = schedule(g, self.lat)
        for v in sch.nodes:
            if self._leaf_or_const(kind, v):
                continue
            if OP_SIGNATURES[v.op][2] is None:
                self._comb(kind, v)
                continue
            op = self._new_operator(kind, v, sch.issue[v.id])
            self._use(op, kind, v, [self._ref(kind, a, op.issue) for a in v.args])

    def _operands_for(self, kind: int, v: Value, op: Operator) -> list[Ref]:
        """The operand refs of ``v`` at ``op``'s issue, in the order that matches the other kind's operands best
        (commutative operations); the taps are not registered yet."""
        refs = [self._peek(kind, a, op.issue) for a in v.args]
        other = next((op.operands[k] for k in op.operands if k != kind), None)
        if other is None or v.op not in _COMMUTATIVE or len(refs) != 2:
            return refs
        swapped = [refs[1], refs[0]]
        return swapped if sum(x.same(y) for x, y in zip(swapped, other)) > sum(
            x.same(y) for x, y in zip(refs, other)) else refs

    def _peek(self, kind: int, v: Value, at: Time) -> Ref:
        if v.op == "const":
            return Ref(const=v)
        src = self._value[kind][v.id]
        assert isinstance(src, Source)
        return Ref(source=src, at=at)

    def _register(self, kind: int, v: Value, refs: list[Ref]) -> list[Ref]:
        """Register the taps of ``refs`` (operands of ``v``, possibly swapped) and the constants."""
        out = []
        for r in refs:
            if r.const is not None:
                self.consts.setdefault(_const_key(r.const), r.const)
            else:
                assert r.source is not None and r.at is not None
                r.source.tap(r.at)
            out.append(r)
        return out

    def _latest_issue(self, kind: int) -> dict[int, np.ndarray]:
        """The latest issue of each operation of the second graph (per mantissa width 1 .. MAX_MAN_BITS) at which its
        outputs are still ready by the first graph's latency (or its own ASAP latency, where that is later)."""
        mbs = np.arange(1, MAX_MAN_BITS + 1)

        def ev(t: Time) -> np.ndarray:
            return np.array([t.eval(int(mb)) for mb in mbs])

        first = schedule(self.graphs[1 - kind], self.lat).latency
        target = np.maximum(ev(first), ev(schedule(self.graphs[kind], self.lat).latency))
        nodes = self.graphs[kind].live_nodes()
        latest_ready = {id(o.value): target for o in self.graphs[kind].outputs}
        latest: dict[int, np.ndarray] = {}
        for v in reversed(nodes):
            if v.op in ("input", "bool_input", "const"):
                continue
            ready = latest_ready.get(id(v), target)
            mod = OP_SIGNATURES[v.op][2]
            issue = ready - ev(self.lat[mod]) if mod else ready
            latest[v.id] = issue
            for a in v.args:
                latest_ready[id(a)] = np.minimum(latest_ready.get(id(a), target), issue)
        return latest

    def _bind_second(self, kind: int) -> None:
        """The second graph's operations, in dependency order, each on the cheapest free operator of the first graph
        that issues no earlier than its operands are ready and no later than its latest issue (which keeps the
        second graph within the first one's latency), or on an operator of its own."""
        g = self.graphs[kind]
        latest = self._latest_issue(kind)
        mbs = range(1, MAX_MAN_BITS + 1)
        for v in g.live_nodes():
            if self._leaf_or_const(kind, v):
                continue
            mod = OP_SIGNATURES[v.op][2]
            if mod is None:
                self._comb(kind, v)
                continue
            earliest = self._ready(kind, v)
            best: Optional[tuple[int, Operator, list[Ref]]] = None
            for op in self.operators:
                if op.module != mod or kind in op.ops or not _at_least(op.issue, earliest):
                    continue
                if any(op.issue.eval(mb) > latest[v.id][mb - 1] for mb in mbs):
                    continue
                refs = self._operands_for(kind, v, op)
                cost = _binding_cost(op, refs, earliest, kind)
                if best is None or cost < best[0]:
                    best = (cost, op, refs)
            if best is None or best[0] >= OPERATOR_COST[mod]:
                op = self._new_operator(kind, v, earliest)
                self._use(op, kind, v, self._register(kind, v, [self._peek(kind, a, earliest) for a in v.args]))
            else:
                _, op, refs = best
                self._use(op, kind, v, self._register(kind, v, refs))

    # --- reports ----------------------------------------------------------------------------------------------
    @property
    def sources(self) -> list[Source]:
        """Every source with a delay line (its taps), in a stable order."""
        out = [s for s in self.inputs if s.taps] + [s for s in self.bool_ports.values() if s.taps]
        out += [s for op in self.operators for s in op.outputs.values() if s.taps]
        out += [c.out for c in self.combs if c.out.taps]
        return out

    def output_muxes(self) -> int:
        """Output words whose two kinds leave from different taps (a multiplexer each)."""
        n = 0
        for k in range(len(self.layout.outputs)):
            a, b = self.outputs[CONTACT][k], self.outputs[FRICTION][k]
            if a is None or b is None or not a.same(b):
                n += 1
        return n

    def stats(self, man_bits: int) -> dict[str, int]:
        """Operators by module (shared ones once), how many serve both kinds, operand and output multiplexers, and
        the delay lines' words (FLOAT) and bits (BOOL) for one MAN_BITS."""
        out: dict[str, int] = {}
        for op in self.operators:
            out[op.module] = out.get(op.module, 0) + 1
        out["shared_operators"] = sum(len(op.ops) == 2 for op in self.operators)
        out["operand_muxes"] = sum(op.operand_muxes() for op in self.operators)
        out["sub_selects"] = sum(len(op.ops) == 2 and op.module == "fp_add"
                                 and (op.ops[CONTACT].op == "sub") != (op.ops[FRICTION].op == "sub")
                                 for op in self.operators)
        out["output_muxes"] = self.output_muxes()
        words = bits = 0
        for s in self.sources:
            depth = max(t.eval(man_bits) for t in s.taps) - s.ready.eval(man_bits)
            if s.type == FLOAT:
                words += depth
            else:
                bits += depth
        out["delay_words"], out["delay_bits"] = words, bits
        return out

    def latency_for(self, man_bits: int) -> int:
        return self.latency.eval(man_bits)

    def evaluate(self, ar, kind: int, inputs: np.ndarray,  # noqa: ANN001 (an Arithmetic)
                 bool_inputs: Optional[dict[str, np.ndarray]] = None) -> np.ndarray:
        """The outputs for records of one kind, (K, N_OUT), computed over the datapath as bound: every operation of
        the kind on its operator from the sources its operand refs name (the words of ``inputs``, (K, N_IN) in the
        shared layout; the bool ports by name): the software twin of the emitted module's wiring (its timing is the
        RTL's to show)."""
        inputs = np.asarray(inputs, dtype=np.float64)
        val: dict[int, np.ndarray] = {id(s): inputs[:, k] for k, s in enumerate(self.inputs)}
        for name, s in self.bool_ports.items():
            if kind in s.kinds:
                val[id(s)] = np.asarray((bool_inputs or {})[name], dtype=bool)

        def operand(r: Ref) -> np.ndarray:
            if r.const is not None:
                return ar.const(r.const.const) * np.ones(inputs.shape[0])
            assert r.source is not None
            return val[id(r.source)]

        items: list[tuple[int, Operator | Comb]] = [(op.ops[kind].id, op) for op in self.operators if kind in op.ops]
        items += [(c.node.id, c) for c in self.combs if c.kind == kind]
        for _, item in sorted(items, key=lambda t: t[0]):
            if isinstance(item, Operator):
                node, refs = item.ops[kind], item.operands[kind]
                out = item.outputs[_PORT.get(node.op, "y")]
            else:
                node, refs, out = item.node, item.operands, item.out
            val[id(out)] = apply(ar, node.op, [operand(r) for r in refs])
        cols = [operand(r) if r is not None else np.zeros(inputs.shape[0]) for r in self.outputs[kind]]
        return np.stack(cols, axis=1)

    def kind_latency(self, kind: int) -> Time:
        """The latest output of one kind alone (what its own pipe would take at least here)."""
        g = self.graphs[kind]
        srcs = [self._value[kind][o.value.id] for o in g.outputs]
        return Time.max([s.ready for s in srcs if isinstance(s, Source)] or [Time.const(0)])


def _binding_cost(op: Operator, refs: list[Ref], earliest: Time, kind: int) -> int:
    """What binding an operation (operands ``refs``, ready at ``earliest``) onto ``op`` costs: its wait and the
    multiplexers it adds."""
    other = next(op.operands[k] for k in op.operands if k != kind)
    muxes = sum(not x.same(y) for x, y in zip(refs, other))
    return WAIT_COST * (_key(op.issue) - _key(earliest)) + MUX_COST * muxes
