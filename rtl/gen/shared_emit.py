"""The SystemVerilog module of a shared datapath (:class:`rtl.gen.shared_datapath.SharedDatapath`): the contact and
friction passes of one lane on one set of operators, the record's kind travelling with it.

The module has the ports of a generated pipe (``rtl/gen/sv_emit.py``) plus ``in_kind`` (0 contact, 1 friction) and
``out_kind`` (the kind of the record leaving). Beside the valid pipeline it keeps ``kind_q`` (the kind of the record
``k`` cycles ago: the operand and output multiplexers' select) and the valid bits of each kind (``valid_c_q``,
``valid_f_q``), which enable the operators and delay lines that only one kind uses. Events as in ``sv_emit``: a shared
operator's flags count for every counted record, a one-kind operator's for its kind's.
"""

from __future__ import annotations

import heapq
from typing import Optional

from models.formats.number_format import KERNEL_FORMATS

from rtl.gen.dataflow import FLOAT
from rtl.gen.operator_timing import Time
from rtl.gen.shared_datapath import CONTACT, FRICTION, KIND_NAMES, Comb, Operator, Ref, SharedDatapath, Source, _const_key
from rtl.gen.sv_emit import (ADD_SHIFT_DSP_PARAM, HEADER, _FLAGGED, _sv_diff, _wrap, comb_assign, expr_text,
                             operator_params, ready_cycles)

_VALID = {frozenset({CONTACT}): "valid_c_q", frozenset({FRICTION}): "valid_f_q",
          frozenset({CONTACT, FRICTION}): "valid_q"}
_EVENTS = {frozenset({CONTACT}): "ev_c_q", frozenset({FRICTION}): "ev_f_q", frozenset({CONTACT, FRICTION}): "ev_q"}


def _width(s: Source) -> str:
    return "W" if s.type == FLOAT else "1"


class _Emitter:
    def __init__(self, dp: SharedDatapath):
        self.dp = dp
        self.const_name: dict[int, str] = {}
        used: set[str] = set()
        for key, v in dp.consts.items():
            name, i = v.name, 1
            while name in used:
                name = f"{v.name}_{i}"
                i += 1
            used.add(name)
            self.const_name[key] = name

    def tap(self, r: Ref) -> str:
        if r.const is not None:
            return self.const_name[_const_key(r.const)]
        s = r.source
        assert s is not None and r.at is not None
        if len(s.taps) == 1:
            return f"dl_{s.name}"
        w = _width(s)
        k = s.taps.index(r.at)
        return f"dl_{s.name}[{k}*{w} +: {w}]" if w != "1" else f"dl_{s.name}[{k}]"

    def select(self, refs: dict[int, Optional[Ref]], at: Time, zero: str) -> str:
        """The word of the kinds' refs at stage ``at``: one tap where they agree, else a multiplexer on the kind."""
        c, f = refs.get(CONTACT), refs.get(FRICTION)
        if c is not None and f is not None and c.same(f):
            return self.tap(c)
        if f is None and c is not None and FRICTION not in refs:
            return self.tap(c)
        if c is None and f is not None and CONTACT not in refs:
            return self.tap(f)
        cs = self.tap(c) if c is not None else zero
        fs = self.tap(f) if f is not None else zero
        return f"kind_q[{at.sv()}] ? {fs} : {cs}"

    def line(self, s: Source) -> list[str]:
        if not s.taps:
            return []
        taps = [_sv_diff(t, s.ready) for t in s.taps]
        depth = _sv_diff(Time.max(s.taps), s.ready)
        w, nt = _width(s), len(taps)
        tap_par = "{" + ", ".join(f"32'({t})" for t in reversed(taps)) + "}"
        out = [f"    logic [{nt}*{w}-1:0] dl_{s.name};" if nt > 1 else f"    logic [{w}-1:0] dl_{s.name};"]
        if nt > 1:
            out.append(f"    pgs_delay #(.WIDTH({w}), .DEPTH({depth}), .N_TAPS({nt}), .TAPS({tap_par}),")
        else:
            out.append(f"    pgs_delay #(.WIDTH({w}), .DEPTH({depth}),")
        out.append("                .BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH))")
        valid = _VALID[frozenset(s.kinds)]
        if depth.isdigit():
            vbits = f"{valid}[{s.ready.sv()} +: {depth}]" if depth != "0" else "1'b0"
        else:
            vbits = f"{valid}[{s.ready.sv()} +: (({depth}) > 0 ? ({depth}) : 1)]"
        out.append(f"        u_dl_{s.name} (.clk(clk), .d({s.name}), .valid({vbits}), .q(dl_{s.name}));")
        return out

    def comb(self, c: Comb) -> list[str]:
        v, ops, out = c.node, [self.tap(r) for r in c.operands], c.out
        L = [f"    // {out.name} = {expr_text(v)}   ({KIND_NAMES[c.kind]}; ready @{ready_cycles(out.ready)})",
             f"    logic [W-1:0] {out.name};" if out.type == FLOAT else f"    logic {out.name};",
             comb_assign(v.op, out.name, ops)]
        return L + self.line(out)

    def operator(self, op: Operator, k_op: int, ev_index: Optional[int]) -> list[str]:
        kinds = frozenset(op.ops)
        uses = "; ".join(f"{KIND_NAMES[k]}: {op.ops[k].name} = {expr_text(op.ops[k])}" for k in sorted(op.ops))
        ready = next(iter(op.outputs.values())).ready
        L = [f"    // {op.name}: {op.module} @{ready_cycles(op.issue)} -> @{ready_cycles(ready)} ({uses})"]
        n_operands = len(next(iter(op.operands.values())))
        operands = []
        for i, port in enumerate("ab"[:n_operands]):
            expr = self.select({k: op.operands[k][i] for k in op.operands}, op.issue, "'0")
            if "?" in expr:
                L.append(f"    logic [W-1:0] {op.name}_{port};")
                L.append(f"    assign {op.name}_{port} = {expr};")
                expr = f"{op.name}_{port}"
            operands.append(expr)
        valid = f"{_VALID[kinds]}[{op.issue.sv()}]"
        if op.module in _FLAGGED:
            y = op.outputs["y"]
            conn = f".a({operands[0]})" + (f", .b({operands[1]})" if op.module != "fp_sqrt" else "")
            if op.module == "fp_add":
                subs = {k: op.ops[k].op == "sub" for k in op.ops}
                if len(set(subs.values())) == 1:
                    conn += f", .sub(1'b{int(next(iter(subs.values())))})"
                else:
                    conn += f", .sub({'' if subs[FRICTION] else '!'}kind_q[{op.issue.sv()}])"
            L += [f"    logic [W-1:0] {y.name};", f"    logic [2:0] fl_{op.name};",
                  f"    {op.module} {operator_params(op.module)} u_{op.name} (",
                  f"        .clk(clk), .rst(rst), .in_valid({valid}), {conn},",
                  f"        .out_valid(op_valid_nc[{k_op}]), .y({y.name}), .flags(fl_{op.name})", "    );"]
            assert ev_index is not None
            ev = f"{_EVENTS[kinds]}[{y.ready.sv()}]"
            L += [f"    assign ev_ovf[{ev_index}] = fl_{op.name}[0] && {ev};",
                  f"    assign ev_unf[{ev_index}] = fl_{op.name}[1] && {ev};",
                  f"    assign ev_inv[{ev_index}] = fl_{op.name}[2] && {ev};"]
            L += self.line(y)
        else:  # fp_minmax: its three results, each a source of its own
            mn, mx, lt = (op.outputs[p] for p in ("min", "max", "lt"))
            L += [f"    fp_minmax #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS), .LATENCY(LAT_MINMAX)) u_{op.name} (",
                  f"        .clk(clk), .rst(rst), .in_valid({valid}), .a({operands[0]}), .b({operands[1]}),",
                  f"        .out_valid(op_valid_nc[{k_op}]), .y_min({mn.name}), .y_max({mx.name}),",
                  f"        .lt({lt.name}), .eq(nc_{op.name}_eq), .unordered(nc_{op.name}_uo)", "    );"]
            for s in (mn, mx, lt):
                L += self.line(s)
        return L


def _reads(item: Operator | Comb) -> set[int]:
    """The sources (by id) whose delay lines ``item`` reads."""
    refs = [r for rs in item.operands.values() for r in rs] if isinstance(item, Operator) else item.operands
    return {id(r.source) for r in refs if r.source is not None}


def _writes(item: Operator | Comb) -> list[Source]:
    return list(item.outputs.values()) if isinstance(item, Operator) else [item.out]


def emit_order(dp: SharedDatapath) -> list[Operator | Comb]:
    """The operators and combinational nodes in schedule order (issue cycle of an operator, ready cycle of a node,
    for fp32; nodes before operators of the same cycle), each after the items whose outputs it reads, so that every
    signal is declared above its first use (which slang requires, Verilator does not)."""
    items: list[Operator | Comb] = [*dp.operators, *dp.combs]
    producer = {id(s): k for k, item in enumerate(items) for s in _writes(item)}
    deps = [{producer[s] for s in _reads(item) if s in producer} - {k} for k, item in enumerate(items)]
    users: list[list[int]] = [[] for _ in items]
    for k, ds in enumerate(deps):
        for d in ds:
            users[d].append(k)

    def key(k: int) -> tuple[int, int, int]:
        item = items[k]
        at = item.issue if isinstance(item, Operator) else item.out.ready
        return at.eval(23), isinstance(item, Operator), k

    waiting = [len(ds) for ds in deps]
    ready = [key(k) for k in range(len(items)) if not waiting[k]]
    heapq.heapify(ready)
    out: list[Operator | Comb] = []
    while ready:
        k = heapq.heappop(ready)[2]
        out.append(items[k])
        for u in users[k]:
            waiting[u] -= 1
            if not waiting[u]:
                heapq.heappush(ready, key(u))
    if len(out) != len(items):
        raise ValueError(f"{dp.name}: a cycle among the datapath's combinational nodes and operators")
    return out


def emit_shared_sv(dp: SharedDatapath) -> str:
    """The SystemVerilog module of ``dp`` (this module's and rtl/gen/shared_datapath.py's docstrings)."""
    e = _Emitter(dp)
    lay = dp.layout
    unused = [s.name for s in dp.inputs if not s.taps]
    if unused:
        raise ValueError(f"{dp.name}: input words no kind reads: {unused}")
    flagged = [op for op in dp.operators if op.module in _FLAGGED]
    if not 0 < len(flagged) < 1 << 16:
        raise ValueError(f"{dp.name}: {len(flagged)} arithmetic operators (the event counts are 16 bits)")
    stats = dp.stats(23)
    L: list[str] = [HEADER]
    L += _wrap(dp.doc)
    L += ["//",
          "// Ports: in_data word k = in_data[k*W +: W], out_data word k = out_data[k*W +: W]; one input per",
          "// cycle (no back-pressure), results exactly LATENCY cycles later, in order; in_kind and in_tag travel",
          "// with the data (out_kind, out_tag). rst (synchronous, active high) clears only the valid pipeline.",
          "// Latencies for the default operators: " + ", ".join(
              f"{name} {dp.latency_for(fmt.man_bits)}" for name, fmt in KERNEL_FORMATS.items()) + "."]
    L += _wrap("Inputs: " + ", ".join(f"{k} {n}" for k, n in enumerate(lay.inputs)))
    L += _wrap("Outputs: " + ", ".join(f"{k} {n}" for k, n in enumerate(lay.outputs)))
    L += _wrap(f"Operators: {len(dp.operators)} ({stats['shared_operators']} serve both kinds), "
               f"{stats['operand_muxes']} operand and {stats['output_muxes']} output multiplexers. Events: the flags "
               f"of the {len(flagged)} add / sub / mul / div / sqrt operators, for inputs taken with in_valid && "
               "in_count (a one-kind operator's for its kind's inputs); ev_overflow / ev_underflow / ev_invalid = how "
               "many were raised in the previous cycle (models/formats/number_format.py defines them).")
    L += ["`default_nettype none", "", f"module {dp.name} #(",
          "    parameter  int EXP_BITS = 8,",
          "    parameter  int MAN_BITS = 23,",
          "    parameter  int TAG_W    = 64,",
          "    // delay lines at least this deep keep their words in block RAM, shallower ones in LUT RAM (0: none in",
          "    // block RAM; pgs_delay's BLOCK_MIN_DEPTH; the same results either way)",
          "    parameter  int DELAY_BLOCK_MIN_DEPTH = 0,",
          *ADD_SHIFT_DSP_PARAM,
          "    localparam int W        = 1 + EXP_BITS + MAN_BITS,",
          f"    localparam int N_IN     = {len(lay.inputs)},",
          f"    localparam int N_OUT    = {len(lay.outputs)},",
          f"    localparam int LATENCY  = {dp.latency.sv()},",
          f"    localparam int N_FP_OPS = {len(flagged)},",
          "    localparam int EV_W     = 16   // width of the event counts (the same in every module)",
          ") (",
          "    input  wire logic               clk,",
          "    input  wire logic               rst,        // synchronous, active high; clears the valid pipeline",
          "    input  wire logic               in_valid,",
          "    input  wire logic               in_kind,    // 0 a contact record, 1 a friction record",
          "    input  wire logic [TAG_W-1:0]   in_tag,",
          "    input  wire logic [N_IN*W-1:0]  in_data,"]
    for port, s in dp.bool_ports.items():
        kinds = " and ".join(KIND_NAMES[k] for k in sorted(s.kinds))
        L.append(f"    input  wire logic               {port},   // read by the {kinds} pass")
    L += ["    input  wire logic               in_count,   // count this input's floating-point events",
          "    output logic                    out_valid,",
          "    output logic                    out_kind,",
          "    output logic      [TAG_W-1:0]   out_tag,",
          "    output logic      [N_OUT*W-1:0] out_data,",
          "    output logic      [EV_W-1:0]    ev_overflow,    // events raised in the previous cycle",
          "    output logic      [EV_W-1:0]    ev_underflow,",
          "    output logic      [EV_W-1:0]    ev_invalid",
          ");",
          "    // The schedule assumes the operator latencies declared in rtl/fp (read by the generator):",
          f"    // fp_add {dp.lat['fp_add'].sv()}, fp_mul {dp.lat['fp_mul'].sv()}, fp_div {dp.lat['fp_div'].sv()}, "
          f"fp_sqrt {dp.lat['fp_sqrt'].sv()}, fp_minmax LAT_MINMAX.",
          f"    localparam int LAT_MINMAX = {dp.lat['fp_minmax'].sv()};", ""]
    if dp.consts:
        L.append("    // Constants, rounded to the format at elaboration (RNE, flush to zero) like NumberFormat.round.")
        for key, v in dp.consts.items():
            L.append(f"    localparam logic [W-1:0] {e.const_name[key]} = "
                     f"W'(pgs_fp_pkg::fp_from_real({v.const!r}, EXP_BITS, MAN_BITS));")
        L.append("")
    minmax = [op for op in dp.operators if op.module == "fp_minmax"]
    L += ["    // Outputs of the operator instances that the datapath does not use: each operator's own valid bit (the",
          "    // pipeline carries a single valid bit, u_valid) and the fp_minmax results other than the ones selected.",
          "    /* verilator lint_off UNUSEDSIGNAL */",
          f"    logic [{len(dp.operators)}-1:0] op_valid_nc;"]
    for op in minmax:
        L.append(f"    logic [W-1:0] {op.outputs['min'].name}, {op.outputs['max'].name};")
        L.append(f"    logic         {op.outputs['lt'].name}, nc_{op.name}_eq, nc_{op.name}_uo;")
    L += ["    /* verilator lint_on UNUSEDSIGNAL */", ""]
    ev_depth = Time.max([op.outputs["y"].ready for op in flagged])
    L += ["    // Valid, kind and tag pipelines. valid_q[k]: in_valid k cycles ago, kind_q[k] its record's kind (read only",
          "    // with the valid bit); valid_c_q / valid_f_q: the valid bits of each kind, which enable the operators and",
          "    // delay lines only that kind uses.",
          "    /* verilator lint_off UNUSEDSIGNAL */",
          "    logic [LATENCY:0] valid_q, kind_q, valid_c_q, valid_f_q;   // not every stage is read",
          "    /* verilator lint_on UNUSEDSIGNAL */",
          "    logic [LATENCY:1] kind_r;",
          "    fp_valid_pipe #(.LATENCY(LATENCY)) u_valid (",
          "        .clk(clk), .rst(rst), .in_valid(in_valid), .stage_valid(valid_q), .out_valid(out_valid)",
          "    );",
          "    always_ff @(posedge clk) kind_r <= LATENCY'({kind_r, in_kind});   // one shift of the whole register",
          "    assign kind_q    = {kind_r, in_kind};",
          "    assign valid_c_q = valid_q & ~kind_q;",
          "    assign valid_f_q = valid_q & kind_q;",
          "    assign out_kind  = kind_q[LATENCY];",
          "    pgs_delay #(.WIDTH(TAG_W), .DEPTH(LATENCY), .BLOCK_MIN_DEPTH(DELAY_BLOCK_MIN_DEPTH)) u_tag (",
          "        .clk(clk), .d(in_tag), .valid(valid_q[LATENCY-1:0]), .q(out_tag)", "    );", "",
          "    // Event pipeline: ev_q[k] = (in_valid && in_count) k cycles ago (reset like the valid pipeline), and per",
          "    // kind; an operator's flags belong to the input taken at its ready cycle minus that many cycles.",
          f"    localparam int EV_DEPTH = {ev_depth.sv()};",
          "    logic [EV_DEPTH:1] ev_r;",
          "    /* verilator lint_off UNUSEDSIGNAL */",
          "    logic [EV_DEPTH:0] ev_q, ev_c_q, ev_f_q;   // read at the operators' ready cycles only",
          "    /* verilator lint_on UNUSEDSIGNAL */",
          "    always_ff @(posedge clk) begin   // one shift of the whole register",
          "        if (rst) ev_r <= '0;",
          "        else     ev_r <= EV_DEPTH'({ev_r, in_valid && in_count});",
          "    end",
          "    assign ev_q   = {ev_r, in_valid && in_count};",
          "    assign ev_c_q = ev_q & ~kind_q[EV_DEPTH:0];",
          "    assign ev_f_q = ev_q & kind_q[EV_DEPTH:0];",
          "    logic [N_FP_OPS-1:0] ev_ovf, ev_unf, ev_inv;   // flags of counted inputs, one bit per operator",
          "    always_ff @(posedge clk) begin",
          "        ev_overflow  <= EV_W'($countones(ev_ovf));",
          "        ev_underflow <= EV_W'($countones(ev_unf));",
          "        ev_invalid   <= EV_W'($countones(ev_inv));",
          "    end", ""]
    L.append("    // Input words and their delay lines.")
    for k, s in enumerate(dp.inputs):
        kinds = " and ".join(KIND_NAMES[x] for x in sorted(s.kinds))
        L.append(f"    logic [W-1:0] {s.name};   // read by the {kinds} pass")
        L.append(f"    assign {s.name} = in_data[{k}*W +: W];")
        L += e.line(s)
    for s in dp.bool_ports.values():
        L += e.line(s)
    L.append("")
    L += _wrap("Datapath in schedule order: the operators (each with the operation of every kind that uses it and the "
               "cycles it issues and is ready at, for " + " / ".join(KERNEL_FORMATS) + ") and the combinational "
               "nodes of each kind; a value's delay line feeds every consumer at the consumer's issue cycle.",
               prefix="    // ")
    ev_index = {id(op): k for k, op in enumerate(flagged)}
    k_op = {id(op): k for k, op in enumerate(dp.operators)}
    for item in emit_order(dp):
        if isinstance(item, Operator):
            L += e.operator(item, k_op[id(item)], ev_index.get(id(item)))
        else:
            assert isinstance(item, Comb)
            L += e.comb(item)
    L.append("")
    L.append("    // Outputs, each delayed to LATENCY, of the leaving record's kind.")
    for k, name in enumerate(lay.outputs):
        expr = e.select({CONTACT: dp.outputs[CONTACT][k], FRICTION: dp.outputs[FRICTION][k]}, dp.latency, "'0")
        L.append(f"    assign out_data[{k}*W +: W] = {expr};   // {name}")
    L += ["endmodule", "", "`default_nettype wire", ""]
    return "\n".join(L)
