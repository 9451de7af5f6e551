"""A tiny typed dataflow DSL for fully pipelined datapaths of format operations.

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
``g.is_pos(a)``    a > 0 (FTZ, BOOL; a not NaN) sign 0, exp != 0 0 (combinational)
``g.select(p,a,b)`` p ? a : b                  mux              0 (combinational)
``-a``             sign flip (exact)           wire             0
``g.const(x)``     x rounded to the format     localparam       --
=================  ==========================  ===============  =====================================

A graph has no test-only switches: a variant with an injected bug is a graph of its own (e.g.
``kernel_graphs.friction_graph(sign_bug=True)``), generated into a build directory only.

The graph is scheduled by :mod:`rtl.gen.operator_schedule` (operator latencies: :mod:`rtl.gen.operator_timing`) and
written as a SystemVerilog module by :mod:`rtl.gen.sv_emit`.

:meth:`Graph.evaluate` interprets the graph with a :class:`models.formats.number_format.Arithmetic`
(vectorized over numpy arrays), the software twin of the emitted RTL.
"""

from __future__ import annotations

import re
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator, Optional

import numpy as np

from models.formats.number_format import FpEvents, NumberFormat

FLOAT = "float"
BOOL = "bool"

# op: (operand types, result type, RTL module or None for combinational/free)
OP_SIGNATURES: dict[str, tuple[tuple[str, ...], str, Optional[str]]] = {
    "add": ((FLOAT, FLOAT), FLOAT, "fp_add"),
    "sub": ((FLOAT, FLOAT), FLOAT, "fp_add"),
    "mul": ((FLOAT, FLOAT), FLOAT, "fp_mul"),
    "div": ((FLOAT, FLOAT), FLOAT, "fp_div"),
    "sqrt": ((FLOAT,), FLOAT, "fp_sqrt"),
    "max": ((FLOAT, FLOAT), FLOAT, "fp_minmax"),
    "min": ((FLOAT, FLOAT), FLOAT, "fp_minmax"),
    "lt": ((FLOAT, FLOAT), BOOL, "fp_minmax"),
    "is_zero": ((FLOAT,), BOOL, None),
    "is_pos": ((FLOAT,), BOOL, None),
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


def apply(ar, op: str, a: list[np.ndarray]) -> np.ndarray:  # noqa: ANN001 (an Arithmetic)
    """The result of operation ``op`` (not an input or constant) on operand arrays ``a`` with arithmetic ``ar``."""
    with np.errstate(all="ignore"):
        if op in ("add", "sub", "mul", "div", "max", "min"):
            return np.asarray(getattr(ar, op)(a[0], a[1]))
        if op == "sqrt":
            return np.asarray(ar.sqrt(a[0]))
        if op == "lt":
            return np.asarray(a[0] < a[1])
        if op == "is_zero":
            return np.asarray(a[0] == 0.0)
        if op == "is_pos":
            return np.asarray(a[0] > 0.0)
        if op == "select":
            return np.where(a[0], a[1], a[2])
        if op == "neg":
            return np.asarray(-a[0])
    raise AssertionError(op)  # pragma: no cover


class Value:
    """A node of a :class:`Graph` (the result of an input, constant or operation)."""

    def __init__(self, graph: "Graph", nid: int, op: str, args: tuple["Value", ...], typ: str, name: str,
                 const: Optional[float] = None, index: Optional[int] = None):
        self.graph, self.id, self.op, self.args, self.type, self.name = graph, nid, op, args, typ, name
        self.const = const
        self.index = index  # input word index (FLOAT inputs) or None
        self.auto_named = False
        self.scope: tuple[str, ...] = tuple(graph._scope)  # the graph.scope() blocks it was created in

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
        if op not in OP_SIGNATURES:
            raise ValueError(f"unknown op {op}")
        types, rtype, _ = OP_SIGNATURES[op]
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

    def is_pos(self, a: Value, name: Optional[str] = None) -> Value:
        """a > 0 for a value of the format that is not NaN (the sign bit clear, the exponent not zero)."""
        return self.op("is_pos", a, name=name)

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

    # software twin -----------------------------------------------------------------------------------
    def evaluate(self, ar, inputs: np.ndarray, bool_inputs: Optional[np.ndarray] = None) -> np.ndarray:
        """Interpret the graph with arithmetic ``ar``; inputs (K, N_IN) float64 -> outputs (K, N_OUT)."""
        inputs = np.asarray(inputs, dtype=np.float64)
        val: dict[int, np.ndarray] = {}
        for v in self.live_nodes():
            a = [val[x.id] for x in v.args]
            if v.op == "input":
                r = inputs[:, v.index]
            elif v.op == "bool_input":
                r = np.asarray(bool_inputs, dtype=bool)[:, self.bool_inputs.index(v)]
            elif v.op == "const":
                r = ar.const(v.const) * np.ones(inputs.shape[0])
            else:
                r = apply(ar, v.op, a)
            val[v.id] = np.asarray(r)
        return np.stack([val[o.value.id] for o in self.outputs], axis=1) if self.outputs else np.zeros((0, 0))


    def count_events(self, fmt: NumberFormat, inputs: np.ndarray, bool_inputs: Optional[np.ndarray] = None) -> FpEvents:
        """The floating-point events (``models/formats/number_format.py``) of the RTL's operators over these inputs:
        what the module's ``ev_*`` outputs add up to for them (taken with ``in_count``)."""
        ar = fmt.counting()
        self.evaluate(ar, inputs, bool_inputs)
        return ar.events
