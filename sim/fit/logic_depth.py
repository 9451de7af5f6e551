"""Register-to-register depth of a synthesized netlist: the timing estimate's walk (``make resources`` runs it on
each Yosys run's netlist, ``sim/fit/timing_estimate.py`` holds the results against a clock).

Yosys's own ``ltp`` does not stop at mapped flip-flops (it knows only Yosys's internal register cells), so this walks
the netlist that ``synth_xilinx`` wrote (``write_json``, hierarchy kept: every submodule instance is inlined here)
as a static timing analysis does: every net bit gets the latest arrival time of a signal launched by a clock edge,
through the combinational cells in topological order, and every register input the arrival plus its net and setup.
Cut points (start and end of a path): FDRE / FDSE / FDCE / FDPE, SRL16E / SRLC32E, the write ports and outputs of
distributed RAM (RAM32M16, RAM64M8, ... whose read address to data is combinational), block RAM (RAMB18E2 /
RAMB36E2), UltraRAM, a DSP48E2's internal registers where Yosys packed some (else the DSP48E2 is combinational), the
unit's ports, and the black boxes of the unit (another unit's module: the pipes in the control's run).

A path's delay uses :mod:`sim.fit.delays` (each cell and net; the net's delay grows with its fanout), and its logic
levels count as Vivado's ``report_design_analysis -logic_level_distribution`` does: each LUT, each CARRY8 and each
MUXF7/8/9 on the path (a DSP48E2 passed through counts one). Yosys maps carry chains to CARRY4 cells for
UltraScale+: a board flow packs two into a CARRY8, so a chain entered at S/DI counts one CARRY8 and each further
CARRY4 half of one. The worst path to each endpoint gives the distribution; the worst paths overall and per module
type are kept with their cells, start and end.

Results per unit (:func:`analyze`): the register-to-register histogram and worst paths, and the worst path from each
input port, to each output port, into and out of each black-box port, for :mod:`sim.fit.timing_estimate` to join
units at their boundaries.
"""

from __future__ import annotations

import json
import math
import re
from collections import defaultdict
from dataclasses import asdict, dataclass, field
import pathlib
from typing import Any, Iterable, Optional

from sim.fit.delays import FIGURES, DelayFigures

# --- cell classes -----------------------------------------------------------------------------------------------
LUTS = {"LUT1", "LUT2", "LUT3", "LUT4", "LUT5", "LUT6", "LUT6_2"}
MUXF = {"MUXF7", "MUXF8", "MUXF9"}
CARRY = {"CARRY4", "CARRY8"}
FLOPS = {"FDRE", "FDSE", "FDCE", "FDPE", "LDCE", "LDPE"}
SRLS = {"SRL16E", "SRLC16E", "SRLC32E"}
LUTRAMS = {"RAM32X1S", "RAM64X1S", "RAM32X1D", "RAM64X1D", "RAM128X1S", "RAM128X1D", "RAM256X1S", "RAM256X1D",
           "RAM32M", "RAM64M", "RAM32M16", "RAM64M8", "RAM512X1S"}
BRAMS = {"RAMB18E2", "RAMB36E2", "FIFO18E2", "FIFO36E2", "URAM288", "URAM288_BASE"}
DSPS = {"DSP48E2"}
PASS = {"INV", "BUF", "IBUF", "OBUF", "BUFG"}  # absorbed into the next LUT / not logic: no delay, no level
CLOCK_PINS = {"C", "CLK", "WCLK", "CLKARDCLK", "CLKBWRCLK", "CLKA", "CLKB"}
DEDICATED_PINS = {"CI", "CI_TOP", "PCIN", "ACIN", "BCIN", "CARRYCASCIN", "MULTSIGNIN", "CASDINA", "CASDINB"}
CONSTANTS = {"0", "1", "x", "z"}


@dataclass
class LogicPath:
    """One path: its delay from the launching clock edge to the capturing register's setup, and what it passes."""

    delay_ns: float
    luts: int
    carry8: float
    muxf: int
    dsp: int
    start: str
    end: str
    module: str  # the module type of the endpoint's instance ("" for the unit's own top)
    cells: list[str] = field(default_factory=list)  # cell types from start to end

    @property
    def levels(self) -> int:
        return self.luts + math.ceil(self.carry8) + self.muxf + self.dsp

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["delay_ns"] = round(self.delay_ns, 4)
        d["carry8"] = math.ceil(self.carry8)
        d["levels"] = self.levels
        d["cells"] = _compress(self.cells)
        return d


def _compress(cells: list[str]) -> str:
    """``LUT6 CARRY4 CARRY4 CARRY4 LUT3`` -> ``LUT6 CARRY4x3 LUT3``."""
    out: list[str] = []
    for c in cells:
        if out and out[-1].split("x")[0] == c and (out[-1] == c or re.fullmatch(rf"{c}x\d+", out[-1])):
            n = int(out[-1].split("x")[1]) + 1 if "x" in out[-1] else 2
            out[-1] = f"{c}x{n}"
        else:
            out.append(c)
    return " ".join(out)


# --- the netlist, inlined ---------------------------------------------------------------------------------------
@dataclass
class Cell:
    name: str  # hierarchical instance name
    type: str
    module: str  # type of the module instance holding it
    params: dict[str, str]
    inputs: dict[str, list[int]]  # pin -> net ids (-1: constant)
    outputs: dict[str, list[int]]


@dataclass
class Netlist:
    cells: list[Cell]
    net_names: dict[int, str]  # the first public name of each net (the outermost module's)
    inputs: dict[str, list[int]]  # top ports
    outputs: dict[str, list[int]]
    boxes: list[Cell]  # instances of modules the netlist does not define (black boxes)
    nets: int
    aliases: dict[int, list[str]] = field(default_factory=dict)  # every public name of each net


class NetlistError(ValueError):
    pass


def load(path: pathlib.Path, top: Optional[str] = None) -> Netlist:
    """The Yosys JSON netlist at ``path`` with every submodule instance inlined (the top module: the one marked top,
    or ``top``)."""
    data = json.loads(path.read_text())
    modules = {n: m for n, m in data.get("modules", {}).items() if not _flag(m, "blackbox")}
    if top is None:
        tops = [n for n, m in modules.items() if _flag(m, "top")]
        if len(tops) != 1:
            raise NetlistError(f"{path}: expected one top module, found {tops or 'none'}")
        top = tops[0]
    if top not in modules:
        raise NetlistError(f"{path}: no module {top!r}")
    builder = _Builder(modules)
    ports = modules[top]["ports"]
    mapping: dict[Any, int] = {}
    for name, p in ports.items():
        for b in p["bits"]:
            if b not in CONSTANTS and b not in mapping:
                mapping[b] = builder.new_net()
    builder.inline(top, "", _display(top), mapping)
    ins = {n: [mapping.get(b, -1) for b in p["bits"]] for n, p in ports.items() if p["direction"] == "input"}
    outs = {n: [mapping.get(b, -1) for b in p["bits"]] for n, p in ports.items() if p["direction"] == "output"}
    for n, bits in {**ins, **outs}.items():
        for i, b in enumerate(bits):
            if b >= 0:
                builder.names.setdefault(b, n if len(bits) == 1 else f"{n}[{i}]")
    return Netlist(builder.cells, builder.names, ins, outs, builder.boxes, builder.count, builder.aliases)


def _flag(module: dict[str, Any], attribute: str) -> bool:
    """A Yosys module attribute read as a bit (JSON writes them as binary strings)."""
    return str(module.get("attributes", {}).get(attribute, "0")).strip("0") != ""


def _display(module: str) -> str:
    """A module's plain name (Yosys's derived names of parameterised modules carry the parameters)."""
    m = re.match(r"\$paramod\$[0-9a-f]+\\(\w+)", module) or re.match(r"\$paramod\\(\w+)", module)
    if m:
        return m.group(1)
    return module.lstrip("\\").split("$")[0] or module


class _Builder:
    def __init__(self, modules: dict[str, Any]) -> None:
        self.modules = modules
        self.cells: list[Cell] = []
        self.boxes: list[Cell] = []
        self.names: dict[int, str] = {}
        self.aliases: dict[int, list[str]] = defaultdict(list)
        self.count = 0

    def new_net(self) -> int:
        self.count += 1
        return self.count - 1

    def inline(self, module: str, prefix: str, mtype: str, mapping: dict[Any, int]) -> None:
        m = self.modules[module]

        def net(b: Any) -> int:
            if b in CONSTANTS:
                return -1
            if b not in mapping:
                mapping[b] = self.new_net()
            return mapping[b]

        for name, nn in m.get("netnames", {}).items():
            if nn.get("hide_name"):
                continue
            bits = nn["bits"]
            for i, b in enumerate(bits):
                if b in CONSTANTS:
                    continue
                full = prefix + (name if len(bits) == 1 else f"{name}[{i}]")
                self.names.setdefault(net(b), full)
                self.aliases[net(b)].append(full)
        for cname, c in m.get("cells", {}).items():
            dirs = c.get("port_directions", {})
            conns = c.get("connections", {})
            inst = prefix + _clean(cname)
            if c["type"] in self.modules:  # a submodule: its port bits are this module's nets
                child: dict[Any, int] = {}
                for pname, p in self.modules[c["type"]]["ports"].items():
                    for cb, pb in zip(p["bits"], conns.get(pname, [])):
                        if cb not in CONSTANTS and cb not in child:
                            n = net(pb)
                            child[cb] = n if n >= 0 else self.new_net()
                self.inline(c["type"], inst + ".", _display(c["type"]), child)
                continue
            ins = {p: [net(b) for b in bits] for p, bits in conns.items() if dirs.get(p, "input") == "input"}
            outs = {p: [net(b) for b in bits] for p, bits in conns.items() if dirs.get(p) == "output"}
            cell = Cell(inst, c["type"], mtype, {k: str(v) for k, v in c.get("parameters", {}).items()}, ins, outs)
            (self.cells if _known(c["type"]) else self.boxes).append(cell)


def _clean(name: str) -> str:
    return name.lstrip("\\")


def _known(ctype: str) -> bool:
    return ctype in LUTS | MUXF | CARRY | FLOPS | SRLS | LUTRAMS | BRAMS | DSPS | PASS


# --- timing arcs ----------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Arc:
    """A combinational arc: from input pins to output pins, adding ``delay`` and the listed levels."""

    ins: tuple[str, ...]
    outs: tuple[str, ...]
    delay: float
    luts: int = 0
    carry8: float = 0.0
    muxf: int = 0
    dsp: int = 0


def _param(cell: Cell, name: str, default: int = 0) -> int:
    v = cell.params.get(name)
    if v is None:
        return default
    try:
        return int(v, 2) if set(v) <= {"0", "1"} and len(v) > 1 else int(v)
    except ValueError:
        return default


_DSP_MULT_PINS = ("A", "B", "D", "ACIN", "BCIN", "INMODE")
_DSP_ALU_PINS = ("C", "PCIN", "CARRYIN", "CARRYCASCIN", "MULTSIGNIN", "OPMODE", "ALUMODE", "CARRYINSEL")
_DSP_INPUT_REG = {"A": "AREG", "ACIN": "AREG", "B": "BREG", "BCIN": "BREG", "D": "DREG", "C": "CREG",
                  "OPMODE": "OPMODEREG", "ALUMODE": "ALUMODEREG", "INMODE": "INMODEREG", "CARRYIN": "CARRYINREG",
                  "CARRYINSEL": "CARRYINSELREG"}


@dataclass(frozen=True)
class CellTiming:
    arcs: tuple[Arc, ...]  # combinational
    ends: dict[str, float]  # input pin -> setup-side delay (an endpoint)
    starts: dict[str, float]  # output pin -> clock-to-out (a startpoint)
    note: str = ""  # an assumed figure on this cell's paths


def cell_timing(cell: Cell, f: DelayFigures = FIGURES) -> CellTiming:
    """How a cell's pins take part in paths."""
    t, ins, outs = cell.type, tuple(p for p in cell.inputs if p not in CLOCK_PINS), tuple(cell.outputs)
    if t in LUTS:
        return CellTiming((Arc(ins, outs, f.lut, luts=1),), {}, {})
    if t in MUXF:
        return CellTiming((Arc(ins, outs, f.muxf, muxf=1),), {}, {})
    if t in PASS:
        return CellTiming((Arc(ins, outs, 0.0),), {}, {})
    if t in CARRY:
        chain = tuple(p for p in ins if p in ("CI", "CI_TOP"))
        entry = tuple(p for p in ins if p not in chain)
        per = 0.5 if t == "CARRY4" else 1.0
        return CellTiming((Arc(entry, outs, f.carry_entry, carry8=1.0),
                           Arc(chain, outs, f.carry_next8 * per, carry8=per)), {}, {})
    if t in FLOPS:
        return CellTiming((), {p: f.ff_setup for p in ins}, {p: f.ff_clock_to_q for p in outs})
    if t in SRLS:
        addr = tuple(p for p in ins if re.fullmatch(r"A\d?", p))
        return CellTiming((Arc(addr, outs, f.lut, luts=1),), {p: f.srl_setup for p in ins if p not in addr},
                          {p: f.srl_clock_to_out for p in outs}, "SRL setup assumed")
    if t in LUTRAMS:
        addr = tuple(p for p in ins if p.startswith(("ADDR", "DPRA", "A")) and p not in ("ADDRH",))
        return CellTiming((Arc(addr, outs, f.lut, luts=1),), {p: f.srl_setup for p in ins if p not in addr or
                                                               p.startswith("ADDRH")},
                          {p: f.srl_clock_to_out for p in outs}, "distributed RAM write setup assumed")
    if t in BRAMS:
        return CellTiming((), {p: f.bram_setup for p in ins}, {p: f.bram_clock_to_out for p in outs},
                          "block RAM setup assumed")
    if t in DSPS:
        return _dsp_timing(cell, ins, outs, f)
    raise NetlistError(f"no timing for cell type {t}")


def _dsp_timing(cell: Cell, ins: tuple[str, ...], outs: tuple[str, ...], f: DelayFigures) -> CellTiming:
    """A DSP48E2 by its registers: outputs behind PREG start a path; behind MREG only, they start after the
    post-adder; inputs with their own register (AREG, ...) end one; the rest pass the multiplier and / or post-adder
    combinationally, to P or to the first internal register."""
    mult = cell.params.get("USE_MULT", "MULTIPLY") != "NONE"
    preg, mreg = _param(cell, "PREG"), _param(cell, "MREG")
    arcs, ends, starts = [], {}, {}
    data_outs = tuple(p for p in outs if p in ("P", "PCOUT", "CARRYOUT", "CARRYCASCOUT", "MULTSIGNOUT",
                                                "PATTERNDETECT", "PATTERNBDETECT", "OVERFLOW", "UNDERFLOW",
                                                "XOROUT"))
    cascade_outs = tuple(p for p in outs if p in ("ACOUT", "BCOUT"))
    note = ""
    for p in ins:
        reg = _DSP_INPUT_REG.get(p)
        through_mult = p in _DSP_MULT_PINS and mult
        if (reg and _param(cell, reg) > 0) or p.startswith(("CE", "RST")):
            ends[p] = f.dsp_setup
            note = "DSP48E2 register setup / clock-to-out assumed"
        elif preg:
            ends[p] = (f.dsp_mult_alu if through_mult else f.dsp_alu) + f.dsp_setup
            note = "DSP48E2 register setup / clock-to-out assumed"
        elif through_mult and mreg:
            ends[p] = f.dsp_mult_alu - f.dsp_alu + f.dsp_setup
            note = "DSP48E2 register setup / clock-to-out assumed"
        else:
            arcs.append(Arc((p,), data_outs, f.dsp_mult_alu if through_mult else f.dsp_alu, dsp=1))
        if p in ("A", "B", "ACIN", "BCIN") and cascade_outs:
            arcs.append(Arc((p,), cascade_outs, 0.0))
    for p in data_outs:
        if preg:
            starts[p] = f.dsp_clock_to_out
        elif mreg:
            starts[p] = f.dsp_clock_to_out + f.dsp_alu
    return CellTiming(tuple(a for a in arcs if a.ins and a.outs), ends, starts, note)


# --- the walk -------------------------------------------------------------------------------------------------------
@dataclass
class _Arrival:
    delay: float
    luts: int
    carry8: float
    muxf: int
    dsp: int
    cell: int  # index of the cell that drove it (-1: a start)
    prev: int  # the input net of the worst arc (-1: a start)
    start: str


class _Walk:
    """Arrival times over the inlined netlist from one set of starts."""

    def __init__(self, nl: Netlist, f: DelayFigures) -> None:
        self.nl, self.f = nl, f
        self.timing = [cell_timing(c, f) for c in nl.cells]
        self.fanout = [0] * nl.nets
        self.driver: dict[int, tuple[int, str]] = {}
        for ci, c in enumerate(nl.cells + nl.boxes):
            for pins in c.inputs.values():
                for n in pins:
                    if n >= 0:
                        self.fanout[n] += 1
        for ci, c in enumerate(nl.cells):
            for pin, nets in c.outputs.items():
                for n in nets:
                    if n >= 0:
                        self.driver[n] = (ci, pin)
        for nets in nl.outputs.values():
            for n in nets:
                if n >= 0:
                    self.fanout[n] += 1
        self.order, self.loops = self._topological()

    def net_delay(self, net: int, pin: str, ctype: str) -> float:
        if pin in DEDICATED_PINS:
            return 0.0
        if ctype in MUXF and pin in ("I0", "I1"):
            return 0.0
        if ctype in CARRY:
            return self.f.net_to_carry
        return self.f.net(self.fanout[net])

    def _topological(self) -> tuple[list[int], int]:
        """Combinational cells in an order where each follows the cells driving its arcs' inputs (Kahn)."""
        comb = [i for i, t in enumerate(self.timing) if t.arcs]
        deps: dict[int, set[int]] = {}
        users: dict[int, list[int]] = defaultdict(list)
        for i in comb:
            d = set()
            for arc in self.timing[i].arcs:
                for pin in arc.ins:
                    for n in self.nl.cells[i].inputs.get(pin, []):
                        drv = self.driver.get(n)
                        if drv is not None and self.timing[drv[0]].arcs and self._arc_output(drv[0], drv[1]):
                            d.add(drv[0])
            deps[i] = d
            for j in d:
                users[j].append(i)
        ready = [i for i in comb if not deps[i]]
        order = []
        remaining = {i: len(deps[i]) for i in comb}
        while ready:
            i = ready.pop()
            order.append(i)
            for u in users[i]:
                remaining[u] -= 1
                if remaining[u] == 0:
                    ready.append(u)
        return order, len(comb) - len(order)

    def _arc_output(self, ci: int, pin: str) -> bool:
        return any(pin in a.outs for a in self.timing[ci].arcs)

    def run(self, starts: dict[int, _Arrival]) -> list[Optional[_Arrival]]:
        arr: list[Optional[_Arrival]] = [None] * self.nl.nets
        for n, a in starts.items():
            arr[n] = a
        for ci in self.order:
            cell, timing = self.nl.cells[ci], self.timing[ci]
            for arc in timing.arcs:
                best: Optional[tuple[float, int, _Arrival]] = None
                for pin in arc.ins:
                    for n in cell.inputs.get(pin, []):
                        a = arr[n] if n >= 0 else None
                        if a is None:
                            continue
                        d = a.delay + self.net_delay(n, pin, cell.type)
                        if best is None or d > best[0]:
                            best = (d, n, a)
                if best is None:
                    continue
                d, n, a = best
                new = _Arrival(d + arc.delay, a.luts + arc.luts, a.carry8 + arc.carry8, a.muxf + arc.muxf,
                               a.dsp + arc.dsp, ci, n, a.start)
                for pin in arc.outs:
                    for o in cell.outputs.get(pin, []):
                        if o >= 0 and (arr[o] is None or arr[o].delay < new.delay):  # type: ignore[union-attr]
                            arr[o] = new
        return arr

    def cells_on(self, arr: list[Optional[_Arrival]], net: int) -> list[str]:
        out = []
        seen = 0
        while net >= 0 and arr[net] is not None and arr[net].cell >= 0 and seen < 10_000:  # type: ignore[union-attr]
            a = arr[net]
            out.append(self.nl.cells[a.cell].type)  # type: ignore[union-attr]
            net = a.prev  # type: ignore[union-attr]
            seen += 1
        return out[::-1]


def _name(nl: Netlist, net: int, fallback: str) -> str:
    return nl.net_names.get(net, fallback)


def _stem(name: str) -> str:
    return re.sub(r"\[\d+\]$", "", name)


@dataclass
class Analysis:
    """The depth of one unit's netlist (see the module docstring)."""

    endpoints: int
    histogram: dict[int, int]  # logic levels -> register-to-register endpoints
    worst: list[LogicPath]
    by_module: dict[str, LogicPath]
    inputs: dict[str, LogicPath]  # input port -> worst path from it to a register
    outputs: dict[str, LogicPath]  # output port -> worst path from a register to it (delay: arrival at the port)
    box_in: dict[str, LogicPath]  # "instance:port" -> worst path from a register into the black box's input
    box_out: dict[str, LogicPath]  # "instance:port" -> worst path from the black box's output to a register
    loops: int  # combinational cells left out of the walk by a loop
    notes: list[str]
    boxes: dict[str, str] = field(default_factory=dict)  # black-box instance -> its module
    from_arguments: list[LogicPath] = field(default_factory=list)  # the worst paths from kernel argument registers

    def as_dict(self) -> dict[str, Any]:
        return {"endpoints": self.endpoints, "histogram": {str(k): v for k, v in sorted(self.histogram.items())},
                "worst": [p.as_dict() for p in self.worst],
                "by_module": {k: p.as_dict() for k, p in sorted(self.by_module.items())},
                "inputs": {k: p.as_dict() for k, p in sorted(self.inputs.items())},
                "outputs": {k: p.as_dict() for k, p in sorted(self.outputs.items())},
                "box_in": {k: p.as_dict() for k, p in sorted(self.box_in.items())},
                "box_out": {k: p.as_dict() for k, p in sorted(self.box_out.items())},
                "boxes": dict(sorted(self.boxes.items())), "from_arguments": [p.as_dict() for p in self.from_arguments],
                "loops": self.loops, "notes": self.notes}


WORST_PATHS = 8


# --- module types of a flattened netlist's names ----------------------------------------------------------------
_MODULE_DECL = re.compile(r"^\s*module\s+(\w+)", re.M)


def _skip_parens(text: str, i: int) -> int:
    """The index after the parenthesis group that opens at ``text[i]``."""
    depth = 0
    for j in range(i, len(text)):
        if text[j] == "(":
            depth += 1
        elif text[j] == ")":
            depth -= 1
            if depth == 0:
                return j + 1
    return len(text)


def instance_types(sources: dict[str, str]) -> dict[str, dict[str, str]]:
    """For each module defined in ``sources`` (file name -> text), its instances of the other modules: instance
    name -> module type."""
    texts = "\n".join(sources.values())
    modules = set(_MODULE_DECL.findall(texts))
    out: dict[str, dict[str, str]] = {}
    for text in sources.values():
        bodies = list(_MODULE_DECL.finditer(text))
        for k, m in enumerate(bodies):
            body = text[m.end(): bodies[k + 1].start() if k + 1 < len(bodies) else len(text)]
            insts = out.setdefault(m.group(1), {})
            for inst in re.finditer(r"\b(" + "|".join(sorted(modules)) + r")\b\s*", body):
                j = inst.end()
                if body[j: j + 1] == "#":
                    j = body.index("(", j)
                    j = _skip_parens(body, j)
                name = re.match(r"\s*(\w+)\s*\(", body[j:])
                if name:
                    insts[name.group(1)] = inst.group(1)
    return out


def module_of(name: str, top: str, types: dict[str, dict[str, str]]) -> str:
    """The module type holding the register ``name`` (a flattened hierarchical name; generate blocks skipped)."""
    cur = top
    for comp in name.split(".")[:-1]:
        comp = re.sub(r"\[\d+\]$", "", comp)
        nxt = types.get(cur, {}).get(comp)
        if nxt is not None:
            cur = nxt
    return cur


# --- delay lines in block RAM ---------------------------------------------------------------------------------
_DEPTH_PARAM = re.compile(r"\.DEPTH\((\w+)\)")
_LOCALPARAM = re.compile(r"localparam\s+int\s+(\w+)\s*=\s*(\d+)")


def delay_line_depths(source: str) -> dict[str, int]:
    """The depth of each ``pgs_delay`` instance of a generated pipe's source (instance name -> DEPTH)."""
    consts = {k: int(v) for k, v in _LOCALPARAM.findall(source)}
    out = {}
    for m in re.finditer(r"\bpgs_delay\s*#\s*\(", source):
        end = _skip_parens(source, m.end() - 1)
        params = source[m.end() - 1: end]
        name = re.match(r"\s*(\w+)\s*\(", source[end:])
        d = _DEPTH_PARAM.search(params)
        if name is None or d is None:
            continue
        depth = int(d.group(1)) if d.group(1).isdigit() else consts.get(d.group(1))
        if depth is not None:
            out[name.group(1)] = depth
    return out


def block_ram_taps(depths: dict[str, int], threshold: int) -> tuple[str, ...]:
    """Name prefixes of the read-tap registers of the delay lines a build with ``DELAY_BLOCK_MIN_DEPTH = threshold``
    keeps in block RAM (``rtl/pgs_delay.sv``: the registered read of a tap of delay >= 2 is the block RAM's output
    latch)."""
    if threshold <= 0:
        return ()
    return tuple(f"{inst}.g_ram.g_tap[" for inst, d in sorted(depths.items()) if d >= threshold)


def _is_bram_tap(names: Iterable[str], taps: tuple[str, ...]) -> bool:
    return bool(taps) and any(n.startswith(taps) and ".g_read.r" in n for n in names)


def argument_register(nl: Netlist, net: int, arguments: Iterable[str]) -> bool:
    """Whether ``net`` is the output of one of the register file's kernel arguments (``u_control.<argument>``: written by
    the host before ``ap_start``, held through a step)."""
    args = tuple(f"u_control.{a}" for a in arguments)
    return any(re.sub(r"\[\d+\]$", "", n) in args for n in nl.aliases.get(net, ()))


def analyze(nl: Netlist, f: DelayFigures = FIGURES, bram_taps: tuple[str, ...] = (),
            arguments: Iterable[str] = (), types: Optional[dict[str, dict[str, str]]] = None,
            top: str = "") -> Analysis:
    """Every register-to-register path's depth in ``nl``, and its boundary paths (see :class:`Analysis`);
    the registers named by ``bram_taps`` (:func:`block_ram_taps`) start their paths at a block RAM's clock-to-out.
    Paths from the kernel's argument registers (``arguments``: static through a step, a multicycle path a board build
    constrains) are kept apart, in ``from_arguments``."""
    walk = _Walk(nl, f)
    arguments = tuple(arguments)
    # 1. from the registers (and RAM / DSP outputs) to registers, output ports and black-box inputs
    starts: dict[int, _Arrival] = {}
    static: dict[int, _Arrival] = {}
    notes: set[str] = set()
    for ci, (c, t) in enumerate(zip(nl.cells, walk.timing)):
        for pin, tco in t.starts.items():
            for i, n in enumerate(c.outputs.get(pin, [])):
                if n >= 0:
                    name = _name(nl, n, f"{c.name}/{pin}")
                    if c.type in FLOPS and _is_bram_tap(nl.aliases.get(n, [name]), bram_taps):
                        tco = f.bram_clock_to_out
                        notes.add("delay lines in block RAM: their taps start at the block RAM's clock-to-out")
                    a = _Arrival(tco, 0, 0.0, 0, 0, -1, -1, name)
                    if arguments and c.type in FLOPS and argument_register(nl, n, arguments):
                        static[n] = a
                    else:
                        starts[n] = a
    from_arguments = []
    if static:
        arr = walk.run(static)
        best: dict[str, tuple[LogicPath, int]] = {}
        for p, n in _endpoints(nl, walk, arr):
            k = _stem(p.end)
            if k not in best or best[k][0].delay_ns < p.delay_ns:
                best[k] = (p, n)
        for p, n in sorted(best.values(), key=lambda pn: -pn[0].delay_ns)[:WORST_PATHS // 2]:
            p.cells = walk.cells_on(arr, n)
            from_arguments.append(p)
    reg = walk.run(starts)
    ends = list(_endpoints(nl, walk, reg))
    if types:
        for p, _n in ends:
            p.module = module_of(p.end, top, types)
    histogram: dict[int, int] = defaultdict(int)
    best_by_end: dict[str, LogicPath] = {}
    by_module: dict[str, LogicPath] = {}
    for p, _net in ends:
        histogram[p.levels] += 1
        key = _stem(p.end)
        if key not in best_by_end or best_by_end[key].delay_ns < p.delay_ns:
            best_by_end[key] = p
    worst_keys = sorted(best_by_end, key=lambda k: -best_by_end[k].delay_ns)[:WORST_PATHS]
    net_of = {id(p): n for p, n in ends}
    worst = []
    for k in worst_keys:
        p = best_by_end[k]
        p.cells = walk.cells_on(reg, net_of[id(p)])
        worst.append(p)
    for p, n in ends:
        cur = by_module.get(p.module)
        if cur is None or cur.delay_ns < p.delay_ns:
            by_module[p.module] = p
    for p in by_module.values():
        if not p.cells:
            p.cells = walk.cells_on(reg, net_of[id(p)])
    for ci, t in enumerate(walk.timing):
        if t.note and (t.starts or t.ends):
            notes.add(t.note)
    outputs = _port_paths(nl, walk, reg, nl.outputs, "output")
    box_in = _box_in_paths(nl, walk, reg)
    # 2. from the input ports (arrival 0 at the port) to registers
    inputs = {port: best for port, nets in nl.inputs.items() if port not in ("clk", "clock", "ap_clk")
              for best in [_worst_from(nl, walk, nets, port)] if best is not None}
    # 3. from black-box outputs (arrival 0) to registers
    box_out = {f"{b.name}:{pin}": best for b in nl.boxes for pin, nets in b.outputs.items()
               for best in [_worst_from(nl, walk, nets, f"{b.name}:{pin}")] if best is not None}
    return Analysis(len(ends), dict(histogram), worst, by_module, inputs, outputs, box_in, box_out, walk.loops,
                    sorted(notes), {b.name: _display(b.type) for b in nl.boxes}, from_arguments)


def _worst_from(nl: Netlist, walk: _Walk, nets: list[int], start: str) -> Optional[LogicPath]:
    """The worst path from ``nets`` (a port or a black box's output bus, arrival 0) to a register; None: none."""
    s = {n: _Arrival(0.0, 0, 0.0, 0, 0, -1, -1, start) for n in nets if n >= 0}
    if not s:
        return None
    arr = walk.run(s)
    return max((p for p, _ in _endpoints(nl, walk, arr)), key=lambda p: p.delay_ns, default=None)


def _endpoints(nl: Netlist, walk: _Walk, arr: list[Optional[_Arrival]]) -> Iterable[tuple[LogicPath, int]]:
    """The worst path into each register-side input pin bit reached by ``arr``."""
    for ci, (c, t) in enumerate(zip(nl.cells, walk.timing)):
        for pin, setup in t.ends.items():
            for i, n in enumerate(c.inputs.get(pin, [])):
                a = arr[n] if n >= 0 else None
                if a is None:
                    continue
                out_net = next((o for nets in c.outputs.values() for o in nets if o >= 0), -1)
                end = _name(nl, out_net, c.name) if c.type in FLOPS else f"{c.name}/{pin}"
                yield (LogicPath(a.delay + walk.net_delay(n, pin, c.type) + setup, a.luts, a.carry8, a.muxf, a.dsp,
                            a.start, end, c.module), n)


def _latest(arr: list[Optional[_Arrival]], nets: list[int]) -> Optional[tuple[_Arrival, int]]:
    """The latest arrival among ``nets`` (a bus's bits) and its net; None when none has one."""
    best: Optional[tuple[_Arrival, int]] = None
    for n in nets:
        a = arr[n] if n >= 0 else None
        if a is not None and (best is None or a.delay > best[0].delay):
            best = (a, n)
    return best


def _port_paths(nl: Netlist, walk: _Walk, arr: list[Optional[_Arrival]], ports: dict[str, list[int]],
                kind: str) -> dict[str, LogicPath]:
    out = {}
    for port, nets in ports.items():
        best = _latest(arr, nets)
        if best is not None:
            a, n = best
            out[port] = LogicPath(a.delay, a.luts, a.carry8, a.muxf, a.dsp, a.start, f"{kind} {port}", "",
                             walk.cells_on(arr, n))
    return out


def _box_in_paths(nl: Netlist, walk: _Walk, arr: list[Optional[_Arrival]]) -> dict[str, LogicPath]:
    out = {}
    for b in nl.boxes:
        for pin, nets in b.inputs.items():
            if pin in CLOCK_PINS or pin == "clk":
                continue
            best = _latest(arr, nets)
            if best is not None:
                a, n = best
                out[f"{b.name}:{pin}"] = LogicPath(a.delay, a.luts, a.carry8, a.muxf, a.dsp, a.start,
                                              f"{b.name}:{pin}", b.type, walk.cells_on(arr, n))
    return out
