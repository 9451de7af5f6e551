"""The timing estimate of a kernel configuration: its units' register-to-register depth (``sim/fit/logic_depth.py``
on each Yosys netlist, committed by ``make resources`` in ``sim/fit/generated/timing_figures.json``) held against
the budget of the platform's clock (``sim/fit/delays.py``).

A configuration's paths are those inside each unit it builds (the contact, friction and integrate pipes, the control
of its kernel) and those that cross between them, joined here at the control's black boxes:

* a pipe: the control's worst path into a pipe input port, then the pipe's worst path from that port to a register
  (and the other way for its outputs; a port's worst arrival is joined with the worst path of the other side, which
  can pair two bits that are not connected: pessimistic);
* a memory the control run keeps as a black box (``CONTROL_BLACKBOXES``), mapped as the resource model maps it:
  block RAM (the records' ring and their heads, the impulse ring and RAM, the rejected-slot flags with the impulses
  in the records, the body RAM's banks) starts a path at the block RAM's clock-to-out and ends one at its setup; an
  asynchronous distributed RAM (the rejected-slot flags with the impulses on chip) is a read tree: the LUT RAM read and a 4:1 LUT per level of the depth multiplexer; the body RAM's
  banked reads add the multiplexer from the 2 x banks port outputs, its writes the one from the 2 x lanes writes
  (``resource_model.bank_mux_resources``: computed, not synthesized);
* the body RAM's dynamic and bad flags (distributed RAM, a bit per body, read asynchronously at the offered record's
  bodies: ``rtl/pgs_body_ram.sv`` dyn_addr) are a read tree of the scene's bodies after the address: in the window
  kernel the address is the ring heads' block RAM output (read a cycle ahead: ``rtl/pgs_window.sv``), in the
  streaming kernel a register (the record assembler's).

The delay lines a build keeps in block RAM (``delay_block_min_depth``) start their taps' paths at the block RAM's
clock-to-out: each pipe's depth is committed for the thresholds the builds use. The control of two lanes is the
one-lane control's figure (the lanes' crossbar and second issue checks were not synthesized:
``resource_model.control_resources``).
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Union

from models.kernel.kernel_job import KernelJob
from models.timing import platforms
from rtl.gen.kernel_graphs import shared_module
from sim.fit import delays
from sim.fit import resource_model as rm

TIMING_FILE = Path(__file__).parent / "generated" / "timing_figures.json"
TIMING_CODE = (Path(__file__).parent / "logic_depth.py", Path(__file__).parent / "delays.py")


def code_digest() -> str:
    """A hash of the walk and the delay figures' source: the committed timing names the code that computed it."""
    return hashlib.sha256(b"".join(p.read_bytes() for p in TIMING_CODE)).hexdigest()[:12]
SHARED_PIPE = shared_module()  # a lane's shared datapath of the default options
# the pipes ``make resources`` synthesizes whole (module -> unit name): their netlists' depth, their Yosys figures
PIPE_UNITS = {"pgs_contact_pipe": "contact", "pgs_friction_pipe": "friction", "pgs_integrate_pipe": "integrate",
              SHARED_PIPE: "shared"}
# a shared datapath without a Yosys run of its own, timed and banded with the default one's run (module -> why):
# the 1-word inverse inertia's has the same operators, multiplexers and stages, and four fewer delay lines
STAND_IN_PIPES = {shared_module(1): f"{shared_module(1)} as {SHARED_PIPE}'s Yosys run (the same operators, "
                                    "multiplexers and stages; four fewer delay lines)"}
DSP_ADDER_UNIT = rm.ADDER_FORMS["dsp"]  # the operator unit of fp_add's DSP48E2 form (its own Yosys run)
BLOCK_RAM_BOXES = {"pgs_impulse_ram", "pgs_body_ram"}


def timing_figures(path: Path = TIMING_FILE) -> dict[str, Any]:
    """The committed timing figures (read once, like the resource figures: ``rm.figures``)."""
    return rm.figures(path)


@dataclass(frozen=True)
class TimedPath:
    """A register-to-register path of a configuration: its delay (launch clock-to-out to capture setup) and levels."""

    where: str  # the unit, or the units it crosses
    delay_ns: float
    luts: int
    carry8: int
    muxf: int
    dsp: int
    start: str
    end: str
    cells: str
    module: str = ""

    @property
    def levels(self) -> int:
        return self.luts + self.carry8 + self.muxf + self.dsp

    def levels_text(self) -> str:
        parts = [f"{self.luts} LUT"] + ([f"{self.carry8} CARRY8"] if self.carry8 else []) + (
            [f"{self.muxf} MUXF"] if self.muxf else []) + ([f"{self.dsp} DSP48E2"] if self.dsp else [])
        return " + ".join(parts)

    def describe(self) -> str:
        mod = f" [{self.module}]" if self.module and self.module not in self.where else ""
        return (f"{self.where}{mod}: {self.start} -> {self.end}, {self.levels} levels ({self.levels_text()}), "
                f"{self.delay_ns:.2f} ns")


def _path(where: str, d: dict[str, Any]) -> TimedPath:
    return TimedPath(where, d["delay_ns"], d["luts"], d["carry8"], d["muxf"], d["dsp"], d["start"], d["end"],
                     d.get("cells", ""), d.get("module", ""))


def _join(where: str, first: dict[str, Any], second: dict[str, Any], extra: Optional[TimedPath] = None) -> TimedPath:
    """``first`` (arrival at a boundary), an optional piece between, then ``second`` (from the boundary on)."""
    parts = [first] + ([{"delay_ns": extra.delay_ns, "luts": extra.luts, "carry8": extra.carry8,
                         "muxf": extra.muxf, "dsp": extra.dsp, "cells": extra.cells}] if extra else []) + [second]
    return TimedPath(where, sum(p["delay_ns"] for p in parts), sum(p["luts"] for p in parts),
                     sum(p["carry8"] for p in parts), sum(p["muxf"] for p in parts), sum(p["dsp"] for p in parts),
                     first["start"], second["end"], " | ".join(p.get("cells", "") for p in parts if p.get("cells")),
                     second.get("module", ""))


def _piece(name: str, delay: float, luts: int = 0, muxf: int = 0, start: str = "", end: str = "") -> TimedPath:
    return TimedPath(name, delay, luts, 0, muxf, 0, start or name, end or name, " ".join(["LUT"] * luts))


def read_tree(depth: int, f: delays.DelayFigures = delays.FIGURES) -> TimedPath:
    """An asynchronous distributed-RAM read of ``depth`` words: the RAM64 read (a LUT, its address net at the fanout
    cap: the address drives every block) and a 4:1 LUT per level of the multiplexer over the 64-word blocks."""
    levels = math.ceil(math.log(max(1, math.ceil(depth / 64)), 4)) if depth > 64 else 0
    delay = f.net(delays.FANOUT_CAP) + f.lut + levels * f.lut_level
    return _piece(f"distributed RAM read, {depth:,} deep", delay, luts=1 + levels)


def mux_tree(inputs: int, f: delays.DelayFigures = delays.FIGURES) -> TimedPath:
    """A multiplexer of ``inputs`` words with registered selects: a 4:1 LUT per level."""
    levels = math.ceil(math.log(inputs, 4)) if inputs > 1 else 0
    return _piece(f"{inputs}:1 multiplexer", levels * f.lut_level, luts=levels)


@dataclass
class TimingVerdict:
    platform: str
    budget: delays.Budget
    paths: list[TimedPath]  # worst first: each unit's deepest and every joined boundary's
    histograms: dict[str, dict[int, int]]  # unit -> logic levels -> register-to-register endpoints
    missing: list[str] = field(default_factory=list)  # parts without a figure
    notes: list[str] = field(default_factory=list)
    argument_paths: list[TimedPath] = field(default_factory=list)  # from kernel argument registers (multicycle)

    @property
    def worst(self) -> TimedPath:
        return self.paths[0]

    @property
    def required_ns(self) -> float:
        return self.budget.period_ns - delays.FIGURES.clock_uncertainty

    @property
    def meets(self) -> bool:
        return self.worst.delay_ns <= self.required_ns

    @property
    def slack_ns(self) -> float:
        return self.required_ns - self.worst.delay_ns

    @property
    def fmax_hz(self) -> float:
        return delays.fmax_hz(self.worst.delay_ns)

    @property
    def failing(self) -> list[TimedPath]:
        return [p for p in self.paths if p.delay_ns > self.required_ns]

    @property
    def clock_hz(self) -> float:
        """The clock this estimate supports: the platform's, or the highest the worst path allows below it."""
        return self.budget.clock_hz if self.meets else self.fmax_hz

    def headline(self) -> str:
        mhz = f"{self.budget.clock_hz / 1e6:g} MHz"
        gaps = f"; not covered: {', '.join(self.missing)}" if self.missing else ""
        if self.meets:
            return f"meets {mhz} (estimate): slack {self.slack_ns:.2f} ns on {self.worst.describe()}{gaps}"
        return (f"fails {mhz} (estimate): {self.worst.describe()} against {self.required_ns:.2f} ns; "
                f"{len(self.failing)} path group(s) over; supports about {self.fmax_hz / 1e6:.0f} MHz{gaps}")


@dataclass(frozen=True)
class NoTiming:
    reason: str


def pipe_unit(module: str) -> Optional[str]:
    """The Yosys unit whose run stands for ``module`` (its own, or :data:`STAND_IN_PIPES`'s); None: no run."""
    return PIPE_UNITS.get(module) or (PIPE_UNITS[SHARED_PIPE] if module in STAND_IN_PIPES else None)


def _units(cfg: rm.KernelConfig) -> tuple[dict[str, str], list[str]]:
    """The units a configuration builds (module -> unit name) and the parts without a unit of their own."""
    units, missing = {}, []
    for module, _ in rm.lane_pipes(cfg) + [("pgs_integrate_pipe", 1)]:
        unit = pipe_unit(module)
        if unit is not None:
            units[module] = unit
        else:
            missing.append(f"{module} (no Yosys run of it)")
    units["control"] = rm.WINDOW_CONTROL_UNIT if cfg.window else rm.control_unit(cfg.body_bits)
    return units, missing


def _analysis(data: dict[str, Any], fmt: str, unit: str, threshold: int) -> Optional[dict[str, Any]]:
    entry = data.get("units", {}).get(fmt, {}).get(unit)
    if entry is None:
        return None
    return entry.get(str(threshold)) or entry.get("0")


def timing(cfg: rm.KernelConfig, platform: platforms.Platform, data: Optional[dict[str, Any]] = None,
           figures: delays.DelayFigures = delays.FIGURES) -> Union[TimingVerdict, NoTiming]:
    """The configuration's timing estimate on ``platform``'s clock."""
    data = data if data is not None else timing_figures()
    if data.get("figures") != figures.digest():
        return NoTiming(f"{TIMING_FILE.name} was computed with other delay figures: `{rm.REGENERATE}`")
    fmt = cfg.fmt.name
    units, missing = _units(cfg)
    stale = [] if data.get("code") == code_digest() else [
        f"{TIMING_FILE.name} was computed by an older sim/fit/logic_depth.py: `{rm.REGENERATE}`"]
    analyses: dict[str, dict[str, Any]] = {}
    for module, unit in units.items():
        threshold = cfg.delay_block_min_depth if unit in PIPE_UNITS.values() else 0
        a = _analysis(data, fmt, unit, threshold)
        if a is None and unit == rm.WINDOW_CONTROL_UNIT:
            a = _analysis(data, fmt, rm.control_unit(cfg.body_bits), 0)
            missing.append("the window kernel's control (the streaming kernel's in its place)")
        if a is None:
            missing.append(f"{unit} in {fmt} (`{rm.REGENERATE} FORMATS={fmt}` adds it)")
            continue
        analyses[unit] = a
    if not analyses:
        return NoTiming(f"no timing figures of {fmt} in {TIMING_FILE.name}: `{rm.REGENERATE} FORMATS={fmt}`")
    control = analyses.get(units["control"])
    dsp_adder = _dsp_adder_analysis(cfg, data, missing)
    if dsp_adder is not None:
        analyses[DSP_ADDER_UNIT] = dsp_adder
    paths = [_path(u, p) for u, a in analyses.items() for p in a["worst"][:1]]
    paths += [_path(u, p) for u, a in analyses.items() for m, p in a["by_module"].items()]
    notes: set[str] = {n for a in analyses.values() for n in a.get("notes", [])}
    notes.update(STAND_IN_PIPES[m] for m, _ in rm.lane_pipes(cfg) if m in STAND_IN_PIPES)
    if cfg.adders == "dsp":
        notes.add(f"the pipes' paths with the fabric adders (their Yosys runs), beside them {DSP_ADDER_UNIT}'s own "
                  "(every fp_add of a build with ADD_SHIFT_DSP = 1)")
    if control is not None:
        paths += _boundaries(cfg, control, analyses, figures, notes)
    paths.sort(key=lambda p: -p.delay_ns)
    paths = _distinct(paths)
    hist = {u: {int(k): v for k, v in a["histogram"].items()} for u, a in analyses.items()}
    if cfg.lanes > 1:
        notes.add(f"control of {cfg.lanes} lanes: the one-lane control's paths (its crossbar not synthesized)")
    args = sorted((_path(u, p) for u, a in analyses.items() for p in a.get("from_arguments", [])),
                  key=lambda p: -p.delay_ns)
    return TimingVerdict(platform.name, delays.budget(platform.preset.clock_hz, figures), paths, hist, missing,
                         stale + sorted(notes), args)


def _dsp_adder_analysis(cfg: rm.KernelConfig, data: dict[str, Any], missing: list[str]) -> Optional[dict[str, Any]]:
    """The DSP48E2 adder's own analysis, for a configuration whose fp_add instances take that form (the whole pipes
    were analysed with the fabric form); None for the fabric form, or when it has none (then named in ``missing``)."""
    if cfg.adders != "dsp":
        return None
    a = _analysis(data, cfg.fmt.name, DSP_ADDER_UNIT, 0)
    if a is None:
        missing.append(f"{DSP_ADDER_UNIT} in {cfg.fmt.name} (`{rm.REGENERATE} FORMATS={cfg.fmt.name}` adds it)")
    return a


def _distinct(paths: list[TimedPath]) -> list[TimedPath]:
    seen, out = set(), []
    for p in paths:
        key = (p.where, p.start, p.end)
        if key not in seen:
            seen.add(key)
            out.append(p)
    return out


def _box(key: str) -> tuple[str, str]:
    inst, pin = key.rsplit(":", 1)
    return inst, pin


def _boundaries(cfg: rm.KernelConfig, control: dict[str, Any], analyses: dict[str, dict[str, Any]],
                f: delays.DelayFigures, notes: set[str]) -> list[TimedPath]:
    """The paths that cross the control's black boxes (see the module docstring)."""
    out: list[TimedPath] = []
    boxes = control.get("boxes", {})
    for key, p in control["box_in"].items():  # into a box
        inst, pin = _box(key)
        btype = boxes.get(inst, "")
        if btype in PIPE_UNITS:
            out += _pipe_join(btype, pin, p, analyses, into=True)
            continue
        end = {"delay_ns": 0.0, "luts": 0, "carry8": 0, "muxf": 0, "dsp": 0, "start": "", "end": key}
        if btype == "pgs_ring_ram" and _distributed_ring(inst):
            if pin == "rd_addr":
                continue  # joined with the read below
            out.append(_join("control -> LUT RAM", p, {**end, "delay_ns": f.net(1) + f.srl_setup}))
        elif btype == "pgs_body_ram":
            mux = mux_tree(max(2, 2 * cfg.lanes)) if pin.startswith("wr") else mux_tree(4 * cfg.lanes)
            out.append(_join("control -> body RAM banks", p, {**end, "delay_ns": f.net(1) + f.bram_setup}, mux))
        else:
            out.append(_join("control -> block RAM", p, {**end, "delay_ns": f.net(1) + f.bram_setup}))
        notes.add("block RAM setup assumed")
    for key, p in control["box_out"].items():  # out of a box
        inst, pin = _box(key)
        btype = boxes.get(inst, "")
        if btype in PIPE_UNITS:
            out += _pipe_join(btype, pin, p, analyses, into=False)
            continue
        if btype == "pgs_body_ram" and pin in ("dyn", "bad"):
            out.append(_body_flags_read(cfg, control, p, f))
            continue
        if btype == "pgs_ring_ram" and _distributed_ring(inst):
            addr = control["box_in"].get(f"{inst}:rd_addr")
            depth = math.ceil(cfg.max_manifolds / cfg.lanes)
            if addr is not None:
                out.append(_join("control -> LUT RAM read -> control", addr, p, read_tree(depth, f)))
            continue
        start = {"delay_ns": f.bram_clock_to_out, "luts": 0, "carry8": 0, "muxf": 0, "dsp": 0, "start": key,
                 "cells": "RAMB"}
        if btype == "pgs_body_ram" and pin == "rd_data":
            out.append(_join("body RAM banks -> control", start, p, mux_tree(2 * cfg.body_banks)))
        elif btype in BLOCK_RAM_BOXES or btype == "pgs_ring_ram":
            out.append(_join("block RAM -> control", start, p))
        else:
            notes.add(f"{btype or inst} outputs: no timing of the box itself")
    return out


def _body_flags_read(cfg: rm.KernelConfig, control: dict[str, Any], flag_path: dict[str, Any],
                     f: delays.DelayFigures) -> TimedPath:
    """The body RAM's flag read at the offered record's bodies, then the control's path from the flag (see the module
    docstring)."""
    flags = read_tree(cfg.max_bodies, f)
    if cfg.window:  # the heads' block RAM, the bypass multiplexer of a head written in the cycle of its read
        start = {"delay_ns": f.bram_clock_to_out, "luts": 0, "carry8": 0, "muxf": 0, "dsp": 0,
                 "start": "the offered record's body indices (the ring heads' block RAM)", "cells": "RAMB"}
        both = _piece(f"the heads' bypass multiplexer, then the body flags' {flags.where}",
                      f.lut_level + flags.delay_ns, luts=1 + flags.luts)
        return _join("ring heads' block RAM -> LUT RAM read (body flags) -> control", start, flag_path, both)
    start = {"delay_ns": f.ff_clock_to_q, "luts": 0, "carry8": 0, "muxf": 0, "dsp": 0,
             "start": "the offered record's body indices (a register)", "cells": ""}
    return _join("register -> LUT RAM read (body flags) -> control", start, flag_path, flags)


def _pipe_join(btype: str, pin: str, control_path: dict[str, Any], analyses: dict[str, dict[str, Any]],
               into: bool) -> list[TimedPath]:
    """The control's path to (``into``) or from a pipe's port joined with the pipe's own path from or to it; none
    when the pipe has no analysis or the port no path."""
    unit = PIPE_UNITS[btype]
    pipe = analyses.get(unit)
    ports = pipe["inputs" if into else "outputs"] if pipe is not None else {}
    if pin not in ports:
        return []
    if into:
        return [_join(f"control -> {unit}", control_path, ports[pin])]
    return [_join(f"{unit} -> control", ports[pin], control_path)]


def _distributed_ring(inst: str) -> bool:
    """A pgs_ring_ram read asynchronously (SYNC_READ = 0): the rejected-slot flags of the on-chip impulses
    (rtl/pgs_seq_issue.sv g_rej_window)."""
    return "g_rej_window" in inst


def timing_or_reason(cfg: rm.KernelConfig, platform: platforms.Platform) -> Union[TimingVerdict, NoTiming]:
    try:
        return timing(cfg, platform)
    except (KeyError, FileNotFoundError, ValueError) as exc:
        return NoTiming(str(exc).strip("'\""))


def kernel_timing(job: KernelJob, dma: str, body_bits: int = rm.DEFAULT_BODY_BITS
                  ) -> Optional[Union[TimingVerdict, NoTiming]]:
    """The timing estimate of a run's configuration on its DMA preset's platform (None: no platform)."""
    if dma not in platforms.PLATFORMS:
        return None
    return timing_or_reason(rm.config_for_job(job, body_bits), platforms.get_platform(dma))


def histogram_text(hist: dict[int, int]) -> str:
    """Endpoints by logic levels, in bands of four, and the deepest."""
    total = sum(hist.values())
    if not total:
        return "no register-to-register paths"
    bands: dict[str, int] = {}
    for lv, n in sorted(hist.items()):
        lo = 4 * ((lv - 1) // 4) + 1 if lv else 0
        key = "0" if lv == 0 else f"{lo}-{lo + 3}"
        bands[key] = bands.get(key, 0) + n
    return ", ".join(f"{k}: {100 * n / total:.1f}%" for k, n in bands.items()) + f" (deepest {max(hist)}, " \
        f"{total:,} endpoints)"


def clock_note(v: Union[TimingVerdict, NoTiming, None], platform_hz: float) -> tuple[float, str]:
    """The clock a design's latency is quoted at, and why: the platform's where the estimate meets it, the estimate's
    highest clock where it does not, the platform's (marked) without an estimate."""
    if isinstance(v, TimingVerdict):
        if v.meets:
            return platform_hz, f"{platform_hz / 1e6:g} MHz (the timing estimate meets it)"
        return v.fmax_hz, f"{v.fmax_hz / 1e6:.0f} MHz (the timing estimate's highest; {platform_hz / 1e6:g} fails)"
    return platform_hz, f"{platform_hz / 1e6:g} MHz (the platform's clock; no timing estimate)"

