"""Resource model of a kernel configuration: LUT, FF, DSP48E2, BRAM36 and UltraRAM in seconds, without Yosys.

What a configuration (:class:`KernelConfig`: number format, lanes, window ring, body and record beat widths,
scene sizes that set the memory depths, and the redesign levers below) costs is summed from parts, each with
the source of its figure:

* **operators**: the floating-point operators of every datapath (``rtl/gen`` graphs: per lane the shared datapath of
  the contact and friction passes, ``rtl/gen/shared_datapath.py``, or with ``shared_datapath=False`` a contact and a
  friction pipe; one integrate pipe), each operator's figure synthesized once per format and latency with Yosys
  (``synth_xilinx -family xcup``, hierarchy kept) and committed in ``sim/fit/generated/resource_figures.json``
  (``make resources`` regenerates it). Where a published Vitis HLS / Floating-Point Operator figure exists
  (:data:`VENDOR_OPERATORS`) it is shown beside Yosys's, and ``operator_source="vendor"`` uses it;
* **multiplexers** of the shared datapath: an operand of a shared operator that the two kinds read from different
  words, and an output word the two kinds leave from different words, a W-bit 2:1 multiplexer on the record's kind:
  W LUTs each (computed: a LUT per bit, as Yosys maps a mux between two module boundaries; Vivado can pack two bits
  of one select into a LUT6_2); the kind's shift register, a flip-flop per stage;
* **delay lines** of the datapaths (``rtl/pgs_delay.sv``, from the generator's schedule): lines shorter than 4
  stages are registers; longer ones are circular buffers in distributed RAM (RAM32M16 / RAM64M8 in simple
  dual-port use: 8 LUTs hold 32 x 14 or 64 x 7 bit-reads, a tap is a read port), plus a register per tap; or,
  from ``delay_block_min_depth`` deep (the build's DELAY_BLOCK_MIN_DEPTH, ``models/kernel/delay_lines.py``), in block
  RAM: one simple dual-port array per tap, in its cheapest BRAM36 / BRAM18 aspect ratio;
* **memories**, mapped as a board build maps them: each array in the cheapest BRAM36 / BRAM18 aspect ratio,
  with the replicas or banks its ports need (true dual-port blocks give two ports), and in UltraRAM (4K x 72,
  two ports) on a platform that has it when the array is at least 4K deep;
* **control**: the register file, sequencer, record assemblers, hazard CAM and FIFOs as Yosys synthesized
  ``pgs_kernel`` with the pipes and RAMs as black boxes (the streaming one-lane kernel of the format); for more
  lanes the hazard CAM's share is scaled with its body ports (a scaled figure, marked so).

Levers a redesign can pull, each a parameter of :class:`KernelConfig`: ``impulses_resident`` (every manifold's
accumulated impulses on chip, or travelling with the records, held only in the ring), ``body_words`` (``"full"``:
the whole body-in record; ``"solve"``: only velocities and mass properties, positions and orientations streamed
through at integration), ``body_ports`` (``"lvt"``: every write port a bank replicated per read port;
``"banked"``: one copy of the velocities in ``body_banks`` true dual-port banks, a busy bank stalling the issue:
``rtl/pgs_body_vel_banks.sv``, 2 x lanes reads and writes a cycle, the lane plan keeping a record's reads within
the banks' ports),
``delay_block_min_depth`` (the delay lines from that depth in block RAM instead of LUT RAM), and
``record_bits`` (word width of the record fields stored in the ring: a storage format per field group), and
``adders`` (``"fabric"``: every ``fp_add`` in LUTs and carry chains; ``"dsp"``: in its DSP48E2 form, ``fp_add_dsp``,
the alignment and normalization shifts as multiplications by a power of two and the add in the DSP; the build's
ADD_SHIFT_DSP, ``make sim ADD_DSP=1``). The verdict of a run counts the form it built (:func:`kernel_fit`) and names
the form the fit picks (:func:`prefers_dsp`: the DSP form where its DSP share stays within the usable share and it
lowers the configuration's highest share-to-usable ratio of LUT, FF and DSP, LUT then being the tighter resource;
else the fabric form); the model-only studies (``make band``) take the fit's pick (:func:`with_chosen_adders`).

The estimate is a sum of parts: Yosys of the whole pipes (cached under ``build/resources``) is printed beside it
by ``make resources``, and ``docs/resources.md`` gives how far apart they lie. Timing closure and the final
utilisation need Vivado.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Optional, Union

from models.sizing import onchip_budget as ob
from models.kernel.body_banks import RECORDS_BANKS
from models.kernel.delay_lines import check_block_min_depth
from models.kernel.kernel_job import KernelJob
from models.sizing.mixed_layout import Converters
from models.formats.number_format import KERNEL_FORMATS, NumberFormat
from models.timing.kernel_shape import IMPULSE_FIFO_DEPTH
from models.kernel.stream_format import (CONTACT_WORDS, FRICTION_WORDS, BODY_IN_WORDS, IMPULSE_OUT_WORDS,
                                         KERNEL_INERTIA_WORDS, WINDOW_WORDS, body_in_word_count)
from rtl.gen.dataflow import BOOL, OP_SIGNATURES
from rtl.gen.kernel_graphs import GRAPHS, MODE_GRAPHS, SHARED_GRAPHS, shared_module
from rtl.gen.operator_timing import MINMAX_LATENCY, operator_latencies
from models.timing import platforms
from rtl.gen.operator_schedule import schedule

FIGURES_FILE = Path(__file__).parent / "generated" / "resource_figures.json"
DEFAULT_BODY_BITS = 128  # the body streams' beat of the default build (BODY_IN_W, BODY_OUT_W of rtl/pgs_kernel.sv)
REGENERATE = "make resources"  # the command that rewrites FIGURES_FILE
OPERATOR_MODULES = tuple(sorted({mod for _, _, mod in OP_SIGNATURES.values() if mod}))
# further forms of an operator, each synthesized and figured under its own name: name -> (RTL module, parameters)
OPERATOR_FORMS: dict[str, tuple[str, tuple[tuple[str, int], ...]]] = {
    "fp_add_dsp": ("fp_add", (("SHIFT_DSP", 1),)),  # the shifts as multiplications, the add in the DSP48E2
}
# the adder forms a configuration can choose (KernelConfig.adders): the figure each form's fp_add instances take
ADDER_FORMS = {"fabric": "fp_add", "dsp": "fp_add_dsp"}
KEYS = ("LUT", "FF", "DSP", "BRAM36", "URAM")


@dataclass
class Resources:
    lut: float = 0
    ff: float = 0
    dsp: float = 0
    bram36: float = 0
    uram: float = 0

    def __add__(self, other: "Resources") -> "Resources":
        return Resources(self.lut + other.lut, self.ff + other.ff, self.dsp + other.dsp, self.bram36 + other.bram36,
                         self.uram + other.uram)

    def scaled(self, k: float) -> "Resources":
        return Resources(self.lut * k, self.ff * k, self.dsp * k, self.bram36 * k, self.uram * k)

    def as_dict(self) -> dict[str, float]:
        return {"LUT": self.lut, "FF": self.ff, "DSP": self.dsp, "BRAM36": self.bram36, "URAM": self.uram}

    @staticmethod
    def from_dict(d: dict[str, Any]) -> "Resources":
        return Resources(d.get("LUT", 0), d.get("FF", 0), d.get("DSP", 0), d.get("BRAM36", 0), d.get("URAM", 0))


# --- published operator figures ---------------------------------------------------------------------------------
@dataclass(frozen=True)
class VendorFigure:
    label: str
    latency: int
    resources: Resources
    source: str


# Published Vitis HLS figures of the Floating-Point Operator cores Vitis binds on UltraScale+ parts (its synthesis
# estimates of the cores, not post-route figures; the research notes fit_accuracy_speed_facts.md section 1 and
# fit_audit_turn3.md section 2). The first figure of an operator is the one ``operator_source="vendor"`` takes (the
# form Vitis binds by default: full_dsp adders, max_dsp multipliers); ``make resources`` writes every figure into
# sim/fit/generated/resource_figures.json beside the operator's Yosys figure.
_FANNS = "Vitis HLS report, Alveo U280 (WenqiJiang/SIGMOD-2022-submission-Fanns)"
_FMUL = ("Vitis HLS reports, Alveo U280 and xcvu35p (ZTTTX/scalehls_vitis_test, gct02/AHLS): 78-123 LUT, 143-197 FF, "
         "3 DSP across them; the upper ends")
_UPCONV = "Vitis HLS report, xczu7ev-2 at 300 MHz (hijoouzc/UpConv_Block_HLS)"
VENDOR_OPERATORS: dict[tuple[str, str], tuple[VendorFigure, ...]] = {
    ("fp_add", "fp32"): (VendorFigure("fadd full_dsp", 3, Resources(lut=226, ff=177, dsp=2), _FANNS),
                         VendorFigure("fadd no_dsp", 5, Resources(lut=338, ff=243, dsp=0), _FANNS)),
    ("fp_mul", "fp32"): (VendorFigure("fmul max_dsp", 3, Resources(lut=123, ff=197, dsp=3), _FMUL),),
    ("fp_add", "fp16"): (VendorFigure("hadd full_dsp", 4, Resources(lut=113, ff=109, dsp=2), _UPCONV),),
    # the DSP48E2 form beside the vendor's full-DSP adders (the same cores as fp_add's first figure)
    ("fp_add_dsp", "fp32"): (VendorFigure("fadd full_dsp", 3, Resources(lut=226, ff=177, dsp=2), _FANNS),),
    ("fp_add_dsp", "fp16"): (VendorFigure("hadd full_dsp", 4, Resources(lut=113, ff=109, dsp=2), _UPCONV),),
    ("fp_mul", "fp16"): (VendorFigure("hmul max_dsp", 3, Resources(lut=34, ff=91, dsp=2), _UPCONV),),
}


def vendor_rows(module: str, fmt_name: str) -> list[dict[str, Any]]:
    """The published figures of one operator in one format, as ``make resources`` writes them beside Yosys's."""
    return [{"label": v.label, "latency": v.latency, "LUT": v.resources.lut, "FF": v.resources.ff,
             "DSP": v.resources.dsp, "source": v.source} for v in VENDOR_OPERATORS.get((module, fmt_name), ())]


# --- the generated figures --------------------------------------------------------------------------------------
@lru_cache(maxsize=None)
def _figures_text(path: Path) -> str:
    return path.read_text()


def figures(path: Path = FIGURES_FILE) -> dict[str, Any]:
    """The committed Yosys figures (operators and whole units per format)."""
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing: `{REGENERATE}` writes it")
    return json.loads(_figures_text(path))


@dataclass(frozen=True)
class OperatorFigure:
    module: str
    fmt: str
    latency: int
    resources: Resources
    source: str  # "Yosys" or the vendor figure's label and source


def operator_figure(module: str, fmt: NumberFormat, source: str = "yosys",
                    data: Optional[dict[str, Any]] = None) -> OperatorFigure:
    """One operator's figure in ``fmt``: Yosys's (committed), or with ``source="vendor"`` the published one where
    there is one (the first listed)."""
    if source == "vendor" and (module, fmt.name) in VENDOR_OPERATORS:
        v = VENDOR_OPERATORS[(module, fmt.name)][0]
        return OperatorFigure(module, fmt.name, v.latency, v.resources, f"{v.label} ({v.source})")
    if source not in ("yosys", "vendor"):
        raise ValueError(f"operator source {source!r}: expected yosys or vendor")
    ops = (data or figures())["operators"].get(fmt.name, {})
    if module not in ops:
        raise KeyError(f"no Yosys figure of {module} in {fmt.name} in {FIGURES_FILE}: `{REGENERATE} "
                       f"FORMATS={fmt.name}` adds it")
    row = ops[module]
    return OperatorFigure(module, fmt.name, row["latency"], Resources.from_dict(row), "Yosys")


def rtl_latency(module: str, fmt: NumberFormat) -> int:
    """The operator's latency in the RTL (``fp_minmax``: the generator's LATENCY parameter)."""
    if module == "fp_minmax":
        return MINMAX_LATENCY
    return operator_latencies()[module].eval(fmt.man_bits)


# --- datapaths: operator counts and delay lines from the generator's schedule -----------------------------------
@dataclass(frozen=True)
class DelayLine:
    width: int
    depth: int
    taps: tuple[int, ...]  # delay of each tap


@dataclass(frozen=True)
class PipeShape:
    name: str
    latency: int
    operators: dict[str, int]  # RTL module -> instances
    lines: tuple[DelayLine, ...]
    muxes: int = 0  # word-wide 2:1 multiplexers on the record's kind (a shared datapath's operands and outputs)
    kind_stages: int = 0  # the kind's shift register (a shared datapath: a flip-flop per stage)


TAG_BITS = 64  # the pass-through tag of every pipe (its TAG_W default)


@lru_cache(maxsize=None)
def pipe_shape(name: str, man_bits: int) -> PipeShape:
    """Operators and delay lines of one generated datapath at ``man_bits`` (the emitted RTL's structure); a shared
    datapath's also its multiplexers (:func:`shared_pipe_shape`)."""
    if name in SHARED_GRAPHS:
        return shared_pipe_shape(name, man_bits)
    graph = {**GRAPHS, **MODE_GRAPHS}[name]()
    sched = schedule(graph)
    ops: dict[str, int] = {}
    for v in sched.nodes:
        mod = OP_SIGNATURES.get(v.op, (None, None, None))[2]
        if mod and v.id in sched.issue:
            ops[mod] = ops.get(mod, 0) + 1
    lines = []
    for vid, line in sched.lines.items():
        v = graph.nodes[vid]
        ready = sched.ready[vid].eval(man_bits)
        taps = tuple(sorted({t.eval(man_bits) - ready for t in line.taps}))
        width = 1 if v.type == BOOL else 0  # 0: a format word (filled in by the format's width)
        if max(taps) > 0:
            lines.append(DelayLine(width, max(taps), taps))
    latency = sched.latency_for(man_bits)
    lines.append(DelayLine(TAG_BITS, latency, (latency,)))  # the tag line (the valid pipe counts with it)
    return PipeShape(name, latency, ops, tuple(lines))


def shared_pipe_shape(name: str, man_bits: int) -> PipeShape:
    """The shared datapath ``name`` (``rtl/gen/shared_datapath.py``) as the emitted module has it: its operator
    instances (a shared operator once), a delay line per source with its distinct taps, the tag line, the operand and
    output multiplexers and the kind's shift register."""
    dp = SHARED_GRAPHS[name]()
    stats = dp.stats(man_bits)
    ops = {mod: stats[mod] for mod in OPERATOR_MODULES if stats.get(mod)}
    lines = []
    for src in dp.sources:
        ready = src.ready.eval(man_bits)
        taps = tuple(sorted({t.eval(man_bits) - ready for t in src.taps}))
        if max(taps) > 0:
            lines.append(DelayLine(1 if src.type == BOOL else 0, max(taps), taps))
    latency = dp.latency_for(man_bits)
    lines.append(DelayLine(TAG_BITS, latency, (latency,)))
    return PipeShape(name, latency, ops, tuple(lines), muxes=stats["operand_muxes"] + stats["output_muxes"],
                     kind_stages=latency)


SHIFT_MAX_DEPTH = 3  # pgs_delay: lines shorter than RAM_MIN_DEPTH = 4 are shift registers


def delay_line_resources(line: DelayLine, word_bits: int, block_min_depth: int = 0) -> Resources:
    """A tapped delay line as a board build maps ``rtl/pgs_delay.sv``: registers, distributed RAM, or (a RAM line
    at least ``block_min_depth`` deep, when that is > 0: the pipes' DELAY_BLOCK_MIN_DEPTH) block RAM, one simple
    dual-port array per tap of delay >= 2 whose output latch is the tap's register."""
    width = line.width or word_bits
    if line.depth <= SHIFT_MAX_DEPTH:
        return Resources(ff=width * line.depth)
    ram_taps = [t for t in line.taps if t >= 2]
    reg_taps = [t for t in line.taps if t == 1]
    pointer = math.ceil(math.log2(line.depth))
    if 0 < block_min_depth <= line.depth:
        return Resources(lut=pointer, ff=width * len(reg_taps) + pointer,
                         bram36=len(ram_taps) * bram36_for(line.depth, width))
    luts = distributed_ram_luts(line.depth, width * len(ram_taps))
    return Resources(lut=luts + pointer, ff=width * (len(ram_taps) + len(reg_taps)) + pointer)


def distributed_ram_luts(depth: int, bit_reads: int, narrow: bool = False) -> int:
    """LUTs of a LUT RAM ``depth`` words deep read ``bit_reads`` bits at a time (width x read ports), simple
    dual-port: RAM32M16 / RAM64M8 (8 LUTs hold 32 x 14 or 64 x 7 bit-reads), a depth multiplexer for each further
    64 words (a LUT6 selects among 3 blocks, F7/F8 muxes beside it). ``narrow``: RAM64X1D too where it is cheaper
    (2 LUTs a 64 x 1 bit-read: a memory of a few bits per word; the delay lines' rule keeps RAM64M8)."""
    if depth <= 32:
        return min(8 * math.ceil(bit_reads / 14), 2 * bit_reads if narrow else math.inf)
    blocks = math.ceil(depth / 64)
    per_block = min(8 * math.ceil(bit_reads / 7), 2 * bit_reads if narrow else math.inf)
    return int(per_block * blocks + bit_reads * math.ceil((blocks - 1) / 3))


# --- memories ---------------------------------------------------------------------------------------------------
# (depth, width) aspect ratios: simple dual-port (one read, one write port) and true dual-port (two ports)
_SDP36 = [(512, 72), (1024, 36), (2048, 18), (4096, 9), (8192, 4), (16384, 2), (32768, 1)]
_SDP18 = [(512, 36), (1024, 18), (2048, 9), (4096, 4), (8192, 2), (16384, 1)]
_TDP36 = _SDP36[1:]
_TDP18 = _SDP18[1:]
URAM_DEPTH, URAM_WIDTH = 4096, 72
URAM_MIN_DEPTH = 4096  # arrays at least this deep go to UltraRAM where the platform has it


def bram36_for(depth: int, width: int, true_dual_port: bool = False) -> float:
    """Block RAMs (in RAMB36E2 units, a RAMB18E2 = 0.5) of one depth x width array."""
    if depth <= 0 or width <= 0:
        return 0.0
    s36, s18 = (_TDP36, _TDP18) if true_dual_port else (_SDP36, _SDP18)
    full = min(math.ceil(depth / d) * math.ceil(width / w) for d, w in s36)
    half = min(math.ceil(depth / d) * math.ceil(width / w) for d, w in s18) * 0.5
    return min(float(full), half)


def uram_for(depth: int, width: int) -> int:
    return 0 if depth <= 0 or width <= 0 else math.ceil(depth / URAM_DEPTH) * math.ceil(width / URAM_WIDTH)


@dataclass(frozen=True)
class MemoryArray:
    name: str
    depth: int
    width: int  # bits
    copies: int  # replicas / banks for the ports
    true_dual_port: bool = False  # each copy serves two ports
    distributed: bool = False  # read in the cycle it is addressed: LUT RAM (the on-chip impulses' rejected-slot flags)

    def resources(self, uram: bool = False) -> Resources:
        """One copy per port pair: in LUT RAM (``distributed``), UltraRAM (``uram``, deep arrays) or block RAM."""
        if self.distributed:
            return Resources(lut=self.copies * distributed_ram_luts(self.depth, self.width, narrow=True))
        if uram and self.depth >= URAM_MIN_DEPTH:
            return Resources(uram=self.copies * uram_for(self.depth, self.width))
        return Resources(bram36=self.copies * bram36_for(self.depth, self.width, self.true_dual_port))


# the constant words of a body beside its inverse-inertia words (IINV_W): pos, q, 1/m | 1/m (the poses off chip)
BODY_CONST_WORDS = {"full": BODY_IN_WORDS - 6 - KERNEL_INERTIA_WORDS, "solve": 1}
BODY_VEL_WORDS = 6
IMPULSE_WORDS = ob.IMPULSE_WORDS


# --- a configuration --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class KernelConfig:
    """A kernel build and the scene sizes that set its memory depths."""

    fmt: NumberFormat
    max_bodies: int
    max_manifolds: int
    lanes: int = 1
    window: int = 0  # records in the ring (0: the streaming kernel)
    impulses_resident: bool = True
    body_words: str = "full"  # "full" | "solve"
    body_ports: str = "lvt"  # "lvt" | "banked"
    body_banks: int = RECORDS_BANKS  # banked, one lane: the banks of rtl/pgs_body_vel_banks.sv (BODY_BANKS)
    record_bits: Optional[int] = None  # ring word width (None: the format's)
    operator_source: str = "yosys"  # "yosys" | "vendor"
    tangents_on_chip: bool = False  # the friction pipe derives t0, t1 from n (pgs_friction_pipe_tb)
    converters: tuple[Converters, ...] = ()  # mixed storage: format converters at unpack and pack (mixed_layout)
    soft_contact: bool = False  # the soft contact pipe (pgs_contact_pipe_soft, SOFT_CONTACT: lam * keep per point)
    delay_block_min_depth: int = 0  # the pipes' delay lines at least this deep in block RAM (DELAY_BLOCK_MIN_DEPTH)
    body_bits: int = DEFAULT_BODY_BITS  # the body streams' beat (BODY_IN_W = BODY_OUT_W): the control's figure
    shared_datapath: bool = True  # SHARED_DATAPATH: one datapath per lane for both passes, else two pipes per lane
    adders: str = "fabric"  # "fabric" | "dsp": the figure of every fp_add instance (ADDER_FORMS)
    inertia_words: int = KERNEL_INERTIA_WORDS  # IINV_W: inverse-inertia words per body (1, 3 or 6)

    def __post_init__(self) -> None:
        body_in_word_count(self.inertia_words)  # 1, 3 or 6, else a ValueError
        if self.adders not in ADDER_FORMS:
            raise ValueError(f"adders {self.adders!r}: expected {' | '.join(ADDER_FORMS)}")
        if self.lanes < 1 or self.lanes & (self.lanes - 1):
            raise ValueError(f"lanes must be a power of two, not {self.lanes}")
        if self.lanes > 1 and self.window == 0:
            raise ValueError("lanes > 1 needs the window kernel (window > 0)")
        if self.body_words not in BODY_CONST_WORDS or self.body_ports not in ("lvt", "banked"):
            raise ValueError(f"body_words {self.body_words!r} / body_ports {self.body_ports!r}: expected "
                             f"{'|'.join(BODY_CONST_WORDS)} / lvt|banked")
        if self.body_banks < 1 or self.body_banks & (self.body_banks - 1):
            raise ValueError(f"body_banks must be a power of two, got {self.body_banks}")
        if min(self.max_bodies, self.max_manifolds, self.window) < 0:
            raise ValueError("memory depths must not be negative")
        check_block_min_depth(self.delay_block_min_depth)

    def describe(self) -> str:
        kind = f"window kernel, ring {self.window:,}, {self.lanes} lane(s)" if self.window else "streaming kernel"
        levers = [f"impulses {'resident' if self.impulses_resident else 'with the records'}",
                  f"body words {self.body_words}", f"body ports {self.body_ports}"
                  + (f" ({self.body_banks} true dual-port banks)" if self.body_ports == "banked" and self.lanes == 1
                     else "")]
        levers.append("one datapath per lane" if self.shared_datapath else "a contact and a friction pipe per lane")
        levers.append("DSP48E2 adders (fp_add_dsp)" if self.adders == "dsp" else "fabric adders (fp_add)")
        if self.tangents_on_chip:
            levers.append("tangent basis derived on chip")
        if self.soft_contact:
            levers.append("soft contact pipe")
        if self.body_bits != DEFAULT_BODY_BITS:
            levers.append(f"{self.body_bits}-bit body streams")
        if self.inertia_words != KERNEL_INERTIA_WORDS:
            levers.append(f"{self.inertia_words}-word inverse inertia")
        if self.delay_block_min_depth:
            levers.append(f"delay lines from {self.delay_block_min_depth} deep in block RAM")
        if self.record_bits:
            levers.append(f"ring words {self.record_bits} bits")
        if self.converters:
            levers.append(f"mixed storage, {sum(c.count for c in self.converters)} format converters")
        return (f"{self.fmt.name}, {kind}, {self.max_bodies:,} bodies, {self.max_manifolds:,} manifold slots; "
                + ", ".join(levers))


def body_const_words(cfg: KernelConfig) -> int:
    """The words per body that stay constant through a step on chip: its ``body_words`` and inverse inertia."""
    return BODY_CONST_WORDS[cfg.body_words] + cfg.inertia_words


def memories(cfg: KernelConfig) -> list[MemoryArray]:
    """The configuration's on-chip arrays with the copies their ports need."""
    w, ports, nb = cfg.fmt.width, 2 * cfg.lanes, cfg.max_bodies
    const_words = body_const_words(cfg)
    const_w = const_words * w
    out = [MemoryArray(f"body constant words ({const_words}), {ports} read ports: "
                       f"{math.ceil(ports / 2)} true dual-port copies", nb, const_w, math.ceil(ports / 2), True)]
    if cfg.body_ports == "lvt":
        out.append(MemoryArray(f"body velocities (v, w), {ports}W{ports}R: {ports * ports} banks (live-value table)",
                               nb, BODY_VEL_WORDS * w, ports * ports))
    else:  # the built banks: one copy, body k in bank k mod banks, two ports each (a record's lanes fit them)
        out.append(MemoryArray(f"body velocities (v, w): one copy in {cfg.body_banks} true dual-port banks "
                               "(BODY_BANKS)", math.ceil(nb / cfg.body_banks), BODY_VEL_WORDS * w, cfg.body_banks,
                               True))
    if cfg.impulses_resident:
        depth = math.ceil(cfg.max_manifolds / cfg.lanes)
        out += [MemoryArray(f"normal impulses lam[4] per slot, {cfg.lanes} bank(s)", depth, 4 * w, cfg.lanes),
                MemoryArray(f"friction impulses lamT[2] per slot, {cfg.lanes} bank(s)", depth, 2 * w, cfg.lanes)]
    if not cfg.impulses_resident:  # the impulse-out stream (pgs_sequencer: a record per slot / per window record)
        out.append(MemoryArray(f"impulse-out FIFO ({cfg.lanes} x {IMPULSE_OUT_WORDS} words per record, "
                               f"{IMPULSE_FIFO_DEPTH} deep)", IMPULSE_FIFO_DEPTH, cfg.lanes * IMPULSE_OUT_WORDS * w, 1))
    if cfg.window:
        out += window_memories(cfg)
    return out


WINDOW_HEAD_FLAGS = 6  # a lane's head beside its two body indices: 5 flags (pgs_sequencer head_of), the truncated bit


def window_memories(cfg: KernelConfig) -> list[MemoryArray]:
    """The window kernel's rings (``rtl/pgs_window.sv``, ``rtl/pgs_ring_ram.sv``): the records' words in block RAM
    (read the cycle after the take; a fetch of the impulses-in-records design streams its one kind's records:
    the contact record with lam[4] is the longer), their heads in block RAM (read the cycle before the record is
    offered: two body indices and the flags per lane), and with the impulses in the records the impulse ring (4 words
    per lane, written at retire, read at issue)."""
    rec = cfg.record_bits or cfg.fmt.width
    words = WINDOW_WORDS if cfg.impulses_resident else max(CONTACT_WORDS + 4, FRICTION_WORDS + IMPULSE_WORDS)
    idx = max(1, math.ceil(math.log2(max(cfg.max_bodies, 2))))
    out = [MemoryArray(f"record ring ({words} words of {rec} bits per lane)", cfg.window, cfg.lanes * words * rec, 1),
           MemoryArray(f"record ring heads (2 x {idx}-bit body indices and {WINDOW_HEAD_FLAGS} flag bits per lane, "
                       "block RAM)", cfg.window, cfg.lanes * (2 * idx + WINDOW_HEAD_FLAGS), 1)]
    if not cfg.impulses_resident:
        out.append(MemoryArray(f"impulse ring ({IMPULSE_OUT_WORDS} words per lane)", cfg.window,
                               IMPULSE_OUT_WORDS * rec, cfg.lanes))
    # the rejected-slot flags (pgs_sequencer): with the impulses in the records read as each record is written into
    # the ring (block RAM), else at the offered pass's slot in the cycle it is offered (LUT RAM)
    slots = math.ceil(cfg.max_manifolds / cfg.lanes)
    out.append(MemoryArray("rejected-slot flags (a bit per slot, block RAM)", slots, 1, cfg.lanes)
               if not cfg.impulses_resident else
               MemoryArray("rejected-slot flags (a bit per slot, LUT RAM)", slots, 1, cfg.lanes, distributed=True))
    return out


@dataclass(frozen=True)
class Part:
    name: str
    resources: Resources
    source: str
    lutram: float = 0.0  # of resources.lut, the LUTs used as distributed RAM (delay lines, LUT-RAM arrays)


@dataclass(frozen=True)
class Estimate:
    config: KernelConfig
    parts: tuple[Part, ...]

    @property
    def total(self) -> Resources:
        t = Resources()
        for p in self.parts:
            t = t + p.resources
        return t


def operator_figure_name(mod: str, cfg: KernelConfig) -> str:
    """The figure an instance of operator ``mod`` takes in the configuration: its own, except fp_add's, which is its
    adder form's (fp_add in the fabric, fp_add_dsp)."""
    return ADDER_FORMS[cfg.adders] if mod == "fp_add" else mod


def pipe_resources(name: str, cfg: KernelConfig, data: dict[str, Any]) -> tuple[Resources, list[str]]:
    """Operators plus delay lines of one pipe, and the source of each operator's figure."""
    shape = pipe_shape(name, cfg.fmt.man_bits)
    total, sources = Resources(), []
    for mod, n in sorted(shape.operators.items()):
        fig_name = operator_figure_name(mod, cfg)
        fig = operator_figure(fig_name, cfg.fmt, cfg.operator_source, data)
        total = total + fig.resources.scaled(n)
        sources.append(f"{n} {fig_name} ({fig.source})")
    for line in shape.lines:
        total = total + delay_line_resources(line, cfg.fmt.width, cfg.delay_block_min_depth)
    if shape.muxes or shape.kind_stages:
        total = total + Resources(lut=shape.muxes * cfg.fmt.width, ff=shape.kind_stages)
        sources.append(f"{shape.muxes} {cfg.fmt.width}-bit kind multiplexers (a LUT per bit, computed)")
    return total, sources


def pipe_lutram(name: str, cfg: KernelConfig) -> float:
    """The LUTs of one pipe's delay lines that are distributed RAM (with their pointers: the rule's LUTs)."""
    shape = pipe_shape(name, cfg.fmt.man_bits)
    return sum(delay_line_resources(line, cfg.fmt.width, cfg.delay_block_min_depth).lut for line in shape.lines)


CAM_UNIT = "hazard_cam"  # the figure of pgs_hazard_cam alone (2 body ports), to scale with lanes
WINDOW_CONTROL_UNIT = "control_window"  # the window kernel's control (impulses in the records, one lane, banked)


def control_unit(body_bits: int) -> str:
    """The name of Yosys's control unit with body streams of ``body_bits`` (sim/fit/yosys_figures.py UNITS)."""
    return "control" if body_bits == DEFAULT_BODY_BITS else f"control_b{body_bits}"


def _control_figure(fmt: NumberFormat, data: dict[str, Any], body_bits: int = DEFAULT_BODY_BITS,
                    window: bool = False) -> tuple[Resources, str]:
    """Yosys's control of ``fmt`` with body streams of ``body_bits``, else of a kernel format with the same word
    width (the control moves words and does no arithmetic on them); where no run has that body width, the 128-bit
    streams' control, marked so (the body assemblers' registers and multiplexers differ). ``window``: the window
    kernel's control (:data:`WINDOW_CONTROL_UNIT`, 128-bit body streams) where a run has it, else the streaming
    kernel's, marked so (without the record window and its pass contexts)."""
    units = data["units"]
    choices = [(control_unit(body_bits), ""),
               ("control", f" with {DEFAULT_BODY_BITS}-bit body streams (none of {body_bits} bits)")]
    if window:
        note = f" with {DEFAULT_BODY_BITS}-bit body streams" if body_bits != DEFAULT_BODY_BITS else ""
        choices = ([(WINDOW_CONTROL_UNIT, f" of the window kernel's control{note}")]
                   + [(u, n + "; the streaming kernel's control: no figure of the window's") for u, n in choices])
    for unit, note in choices:
        if unit in units.get(fmt.name, {}):
            return Resources.from_dict(units[fmt.name][unit]), "Yosys" + note
        for other in KERNEL_FORMATS.values():
            if other.width == fmt.width and unit in units.get(other.name, {}):
                return (Resources.from_dict(units[other.name][unit]),
                        f"Yosys of the {other.name} control (same width){note}")
    raise KeyError(f"no Yosys figure of the control in {fmt.name} in {FIGURES_FILE}: `{REGENERATE}`")


def control_resources(cfg: KernelConfig, data: dict[str, Any]) -> Part:
    ctrl, source = _control_figure(cfg.fmt, data, cfg.body_bits, cfg.window > 0)
    if cfg.lanes == 1:
        return Part("control (register file, sequencer, assemblers, hazard CAM, FIFOs)", ctrl, source)
    # the CAM has no format parameter: its figure from whichever format's run has it
    cam_row = next((u[CAM_UNIT] for u in data["units"].values() if CAM_UNIT in u), None)
    if cam_row is None:
        raise KeyError(f"no Yosys figure of {CAM_UNIT} in {FIGURES_FILE}: `{REGENERATE}` adds it")
    cam = Resources.from_dict(cam_row)
    return Part(f"control, hazard CAM scaled to {2 * cfg.lanes} body ports", ctrl + cam.scaled(cfg.lanes - 1),
                f"{source} (one lane) + Yosys of the CAM per extra lane")


def bank_mux_resources(banks: int, width: int, bodies: int, ports: int = 2) -> Resources:
    """The multiplexers of ``rtl/pgs_body_vel_banks.sv`` beside the control's Yosys figure (which has the body RAM
    as a black box), ``ports`` reads and ``ports`` writes a cycle (2 x lanes): per bank port, the write data from the
    writes (two: a LUT6 holds two 2:1 bits; more: a LUT6 per 4:1 bit of the tree) and the row from the 2 x
    ``ports`` accesses (a LUT6 per 4:1 bit); per read, its word from the 2 x ``banks`` port outputs and the
    registered bank and port; the port selection a few LUTs per bank."""
    row = max(1, math.ceil(math.log2(max(2, math.ceil(bodies / banks)))))
    data = math.ceil(width / 2) if ports == 2 else width * math.ceil((ports - 1) / 3)
    per_port = data + row * math.ceil((2 * ports - 1) / 3)
    read = ports * width * math.ceil((2 * banks - 1) / 3)
    sel = 2 * (math.ceil(math.log2(banks)) + 1) if banks > 1 else 2
    return Resources(lut=2 * banks * per_port + read + 8 * banks, ff=sel)


def converter_resources(conv: Converters, compute: NumberFormat) -> Resources:
    """One converter's LUT6 and FF rule (computed, not synthesized; subnormals flush to zero, as every operator
    reads them), times ``conv.count``, each with a register of its output word:

    * unpack (stored eSmT -> kernel eEmM): the exponent re-biased by a constant where eS < eE (an eE-bit carry
      chain, one LUT per bit) with the zero and all-ones codes kept (their detection, a LUT per 6 bits each),
      the mantissa zero-padded (wires; with the kernel's exponent nothing else, and no register);
    * pack (kernel -> stored, round to nearest even): the sticky OR of the dropped mantissa bits (a LUT per 6),
      the round decision (1), an incrementer over the stored exponent and mantissa (a LUT per bit), and where
      eS < eE the range check (a LUT per 6 exponent bits, twice) and the clamp to zero or infinity (a LUT per
      stored bit)."""
    s_fmt = conv.stored
    narrower_exp = s_fmt.exp_bits < compute.exp_bits
    if conv.direction == "unpack":  # with the kernel's exponent: the mantissa zero-padded, wires only
        lut = (compute.exp_bits + 2 * math.ceil(s_fmt.exp_bits / 6)) if narrower_exp else 0
        ff = compute.width if narrower_exp else 0
    elif conv.direction == "pack":
        dropped = compute.man_bits - s_fmt.man_bits
        lut = math.ceil(max(dropped - 1, 0) / 6) + 1 + s_fmt.exp_bits + s_fmt.man_bits
        if narrower_exp:
            lut += 2 * math.ceil(compute.exp_bits / 6) + s_fmt.width
        ff = s_fmt.width
    else:
        raise ValueError(f"converter direction must be unpack or pack, got {conv.direction!r}")
    return Resources(lut=lut * conv.count, ff=ff * conv.count)


def lane_pipes(cfg: KernelConfig) -> list[tuple[str, int]]:
    """The datapath modules of the configuration's lanes and how many of each: the shared datapath of its options per
    lane, or a contact and a friction pipe per lane."""
    if cfg.shared_datapath:
        return [(shared_module(cfg.inertia_words, soft=cfg.soft_contact, tangents_on_chip=cfg.tangents_on_chip),
                 cfg.lanes)]
    friction = "pgs_friction_pipe_tb" if cfg.tangents_on_chip else "pgs_friction_pipe"
    contact = "pgs_contact_pipe_soft" if cfg.soft_contact else "pgs_contact_pipe"
    return [(contact, cfg.lanes), (friction, cfg.lanes)]


def estimate(cfg: KernelConfig, platform: Optional[platforms.Platform] = None,
             data: Optional[dict[str, Any]] = None) -> Estimate:
    """The configuration's resources, part by part (memories mapped for ``platform``: UltraRAM where it has)."""
    data = data or figures()
    parts = []
    for name, per in lane_pipes(cfg) + [("pgs_integrate_pipe", 1)]:
        res, src = pipe_resources(name, cfg, data)
        parts.append(Part(f"{name} x {per}", res.scaled(per), "operators: " + ", ".join(src)
                          + "; delay lines: distributed RAM rule", lutram=per * pipe_lutram(name, cfg)))
    parts.append(control_resources(cfg, data))
    if cfg.body_ports == "banked":
        parts.append(Part(f"body bank port multiplexers ({cfg.body_banks} banks, {2 * cfg.lanes} reads and writes)",
                          bank_mux_resources(cfg.body_banks, BODY_VEL_WORDS * cfg.fmt.width, cfg.max_bodies,
                                             2 * cfg.lanes), "computed (LUT6 mux rule)"))
    if cfg.converters:
        conv = Resources()
        for c in cfg.converters:
            conv = conv + converter_resources(c, cfg.fmt)
        parts.append(Part(f"storage format converters ({sum(c.count for c in cfg.converters)} words)", conv,
                          "computed (converter rule, not synthesized)"))
    uram = platform is not None and platform.uram > 0
    for m in memories(cfg):
        res = m.resources(uram)
        parts.append(Part(m.name, res, f"{m.depth:,} x {m.width} bits, computed", lutram=res.lut))
    return Estimate(cfg, tuple(parts))


# --- the verdict ------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class FitVerdict:
    platform: platforms.Platform
    total: Resources
    shares: dict[str, float]  # of the device, by KEYS
    limits: dict[str, float]
    config: str
    operator_sources: str = ""  # where each operator's figure came from
    adders: str = "fabric"  # the adder form the estimate counted (KernelConfig.adders)
    # the same configuration with the other adder form (None: not asked, or that form cannot be built for the run)
    other_adders: Optional["FitVerdict"] = None

    @property
    def overflows(self) -> list[str]:
        """Resources above their usable share, worst first."""
        over = [k for k in KEYS if self.shares[k] > self.limits[k]]
        return sorted(over, key=lambda k: self.shares[k] / self.limits[k] if self.limits[k] else math.inf,
                      reverse=True)

    @property
    def fits(self) -> bool:
        return not self.overflows

    def headline(self) -> str:
        if self.fits:
            return f"FITS the {self.platform.name}"
        k = self.overflows[0]
        return f"DOES NOT FIT the {self.platform.name}: {k} {_share(self.shares[k])} (usable {_share(self.limits[k])})"

    def shares_text(self) -> str:
        return ", ".join(f"{k} {_share(self.shares[k])}" for k in KEYS if self.platform.capacity(k) or self.shares[k])


def _share(x: float) -> str:
    return "inf" if math.isinf(x) else f"{100 * x:.1f}%"


def verdict(est: Estimate, platform: platforms.Platform) -> FitVerdict:
    total = est.total.as_dict()
    shares = {k: (total[k] / platform.capacity(k) if platform.capacity(k) else (math.inf if total[k] else 0.0))
              for k in KEYS}
    return FitVerdict(platform, est.total, shares, dict(platforms.USABLE_SHARE), est.config.describe(),
                      operator_sources(est.config), est.config.adders)


def operator_sources(cfg: KernelConfig) -> str:
    """Which figure each operator's count was multiplied by: Yosys's, or a published one."""
    by: dict[str, list[str]] = {}
    for mod in (operator_figure_name(m, cfg) for m in OPERATOR_MODULES):
        vendor = cfg.operator_source == "vendor" and (mod, cfg.fmt.name) in VENDOR_OPERATORS
        label = VENDOR_OPERATORS[(mod, cfg.fmt.name)][0].label if vendor else "Yosys"
        by.setdefault(label, []).append(mod)
    return "; ".join(f"{label}: {', '.join(mods)}" for label, mods in by.items())


def fit(cfg: KernelConfig, platform: platforms.Platform) -> FitVerdict:
    return verdict(estimate(cfg, platform), platform)


def _pressure(v: FitVerdict) -> float:
    """The highest share-to-usable ratio of LUT, FF and DSP (the resources the adder form trades)."""
    return max(v.shares[k] / v.limits[k] for k in ("LUT", "FF", "DSP"))


def prefers_dsp(fabric: FitVerdict, dsp: FitVerdict) -> bool:
    """Whether the fit picks the DSP adders over the fabric ones for one configuration: where the DSP form's DSP
    share stays within the usable share and it lowers the highest share-to-usable ratio of LUT, FF and DSP (so LUT,
    or FF, was the tighter resource)."""
    return dsp.shares["DSP"] <= dsp.limits["DSP"] and _pressure(dsp) < _pressure(fabric)


def with_chosen_adders(cfg: KernelConfig, platform: platforms.Platform) -> KernelConfig:
    """``cfg`` with the adder form the fit picks (:func:`picked_adders`)."""
    return dataclasses.replace(cfg, adders=picked_adders(with_other_adders(cfg, platform)))


def with_other_adders(cfg: KernelConfig, platform: platforms.Platform) -> FitVerdict:
    """The verdict of ``cfg`` as built (its own adder form), beside it that of the other form."""
    other = "fabric" if cfg.adders == "dsp" else "dsp"
    return dataclasses.replace(fit(cfg, platform), other_adders=fit(dataclasses.replace(cfg, adders=other), platform))


def picked_adders(v: FitVerdict) -> str:
    """The adder form the fit picks for ``v``'s configuration (``v.adders`` when the other form was not figured)."""
    if v.other_adders is None:
        return v.adders
    fabric, dsp = (v, v.other_adders) if v.adders == "fabric" else (v.other_adders, v)
    return "dsp" if prefers_dsp(fabric, dsp) else "fabric"


def adders_text(v: FitVerdict) -> str:
    """The adder form built and the one the fit picks, with the shares that decide (the built form's tighter
    resource among LUT, FF, DSP, and DSP) and the option that builds the pick."""
    built = f"{ADDER_FORMS[v.adders]} ({v.adders}) built"
    o = v.other_adders
    if o is None:
        return built + " (the other form not figured: it is not built for this datapath)"
    tight = max(("LUT", "FF", "DSP"), key=lambda k: v.shares[k] / v.limits[k])
    keys = [tight] + (["DSP"] if tight != "DSP" else [])
    pick = picked_adders(v)
    if pick == v.adders:
        cmp = ", ".join(f"{k} {_share(v.shares[k])} against {_share(o.shares[k])}" for k in keys)
        return f"{built}, the fit's pick too: {cmp} with {ADDER_FORMS[o.adders]}"
    cmp = ", ".join(f"{k} {_share(o.shares[k])} against {_share(v.shares[k])}" for k in keys)
    return (f"{built}; the fit picks {ADDER_FORMS[pick]} ({pick}): {cmp} built; command: the same run with "
            f"ADD_DSP={int(pick == 'dsp')} (--add-dsp {int(pick == 'dsp')})")


@dataclass(frozen=True)
class NoEstimate:
    """No fit verdict for a run: no platform behind its DMA preset, or no figures for its format."""

    reason: str


def config_for_job(job: KernelJob, body_bits: int = DEFAULT_BODY_BITS) -> KernelConfig:
    """The configuration a run built: its format, lanes and ring, memories as deep as its scene needs, body streams
    of ``body_bits``, its adders' form (``KernelJob.add_dsp``)."""
    plan = job.record_window
    return KernelConfig(job.fmt, job.bodies.num_bodies, len(job.slots), lanes=plan.lanes if plan else 1,
                        window=plan.depth if plan else 0, impulses_resident=not job.impulses_in_records,
                        body_ports="banked" if job.body_banks else "lvt", body_banks=job.body_banks or RECORDS_BANKS,
                        tangents_on_chip=job.tangents_on_chip, soft_contact=job.params.soft_keep is not None,
                        delay_block_min_depth=job.delay_block_min_depth, body_bits=body_bits,
                        shared_datapath=job.shared_datapath, adders="dsp" if job.add_dsp else "fabric",
                        inertia_words=job.inertia_words)


def window_config(fmt: NumberFormat, bodies: int, manifolds: int, ring_records: int, lanes: int = 1,
                  impulses_resident: bool = True) -> KernelConfig:
    """The window kernel whose ring holds ``ring_records`` records (rounded up to the power of two pgs_window
    needs)."""
    return KernelConfig(fmt, bodies, manifolds, lanes=lanes, window=1 << max(ring_records - 1, 1).bit_length(),
                        impulses_resident=impulses_resident)


def fit_or_reason(cfg: KernelConfig, platform: platforms.Platform,
                  advise_adders: bool = False) -> Union[FitVerdict, NoEstimate]:
    """The verdict of ``cfg`` (its own adder form; with ``advise_adders`` the other form's beside it), or why there is
    none."""
    try:
        return with_other_adders(cfg, platform) if advise_adders else fit(cfg, platform)
    except (KeyError, FileNotFoundError) as exc:
        return NoEstimate(str(exc).strip("'\""))


def short_verdict(v: Union[FitVerdict, NoEstimate]) -> str:
    """One table cell: FITS, or DOES NOT FIT with the worst overflowing resource's share."""
    if isinstance(v, NoEstimate):
        return "no estimate"
    return "FITS" if v.fits else f"DOES NOT FIT ({v.overflows[0]} {_share(v.shares[v.overflows[0]])})"


def kernel_fit(job: KernelJob, dma: str, body_bits: int = DEFAULT_BODY_BITS,
               advise_adders: bool = True) -> Union[FitVerdict, NoEstimate]:
    """The fit verdict of a run's configuration as built (body streams of ``body_bits``, its adder form) on its DMA
    preset's platform; with ``advise_adders`` the other adder form's beside it (:func:`adders_text`; off where that
    form cannot be built, the XLS datapath's)."""
    if dma not in platforms.PLATFORMS:
        return NoEstimate(f"no platform behind the DMA preset {dma!r} (platforms: {', '.join(platforms.PLATFORMS)})")
    return fit_or_reason(config_for_job(job, body_bits), platforms.get_platform(dma), advise_adders)


def fit_rows(v: Union[FitVerdict, NoEstimate]) -> dict[str, str]:
    """What ``make sim`` / ``sweep`` / ``band`` print for one configuration."""
    if isinstance(v, NoEstimate):
        return {"verdict": f"no estimate ({v.reason})"}
    return {"configuration": v.config, "platform": f"{v.platform.name} ({v.platform.describe()})",
            "LUT, FF, DSP, BRAM36, URAM (share of the device)": v.shares_text(),
            f"verdict (usable: {platforms.describe_usable()})": v.headline(),
            "operator figures": v.operator_sources,
            "adders (the fit picks the DSP form where its DSP share stays within the usable share and it lowers the "
            "highest share-to-usable ratio of LUT, FF and DSP)": adders_text(v),
            "estimate": "sim/fit/resource_model.py: per-operator Yosys figures, memories computed (docs/resources.md)"}
