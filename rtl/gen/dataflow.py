"""A tiny typed dataflow DSL for fully pipelined datapaths of format operations, and its SV emitter.

A :class:`Graph` holds nodes of two types, ``FLOAT`` (one word of the number format, ``W`` bits) and
``BOOL`` (1 bit). Operations and the RTL that implements each:

=================  ==========================  ===============  =====================================
DSL                meaning                     RTL              latency
=================  ==========================  ===============  =====================================
``a + b``          format add                  ``fp_add``       4
``a - b``          format sub                  ``fp_add`` sub=1 4
``a * b``          format mul                  ``fp_mul``       3
``a / b``          format div                  ``fp_div``       MAN_BITS + 5
``g.sqrt(a)``      format sqrt                 ``fp_sqrt``      MAN_BITS + 4
``g.max/min(a,b)`` IEEE maximum / minimum      ``fp_minmax``    1 (its LATENCY parameter)
``g.lt(a, b)``     a < b (quiet, BOOL)         ``fp_minmax`` lt 1
``g.is_zero(a)``   a == 0 (FTZ, BOOL)          exponent == 0    0 (combinational)
``g.select(p,a,b)`` p ? a : b                  mux              0 (combinational)
``-a``             sign flip (exact)           wire             0
``g.const(x)``     x rounded to the format     localparam       --
=================  ==========================  ===============  =====================================

A graph has no test-only switches: a variant with an injected bug is a graph of its own (e.g.
``kernel_graphs.friction_graph(sign_bug=True)``), generated into a build directory only.

The latencies are read from the operators' sources (``rtl/fp/*.sv``, ``localparam int LATENCY``) by
:func:`operator_latencies`, so the schedule follows the RTL. ``div`` and ``sqrt`` depend on
``MAN_BITS``; a node's ready time is therefore kept symbolically as :class:`Time`, the maximum of
terms ``c + k*MAN_BITS`` (Pareto-pruned), and the emitted SystemVerilog computes every delay for the
module's own ``MAN_BITS`` at elaboration: one source serves every format.

Scheduling is ASAP: an operation issues as soon as its last operand is ready; every other operand
is delayed to that cycle by a tapped delay line (``rtl/pgs_delay.sv``; one line per value, one tap
per distinct consumer delay). All outputs are delayed to the common ``LATENCY``. The pipeline
carries one valid bit (``fp_valid_pipe``, reset) and a pass-through tag (``pgs_delay``).

Floating-point events: every ``fp_add``/``fp_mul``/``fp_div``/``fp_sqrt`` instance reports its event flags
(overflow, underflow, invalid: ``models/number_format.py``) with its result. The module counts the flags
of the inputs taken with ``in_valid && in_count`` (a second reset shift register, tapped at each operator's
ready cycle) and outputs, every cycle, how many of each were raised in the previous cycle
(``ev_overflow``, ``ev_underflow``, ``ev_invalid``: a registered population count). Summed over a run, they
equal :meth:`Graph.evaluate` with a counting format (``NumberFormat.counting()``) over the counted inputs.

:meth:`Graph.evaluate` interprets the graph with a :class:`models.number_format.Arithmetic`
(vectorized over numpy arrays), the software twin of the emitted RTL.
"""

from __future__ import annotations

import math
import re
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Optional, Sequence

import numpy as np

from models.number_format import KERNEL_FORMATS, FpEvents, NumberFormat

FLOAT = "float"
BOOL = "bool"

REPO_ROOT = Path(__file__).resolve().parents[2]
FP_DIR = REPO_ROOT / "rtl" / "fp"

MINMAX_LATENCY = 1  # the LATENCY parameter given to every fp_minmax instance

# --------------------------------------------------------------------------------------------------
# Symbolic times: max over terms c + k*MAN_BITS
# --------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Time:
    """max_i (c_i + k_i * MAN_BITS) over a Pareto-pruned set of (c, k) terms (k >= 0)."""

    terms: frozenset[tuple[int, int]]

    @staticmethod
    def const(c: int, k: int = 0) -> "Time":
        return Time(frozenset({(c, k)}))

    @staticmethod
    def _prune(terms: set[tuple[int, int]]) -> frozenset[tuple[int, int]]:
        keep = {t for t in terms if not any(o != t and o[0] >= t[0] and o[1] >= t[1] for o in terms)}
        return frozenset(keep)

    def __add__(self, lat: "Time") -> "Time":
        assert len(lat.terms) == 1, "latencies are single terms"
        (dc, dk), = lat.terms
        return Time(frozenset((c + dc, k + dk) for c, k in self.terms))

    @staticmethod
    def max(times: Sequence["Time"]) -> "Time":
        allt: set[tuple[int, int]] = set()
        for t in times:
            allt |= t.terms
        return Time(Time._prune(allt))

    def eval(self, man_bits: int) -> int:
        return max(c + k * man_bits for c, k in self.terms)

    @property
    def is_const(self) -> bool:
        return all(k == 0 for _, k in self.terms)

    def sv(self) -> str:
        """SystemVerilog int expression (in MAN_BITS)."""
        if self.is_const:
            return str(self.eval(0))
        parts = []
        for c, k in sorted(self.terms, key=lambda t: (t[1], t[0])):
            mb = "MAN_BITS" if k == 1 else f"{k}*MAN_BITS"
            parts.append(mb if c == 0 and k else (f"{c}" if k == 0 else f"{mb} + {c}"))
        expr = parts[0]
        for p in parts[1:]:
            expr = f"pgs_fp_pkg::tmax({expr}, {p})"
        return expr


def _sv_diff(a: Time, b: Time) -> str:
    """a - b as an SV expression (folded to an int when both are constant)."""
    if a.is_const and b.is_const:
        return str(a.eval(0) - b.eval(0))
    if a == b:
        return "0"
    return f"({a.sv()}) - ({b.sv()})"


_LAT_RE = re.compile(r"\b(?:local)?param(?:eter)?\s+int\s+LATENCY\s*=\s*([^,;\n]+)")


def operator_latencies(fp_dir: Path = FP_DIR) -> dict[str, Time]:
    """LATENCY of each operator read from its RTL source (``4``, ``MAN_BITS + 5``, ...)."""
    out: dict[str, Time] = {}
    for mod in ("fp_add", "fp_mul", "fp_div", "fp_sqrt"):
        text = (fp_dir / f"{mod}.sv").read_text()
        m = _LAT_RE.search(text)
        if not m:
            raise RuntimeError(f"no LATENCY declaration in {mod}.sv")
        expr = m.group(1).strip()
        m2 = re.fullmatch(r"(\d+)", expr) or re.fullmatch(r"MAN_BITS\s*\+\s*(\d+)", expr)
        if not m2:
            raise RuntimeError(f"{mod}.sv: LATENCY = {expr!r} is not 'C' or 'MAN_BITS + C'")
        out[mod] = Time.const(int(m2.group(1)), 0 if expr[0].isdigit() else 1)
    out["fp_minmax"] = Time.const(MINMAX_LATENCY)
    return out


# --------------------------------------------------------------------------------------------------
# Graph
# --------------------------------------------------------------------------------------------------

# op: (operand types, result type, RTL module or None for combinational/free)
_SIGS: dict[str, tuple[tuple[str, ...], str, Optional[str]]] = {
    "add": ((FLOAT, FLOAT), FLOAT, "fp_add"),
    "sub": ((FLOAT, FLOAT), FLOAT, "fp_add"),
    "mul": ((FLOAT, FLOAT), FLOAT, "fp_mul"),
    "div": ((FLOAT, FLOAT), FLOAT, "fp_div"),
    "sqrt": ((FLOAT,), FLOAT, "fp_sqrt"),
    "max": ((FLOAT, FLOAT), FLOAT, "fp_minmax"),
    "min": ((FLOAT, FLOAT), FLOAT, "fp_minmax"),
    "lt": ((FLOAT, FLOAT), BOOL, "fp_minmax"),
    "is_zero": ((FLOAT,), BOOL, None),
    "select": ((BOOL, FLOAT, FLOAT), FLOAT, None),
    "neg": ((FLOAT,), FLOAT, None),
}
_SV_KEYWORDS = set("""
always and assign automatic begin bit buf byte case cell chandle class clk config const default defparam
design disable do edge else end endcase endfunction endmodule event final for force forever fork function
generate genvar highz0 highz1 if iff initial inout input int integer join large let library local localparam
logic longint macromodule medium module nand negedge nmos nor not null or output packed parameter pmos
posedge primitive pull0 pull1 pulldown pullup rand real realtime reg release repeat return rnmos rpmos rst
rtran scalared shortint shortreal signed small specify static string strong0 strong1 supply0 supply1 table
task time tran tri type union unique unsigned use var vectored void wait wand weak0 weak1 while wire with
wor xnor xor q d
""".split())
_COMMUTATIVE = {"add", "mul", "max", "min"}
_FLAGGED = ("fp_add", "fp_mul", "fp_div", "fp_sqrt")  # operators with event flags
_SYMBOL = {"add": "+", "sub": "-", "mul": "*", "div": "/"}


class Value:
    """A node of a :class:`Graph` (the result of an input, constant or operation)."""

    def __init__(self, graph: "Graph", nid: int, op: str, args: tuple["Value", ...], typ: str, name: str,
                 const: Optional[float] = None, index: Optional[int] = None):
        self.graph, self.id, self.op, self.args, self.type, self.name = graph, nid, op, args, typ, name
        self.const = const
        self.index = index  # input word index (FLOAT inputs) or None
        self.auto_named = False

    # arithmetic sugar ---------------------------------------------------------------------------
    def __add__(self, o: "Value") -> "Value":
        return self.graph.op("add", self, o)

    def __sub__(self, o: "Value") -> "Value":
        return self.graph.op("sub", self, o)

    def __mul__(self, o: "Value") -> "Value":
        return self.graph.op("mul", self, o)

    def __truediv__(self, o: "Value") -> "Value":
        return self.graph.op("div", self, o)

    def __neg__(self) -> "Value":
        return self.graph.op("neg", self)

    def named(self, name: str) -> "Value":
        """Give the node a readable name (if it has none yet); returns self."""
        if self.op not in ("input", "const") and self.auto_named:
            self.graph._names.discard(self.name)
            self.name = self.graph._unique(self.graph._scoped(name))
            self.auto_named = False
        return self

    def __repr__(self) -> str:
        return f"<{self.op} {self.name}>"


@dataclass
class Output:
    name: str
    value: Value


class Graph:
    """A dataflow graph with FLOAT word inputs (``in_data``), BOOL bit inputs and FLOAT outputs."""

    def __init__(self, name: str, doc: str = ""):
        self.name = name
        self.doc = doc
        self.nodes: list[Value] = []
        self.inputs: list[Value] = []      # FLOAT word inputs, in word order
        self.bool_inputs: list[Value] = []  # 1-bit inputs (ports in_<name>)
        self.outputs: list[Output] = []
        self._names: set[str] = set()
        self._cse: dict[tuple, Value] = {}
        self._consts: dict[int, Value] = {}
        self._scope: list[str] = []

    # naming ----------------------------------------------------------------------------------------
    def _unique(self, name: str) -> str:
        base = re.sub(r"[^A-Za-z0-9_]", "_", name)
        if base.lower() in _SV_KEYWORDS or base[0].isdigit():
            base = "v_" + base
        cand, i = base, 1
        while cand in self._names:
            cand = f"{base}_{i}"
            i += 1
        self._names.add(cand)
        return cand

    def _auto_id(self) -> int:
        """The number in an automatic node name."""
        return len(self.nodes)

    def _scoped(self, name: str) -> str:
        return "_".join(self._scope + [name])

    @contextmanager
    def scope(self, prefix: str) -> Iterator[None]:
        """Prefix the names of the nodes created inside (nestable)."""
        self._scope.append(prefix)
        try:
            yield
        finally:
            self._scope.pop()

    def _new(self, op: str, args: tuple[Value, ...], typ: str, name: str, **kw) -> Value:
        v = Value(self, len(self.nodes), op, args, typ, name, **kw)
        self.nodes.append(v)
        return v

    # sources ---------------------------------------------------------------------------------------
    def input(self, name: str) -> Value:
        """The next FLOAT word of ``in_data``."""
        v = self._new("input", (), FLOAT, self._unique("in_" + name), index=len(self.inputs))
        self.inputs.append(v)
        return v

    def inputs_vec(self, name: str, n: int = 3, comps: str = "xyzw") -> list[Value]:
        return [self.input(f"{name}_{comps[k]}") for k in range(n)]

    def bool_input(self, name: str) -> Value:
        """A 1-bit input port ``in_<name>`` (aligned with in_data)."""
        v = self._new("bool_input", (), BOOL, self._unique("in_" + name))
        self.bool_inputs.append(v)
        return v

    def const(self, x: float, name: Optional[str] = None) -> Value:
        """The constant x (float64), rounded to the module's format at elaboration."""
        key = np.float64(x).view(np.uint64).item()
        if key not in self._consts:
            label = name or ("k_" + repr(float(x)).replace("-", "m").replace(".", "p").replace("e", "e"))
            self._consts[key] = self._new("const", (), FLOAT, self._unique("K_" + label.upper()), const=float(x))
        return self._consts[key]

    # operations ------------------------------------------------------------------------------------
    def op(self, op: str, *args: Value, name: Optional[str] = None) -> Value:
        if op not in _SIGS:
            raise ValueError(f"unknown op {op}")
        types, rtype, _ = _SIGS[op]
        if len(args) != len(types):
            raise TypeError(f"{op} takes {len(types)} operands, got {len(args)}")
        for i, (a, t) in enumerate(zip(args, types)):
            if not isinstance(a, Value) or a.graph is not self:
                raise TypeError(f"{op}: operand {i} is not a value of this graph: {a!r}")
            if a.type != t:
                raise TypeError(f"{op}: operand {i} ({a.name}) is {a.type}, expected {t}")
        if op == "neg" and args[0].op == "const":
            return self.const(-args[0].const)  # exact
        key = (op,) + tuple(a.id for a in args)
        if op in _COMMUTATIVE:
            key = (op,) + tuple(sorted(a.id for a in args))
        if key in self._cse:
            v = self._cse[key]
        else:
            v = self._new(op, tuple(args), rtype, self._unique(self._scoped(f"{op}{self._auto_id()}")))
            v.auto_named = True
            self._cse[key] = v
        if name:
            v.named(name)
        return v

    def sqrt(self, a: Value, name: Optional[str] = None) -> Value:
        return self.op("sqrt", a, name=name)

    def max(self, a: Value, b: Value, name: Optional[str] = None) -> Value:
        return self.op("max", a, b, name=name)

    def min(self, a: Value, b: Value, name: Optional[str] = None) -> Value:
        return self.op("min", a, b, name=name)

    def lt(self, a: Value, b: Value, name: Optional[str] = None) -> Value:
        return self.op("lt", a, b, name=name)

    def is_zero(self, a: Value, name: Optional[str] = None) -> Value:
        return self.op("is_zero", a, name=name)

    def select(self, p: Value, a: Value, b: Value, name: Optional[str] = None) -> Value:
        """p ? a : b"""
        return self.op("select", p, a, b, name=name)

    def output(self, name: str, v: Value) -> None:
        if v.type != FLOAT:
            raise TypeError(f"output {name} must be FLOAT")
        self.outputs.append(Output(name, v))

    # analysis ----------------------------------------------------------------------------------------
    def live_nodes(self) -> list[Value]:
        """Nodes that some output depends on, in creation (topological) order."""
        live: set[int] = set()
        stack = [o.value for o in self.outputs]
        while stack:
            v = stack.pop()
            if v.id in live:
                continue
            live.add(v.id)
            stack.extend(v.args)
        return [v for v in self.nodes if v.id in live]

    def schedule(self, lat: Optional[dict[str, Time]] = None) -> "Schedule":
        return Schedule(self, lat or operator_latencies())

    # software twin -----------------------------------------------------------------------------------
    def evaluate(self, ar, inputs: np.ndarray, bool_inputs: Optional[np.ndarray] = None) -> np.ndarray:
        """Interpret the graph with arithmetic ``ar``; inputs (K, N_IN) float64 -> outputs (K, N_OUT)."""
        inputs = np.asarray(inputs, dtype=np.float64)
        val: dict[int, np.ndarray] = {}
        for v in self.live_nodes():
            a = [val[x.id] for x in v.args]
            with np.errstate(all="ignore"):
                if v.op == "input":
                    r = inputs[:, v.index]
                elif v.op == "bool_input":
                    r = np.asarray(bool_inputs, dtype=bool)[:, self.bool_inputs.index(v)]
                elif v.op == "const":
                    r = ar.const(v.const) * np.ones(inputs.shape[0])
                elif v.op in ("add", "sub", "mul", "div", "max", "min"):
                    r = getattr(ar, v.op)(a[0], a[1])
                elif v.op == "sqrt":
                    r = ar.sqrt(a[0])
                elif v.op == "lt":
                    r = a[0] < a[1]
                elif v.op == "is_zero":
                    r = a[0] == 0.0
                elif v.op == "select":
                    r = np.where(a[0], a[1], a[2])
                elif v.op == "neg":
                    r = -a[0]
                else:  # pragma: no cover
                    raise AssertionError(v.op)
            val[v.id] = np.asarray(r)
        return np.stack([val[o.value.id] for o in self.outputs], axis=1) if self.outputs else np.zeros((0, 0))


    def count_events(self, fmt: NumberFormat, inputs: np.ndarray, bool_inputs: Optional[np.ndarray] = None) -> FpEvents:
        """The floating-point events (``models/number_format.py``) of the RTL's operators over these inputs:
        what the module's ``ev_*`` outputs add up to for them (taken with ``in_count``)."""
        ar = fmt.counting()
        self.evaluate(ar, inputs, bool_inputs)
        return ar.events


# --------------------------------------------------------------------------------------------------
# Schedule
# --------------------------------------------------------------------------------------------------


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
            mod = _SIGS[v.op][2]
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


# --------------------------------------------------------------------------------------------------
# SystemVerilog emitter
# --------------------------------------------------------------------------------------------------

HEADER = "// generated by rtl/gen (python -m rtl.gen), do not edit: change rtl/gen/kernel_graphs.py instead."


def _wrap(text: str, prefix: str = "// ", width: int = 100) -> list[str]:
    out: list[str] = []
    # join the lines of each paragraph (paragraphs are separated by blank lines)
    paras = [" ".join(p.split("\n")) for p in text.strip("\n").split("\n\n")]
    for i, para in enumerate(paras):
        if i:
            out.append(prefix.rstrip())
        indent = len(para) - len(para.lstrip())
        words = para.split()
        line = " " * indent
        for w in words:
            if len(prefix) + len(line) + len(w) + 1 > width and line.strip():
                out.append(prefix + line.rstrip())
                line = " " * indent
            line += ("" if not line.strip() else " ") + w
        out.append(prefix + line.rstrip())
    return out


def emit_sv(graph: Graph, lat: Optional[dict[str, Time]] = None) -> str:
    """The SystemVerilog module of a graph (see the module docstring for the structure)."""
    sch = graph.schedule(lat)
    lat = sch.lat
    nodes = sch.nodes
    n_in, n_out = len(graph.inputs), len(graph.outputs)
    used_inputs = {v.index for v in nodes if v.op == "input"}
    if used_inputs != set(range(n_in)):
        raise ValueError(f"{graph.name}: unused input words {sorted(set(range(n_in)) - used_inputs)}")
    unused_bool = [v.name for v in graph.bool_inputs if v not in nodes]
    if unused_bool:
        raise ValueError(f"{graph.name}: unused bool inputs {unused_bool}")

    def width(v: Value) -> str:
        return "W" if v.type == FLOAT else "1"

    def tap_ref(v: Value, tap: int) -> str:
        line = sch.lines[v.id]
        if len(line.taps) == 1:
            return f"dl_{v.name}"
        w = width(v)
        return f"dl_{v.name}[{tap}*{w} +: {w}]" if w != "1" else f"dl_{v.name}[{tap}]"

    def operand(cons: Value, pos: int) -> str:
        a = cons.args[pos]
        if a.op == "const":
            return a.name
        return tap_ref(a, sch.operand_tap[(cons.id, pos)])

    def expr_text(v: Value) -> str:
        names = [a.name.removeprefix("in_") if a.op != "const" else f"{a.const!r}" for a in v.args]
        if v.op in _SYMBOL:
            return f"{names[0]} {_SYMBOL[v.op]} {names[1]}"
        if v.op == "neg":
            return f"-{names[0]}"
        if v.op == "select":
            return f"{names[0]} ? {names[1]} : {names[2]}"
        if v.op == "lt":
            return f"{names[0]} < {names[1]}"
        if v.op == "is_zero":
            return f"{names[0]} == 0"
        return f"{v.op}({', '.join(names)})"

    L: list[str] = [HEADER]
    L += _wrap(graph.doc)
    L += [
        "//",
        f"// Ports: in_data word k = in_data[k*W +: W], out_data word k = out_data[k*W +: W]; one input per",
        "// cycle (no back-pressure), results exactly LATENCY cycles later, in order; in_tag travels",
        "// with the data. rst (synchronous, active high) clears only the valid pipeline.",
        "// Latencies for the default operators: " + ", ".join(
            f"{name} {sch.latency_for(fmt.man_bits)}" for name, fmt in KERNEL_FORMATS.items()) + ".",
    ]
    L += _wrap("Inputs: " + ", ".join(f"{v.index} {v.name.removeprefix('in_')}" for v in graph.inputs))
    L += _wrap("Outputs: " + ", ".join(f"{k} {o.name}" for k, o in enumerate(graph.outputs)))
    fp_nodes = [v for v in nodes if v.op in _SIGS and _SIGS[v.op][2] in _FLAGGED]
    if not 0 < len(fp_nodes) < 1 << 16:
        raise ValueError(f"{graph.name}: {len(fp_nodes)} arithmetic operators (the event counts are 16 bits)")
    L += _wrap(f"Events: the flags of the {len(fp_nodes)} add / sub / mul / div / sqrt operators, for inputs "
               "taken with in_valid && in_count; ev_overflow / ev_underflow / ev_invalid = how many were "
               "raised in the previous cycle (models/number_format.py defines them).")
    L += ["`default_nettype none", "", f"module {graph.name} #(",
          "    parameter  int EXP_BITS = 8,",
          "    parameter  int MAN_BITS = 23,",
          "    parameter  int TAG_W    = 64,",
          "    localparam int W        = 1 + EXP_BITS + MAN_BITS,",
          f"    localparam int N_IN     = {n_in},",
          f"    localparam int N_OUT    = {n_out},",
          f"    localparam int LATENCY  = {sch.latency.sv()},",
          f"    localparam int N_FP_OPS = {len(fp_nodes)},",
          "    localparam int EV_W     = 16   // width of the event counts (the same in every module)",
          ") ("]
    ports = [
        "    input  wire logic               clk,",
        "    input  wire logic               rst,        // synchronous, active high; clears the valid pipeline",
        "    input  wire logic               in_valid,",
        "    input  wire logic [TAG_W-1:0]   in_tag,",
        "    input  wire logic [N_IN*W-1:0]  in_data,",
    ]
    for v in graph.bool_inputs:
        ports.append(f"    input  wire logic               {v.name},")
    ports += [
        "    input  wire logic               in_count,   // count this input's floating-point events",
        "    output logic                    out_valid,",
        "    output logic      [TAG_W-1:0]   out_tag,",
        "    output logic      [N_OUT*W-1:0] out_data,",
        "    output logic      [EV_W-1:0]    ev_overflow,    // events raised in the previous cycle",
        "    output logic      [EV_W-1:0]    ev_underflow,",
        "    output logic      [EV_W-1:0]    ev_invalid",
        ");",
    ]
    L += ports
    L += [
        "    // The schedule assumes the operator latencies declared in rtl/fp (read by the generator):",
        f"    // fp_add {lat['fp_add'].sv()}, fp_mul {lat['fp_mul'].sv()}, fp_div {lat['fp_div'].sv()}, "
        f"fp_sqrt {lat['fp_sqrt'].sv()}, fp_minmax LAT_MINMAX.",
        f"    localparam int LAT_MINMAX = {lat['fp_minmax'].sv()};",
        "",
    ]
    op_nodes = [v for v in nodes if _SIGS.get(v.op, (None, None, None))[2] is not None]
    consts = [v for v in nodes if v.op == "const"]
    if consts:
        L.append("    // Constants, rounded to the format at elaboration (RNE, flush to zero) like NumberFormat.round.")
        for v in consts:
            L.append(f"    localparam logic [W-1:0] {v.name} = W'(pgs_fp_pkg::fp_from_real({v.const!r}, EXP_BITS, MAN_BITS));")
        L.append("")

    L += [
        "    // Outputs of the operator instances that the datapath does not use: each operator's own",
        "    // valid bit (the pipeline carries a single valid bit, u_valid) and the fp_minmax results",
        "    // other than the one selected.",
        "    /* verilator lint_off UNUSEDSIGNAL */",
        f"    logic [{max(len(op_nodes), 1)}-1:0] op_valid_nc;",
    ]
    mm_nodes = [v for v in op_nodes if _SIGS[v.op][2] == "fp_minmax"]
    for v in mm_nodes:
        L.append(f"    logic [W-1:0] nc_{v.name}_min, nc_{v.name}_max;")
        L.append(f"    logic         nc_{v.name}_lt, nc_{v.name}_eq, nc_{v.name}_uo;")
    if not op_nodes:
        L.append("    assign op_valid_nc = '0;")
    L += ["    /* verilator lint_on UNUSEDSIGNAL */", ""]

    L += ["    // Valid and tag pipelines.",
          "    fp_valid_pipe #(.LATENCY(LATENCY)) u_valid (",
          "        .clk(clk), .rst(rst), .in_valid(in_valid), .out_valid(out_valid)", "    );",
          "    pgs_delay #(.WIDTH(TAG_W), .DEPTH(LATENCY)) u_tag (.clk(clk), .d(in_tag), .q(out_tag));", ""]
    ev_depth = Time.max([sch.ready[v.id] for v in fp_nodes])
    L += ["    // Event pipeline: ev_q[k] = (in_valid && in_count) k cycles ago (reset like the valid pipeline);",
          "    // an operator's flags belong to the input taken at its ready cycle minus that many cycles.",
          f"    localparam int EV_DEPTH = {ev_depth.sv()};",
          "    logic [EV_DEPTH:0] ev_q;",
          "    assign ev_q[0] = in_valid && in_count;",
          "    for (genvar i = 1; i <= EV_DEPTH; i++) begin : g_ev",
          "        always_ff @(posedge clk) begin",
          "            if (rst) ev_q[i] <= 1'b0;",
          "            else     ev_q[i] <= ev_q[i-1];",
          "        end",
          "    end",
          "    logic [N_FP_OPS-1:0] ev_ovf, ev_unf, ev_inv;   // flags of counted inputs, one bit per operator",
          "    always_ff @(posedge clk) begin",
          "        ev_overflow  <= EV_W'($countones(ev_ovf));",
          "        ev_underflow <= EV_W'($countones(ev_unf));",
          "        ev_invalid   <= EV_W'($countones(ev_inv));",
          "    end", ""]
    ev_index = {v.id: k for k, v in enumerate(fp_nodes)}

    def emit_flags(v: Value) -> list[str]:
        k, at = ev_index[v.id], sch.ready[v.id].sv()
        return [f"    assign ev_ovf[{k}] = fl_{v.name}[0] && ev_q[{at}];",
                f"    assign ev_unf[{k}] = fl_{v.name}[1] && ev_q[{at}];",
                f"    assign ev_inv[{k}] = fl_{v.name}[2] && ev_q[{at}];"]

    def emit_line(v: Value) -> list[str]:
        line = sch.lines.get(v.id)
        if line is None:
            return []
        ready = sch.ready[v.id]
        taps = [_sv_diff(t, ready) for t in line.taps]
        depth_t = Time.max(line.taps)
        depth = _sv_diff(depth_t, ready)
        w = width(v)
        nt = len(taps)
        tap_par = "{" + ", ".join(f"32'({t})" for t in reversed(taps)) + "}"
        out = [f"    logic [{nt}*{w}-1:0] dl_{v.name};" if nt > 1 else f"    logic [{w}-1:0] dl_{v.name};"]
        if nt > 1:
            out.append(f"    pgs_delay #(.WIDTH({w}), .DEPTH({depth}), .N_TAPS({nt}), .TAPS({tap_par}))")
        else:
            out.append(f"    pgs_delay #(.WIDTH({w}), .DEPTH({depth}))")
        out.append(f"        u_dl_{v.name} (.clk(clk), .d({v.name}), .q(dl_{v.name}));")
        return out

    L.append("    // Input words and their delay lines.")
    for v in graph.inputs:
        L.append(f"    logic [W-1:0] {v.name};")
        L.append(f"    assign {v.name} = in_data[{v.index}*W +: W];")
        L += emit_line(v)
    for v in graph.bool_inputs:
        L += emit_line(v)
    L.append("")

    fmt_names = " / ".join(KERNEL_FORMATS)
    L += _wrap(f"Datapath in schedule order. Each value: cycle it is ready (after the input) for {fmt_names}; its "
               "delay line feeds every consumer at the consumer's issue cycle.", prefix="    // ")
    k_op = 0
    for v in nodes:
        if v.op in ("input", "bool_input", "const"):
            continue
        w = width(v)
        r = sch.ready[v.id]
        cyc = "/".join(str(r.eval(fmt.man_bits)) for fmt in KERNEL_FORMATS.values())
        L.append(f"    // {v.name} = {expr_text(v)}   (ready @{cyc})")
        L.append(f"    logic [{w}-1:0] {v.name};" if w != "1" else f"    logic {v.name};")
        ops = [operand(v, i) for i in range(len(v.args))]
        mod = _SIGS[v.op][2]
        if v.op == "neg":
            L.append(f"    assign {v.name} = {{~{ops[0]}[W-1], {ops[0]}[W-2:0]}};")
        elif v.op == "select":
            L.append(f"    assign {v.name} = {ops[0]} ? {ops[1]} : {ops[2]};")
        elif v.op == "is_zero":
            L.append(f"    assign {v.name} = ({ops[0]}[W-2:MAN_BITS] == '0);   // subnormals read as zero")
        elif mod in _FLAGGED:
            operands = f".a({ops[0]})" + (f", .b({ops[1]})" if mod != "fp_sqrt" else "")
            extra = f", .sub(1'b{1 if v.op == 'sub' else 0})" if mod == "fp_add" else ""
            L.append(f"    logic [2:0] fl_{v.name};")
            L.append(f"    {mod} #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_{v.name} (")
            L.append(f"        .clk(clk), .rst(rst), .in_valid(1'b1), {operands}{extra},")
            L.append(f"        .out_valid(op_valid_nc[{k_op}]), .y({v.name}), .flags(fl_{v.name})")
            L.append("    );")
            L += emit_flags(v)
            k_op += 1
        elif mod == "fp_minmax":
            conn = {"min": f"nc_{v.name}_min", "max": f"nc_{v.name}_max", "lt": f"nc_{v.name}_lt"}
            conn[{"min": "min", "max": "max", "lt": "lt"}[v.op]] = v.name
            L.append(f"    fp_minmax #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .LATENCY(LAT_MINMAX)) u_{v.name} (")
            L.append(f"        .clk(clk), .rst(rst), .in_valid(1'b1), .a({ops[0]}), .b({ops[1]}),")
            L.append(f"        .out_valid(op_valid_nc[{k_op}]), .y_min({conn['min']}), .y_max({conn['max']}),")
            L.append(f"        .lt({conn['lt']}), .eq(nc_{v.name}_eq), .unordered(nc_{v.name}_uo)")
            L.append("    );")
            k_op += 1
        else:  # pragma: no cover
            raise AssertionError(v.op)
        L += emit_line(v)
    L.append("")
    L.append("    // Outputs, each delayed to LATENCY.")
    for k, o in enumerate(graph.outputs):
        src = o.value.name if o.value.op == "const" else tap_ref(o.value, sch.output_tap[k])
        L.append(f"    assign out_data[{k}*W +: W] = {src};   // {o.name}")
    L += ["endmodule", "", "`default_nettype wire", ""]
    return "\n".join(L)
