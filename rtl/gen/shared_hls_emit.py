"""The shared datapaths (:class:`rtl.gen.shared_datapath.SharedDatapath`) as C++ for the HLS kernel (``hls_export/``):
``hls_export/generated/pgs_shared_datapath.h``, one function per shared datapath module, written by ``python -m rtl.gen``.

A function computes one manifold-pass of either kind on the bound operators, in the emitted module's order: each
operator once, its operands chosen by the kind (``friction ? f : c``, the RTL's operand multiplexers; a shared adder
that subtracts for one kind negates its second operand for it: ``a - b`` is ``a + (-b)`` exactly), the combinational
nodes of each kind, the outputs chosen by the kind. The arithmetic is ``hls_export/pgs_fp.h``'s (the golden rules).
Pipeline stages have no meaning in C++: a value is a variable, read by every consumer. With ``#pragma HLS INLINE
off`` and one instance allocated (``hls_export/pgs_kernel.cpp``), Vitis HLS builds the one datapath both passes run on.
"""

from __future__ import annotations

from models.formats.number_format import MAX_MAN_BITS

from rtl.gen.dataflow import FLOAT, Value
from rtl.gen.shared_datapath import CONTACT, FRICTION, KIND_NAMES, Comb, Operator, Ref, SharedDatapath, _const_key

HEADER_FILE = "pgs_shared_datapath.h"
# the bool parameters, in the order every function takes them whichever graph reads them (the RTL's ports are
# connected by name, a C++ call by position): the order hls_export/pgs_kernel.cpp's lane_pass passes them in, the
# friction pass's spin damping, then the contact pass's soft row
BOOL_PARAMS = ("in_spin_damp", "in_soft")
_CALL = {"fp_add": "add", "fp_mul": "mul", "fp_div": "div", "fp_sqrt": "sqrt"}


class _Writer:
    def __init__(self, dp: SharedDatapath):
        self.dp = dp
        self.consts = {key: f"K{k}" for k, key in enumerate(dp.consts)}

    def ref(self, r: Ref | None) -> str:
        if r is None:
            return "0.0f"
        if r.const is not None:
            return self.consts[_const_key(r.const)]
        assert r.source is not None
        return r.source.name

    def choose(self, c: Ref | None, f: Ref | None, kinds: set[int]) -> str:
        if kinds == {CONTACT}:
            return self.ref(c)
        if kinds == {FRICTION}:
            return self.ref(f)
        if c is not None and f is not None and c.same(f):
            return self.ref(c)
        return f"(friction ? {self.ref(f)} : {self.ref(c)})"

    def operator(self, op: Operator) -> list[str]:
        kinds = set(op.ops)
        n = len(next(iter(op.operands.values())))
        a = [self.choose(op.operands.get(CONTACT, [None] * n)[i], op.operands.get(FRICTION, [None] * n)[i], kinds)
             for i in range(n)]
        uses = "; ".join(f"{KIND_NAMES[k]}: {op.ops[k].name}" for k in sorted(op.ops))
        out = [f"    // {op.name} ({uses})"]
        if op.module == "fp_minmax":
            for port, source in op.outputs.items():
                if not source.taps and not self._is_output(source):
                    continue
                expr = {"min": f"minimum({a[0]}, {a[1]})", "max": f"maximum({a[0]}, {a[1]})",
                        "lt": f"{a[0]} < {a[1]}"}[port]
                typ = "float" if source.type == FLOAT else "bool"
                out.append(f"    const {typ} {source.name} = {expr};")
            return out
        y = op.outputs["y"]
        if op.module == "fp_add":
            subs = {k: op.ops[k].op == "sub" for k in op.ops}
            if len(set(subs.values())) == 1:
                fn = "sub" if next(iter(subs.values())) else "add"
                out.append(f"    const float {y.name} = {fn}({a[0]}, {a[1]});")
            else:  # one kind adds, the other subtracts: its second operand negated (exact)
                neg = "friction" if subs[FRICTION] else "!friction"
                out.append(f"    const float {y.name}_b = {a[1]};")
                out.append(f"    const float {y.name} = add({a[0]}, {neg} ? -{y.name}_b : {y.name}_b);")
            return out
        args = ", ".join(a[:1] if op.module == "fp_sqrt" else a)
        out.append(f"    const float {y.name} = {_CALL[op.module]}({args});")
        return out

    def _is_output(self, source) -> bool:  # noqa: ANN001
        return any(r is not None and r.source is source for refs in self.dp.outputs for r in refs)

    def comb(self, c: Comb) -> str:
        v, ops, name = c.node, [self.ref(r) for r in c.operands], c.out.name
        typ = "float" if c.out.type == FLOAT else "bool"
        expr = {"neg": lambda: f"-{ops[0]}", "select": lambda: f"{ops[0]} ? {ops[1]} : {ops[2]}",
                "is_zero": lambda: f"{ops[0]} == 0.0f", "is_pos": lambda: f"{ops[0]} > 0.0f"}[v.op]()
        return f"    const {typ} {name} = {expr};   // {KIND_NAMES[c.kind]}"


def _order(dp: SharedDatapath) -> list[Operator | Comb]:
    """Every operator and combinational node in an order that computes each value before its consumers, for both
    kinds: by the cycle it computes at (the widest mantissa's), a combinational node before an operator of the same
    cycle (an operator's result is ready later), each kind's nodes in its graph's order."""
    items: list[tuple[tuple[int, int, int], Operator | Comb]] = []
    for op in dp.operators:
        node: Value = next(iter(op.ops.values()))
        items.append(((op.issue.eval(MAX_MAN_BITS), 1, node.id), op))
    for c in dp.combs:
        items.append(((c.out.ready.eval(MAX_MAN_BITS), 0, c.node.id), c))
    return [item for _, item in sorted(items, key=lambda t: t[0])]


def bool_params(dp: SharedDatapath) -> list[str]:
    """``dp``'s bool ports in :data:`BOOL_PARAMS` order (not the order the binding met them in)."""
    unknown = sorted(set(dp.bool_ports) - set(BOOL_PARAMS))
    if unknown:
        raise ValueError(f"{dp.name}: bool ports {unknown} have no place in the C++ parameters {BOOL_PARAMS}")
    return [b for b in BOOL_PARAMS if b in dp.bool_ports]


def emit_shared_function(dp: SharedDatapath) -> list[str]:
    w = _Writer(dp)
    bools = bool_params(dp)
    params = ", ".join(["bool friction", f"const float in[{len(dp.layout.inputs)}]"]
                       + [f"bool {b}" for b in bools] + [f"float out[{len(dp.layout.outputs)}]"])
    L = [f"// {dp.name}: {len(dp.operators)} operators for both passes; inputs in the shared layout: "
         + ", ".join(f"{k} {n}" for k, n in enumerate(dp.layout.inputs)),
         f"constexpr int {dp.name}_in = {len(dp.layout.inputs)};",
         f"inline void {dp.name}({params}) {{",
         "#pragma HLS INLINE off"]
    for key, v in dp.consts.items():
        L.append(f"    const float {w.consts[key]} = constant({v.const!r});   // {v.name}")
    for k, s in enumerate(dp.inputs):
        L.append(f"    const float {s.name} = in[{k}];")
    for item in _order(dp):
        L += w.operator(item) if isinstance(item, Operator) else [w.comb(item)]
    for k, name in enumerate(dp.layout.outputs):
        L.append(f"    out[{k}] = {w.choose(dp.outputs[CONTACT][k], dp.outputs[FRICTION][k], {CONTACT, FRICTION})};"
                 f"   // {name}")
    L += ["}", ""]
    return L


def emit_shared_header(datapaths: list[SharedDatapath]) -> str:
    guard = "PGS_SHARED_DATAPATH_H"
    L = ["// generated by rtl/gen (python -m rtl.gen), do not edit: change rtl/gen/kernel_graphs.py instead.",
         "// pgs_shared_datapath.h: a lane's contact and friction passes on one datapath (rtl/gen/shared_datapath.py),",
         "// the C++ of rtl/generated/pgs_shared_pipe*.sv: one function per option set, `friction` the record's kind;",
         "// outputs: imp0..3 (contact lam0..3; friction lamT0, lamT1, 0, 0), vA, wA, vB, wB (rtl/gen/shared_hls_emit.py).",
         f"#ifndef {guard}", f"#define {guard}", "", '#include "../pgs_fp.h"', "", "namespace pgs {",
         "namespace shared {", ""]
    for dp in datapaths:
        L += emit_shared_function(dp)
    L += ["}  // namespace shared", "}  // namespace pgs", "", f"#endif  // {guard}", ""]
    return "\n".join(L)
