"""GTKWave save files (``.gtkw``) for the FST waveforms of ``WAVES=1`` cocotb runs.

A save file is plain text: ``[dumpfile] "<fst>"`` and ``[savefile] "<gtkw>"``, then the traces, each preceded
by its display flags (``@28`` binary, ``@22`` hexadecimal, ``@24`` decimal) and named by its full hierarchical
path as Verilator (5.48) writes it into the FST: ``<top>.<instance>...<signal>``, a vector with its range, e.g.
``pgs_kernel.s_axi_control_AWADDR[7:0]`` (no ``TOP.`` prefix; the scope ``$rootio`` beside the top holds its
ports again). Groups are ``@800200`` / ``-<name>`` ... ``@1000200`` / ``-<name>``. ``gtkwave <file>.gtkw``
opens the dump with those traces shown.

A :class:`View` opens the window at a size, on a span of time (``[timestart]`` and the zoom of the ``*`` line),
with the primary marker and up to 26 named markers (``A``..``Z``, each named by a ``[markername]`` line); the
zoom follows GTKWave's own rule (:func:`gtkwave_zoom`: ``z`` shows ``2**-z`` time units per 200 pixels of the
wave pane) and a ``[*] view:`` comment states the span it opens on. The compiled harness's
dump of the kernel (:func:`write_kernel_save_file`) opens on 40 clock cycles from 4 before the solve phase, with a
marker at each phase start, read from the ``.phases`` file the harness writes beside the FST; :func:`fst_times`
reads an FST's time range and time unit from its header block.

The signal names and ranges are taken from the RTL source (:func:`rtl_signals`: the ports and nets a module
file declares, their widths evaluated with the module's parameters), so a save file names only signals the
design has; :func:`fst_signal_names` reads the names back from an FST's hierarchy block (decompressed here: no
tool needed) for a check against a real dump.
"""

from __future__ import annotations

import fnmatch
import io
import math
import re
import string
import struct
import zlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import BinaryIO

RTL_DIR = Path(__file__).resolve().parents[2] / "rtl"

BIN, HEX, DEC = "28", "22", "24"  # GTKWave display flags (right-justified binary / hexadecimal / decimal)
GROUP_BEGIN, GROUP_END = "800200", "1000200"


@dataclass(frozen=True)
class Trace:
    path: str  # full hierarchical name as in the FST, vectors with their range
    flags: str = HEX


@dataclass(frozen=True)
class Group:
    name: str
    traces: tuple[Trace, ...]


SIGNALS_WIDTH, SST_WIDTH = 320, 260  # pixels of the signal-name pane and of the hierarchy pane
WINDOW_SIZE = (1600, 1000)  # pixels of the GTKWave window
# Pixels of the window's width that are neither the two panes above nor the wave pane (pane handles, frames, the
# wave pane's scrollbar): GTKWave 3.3.118 (Debian 12, GTK 2) under Xvfb opens a [size] 1600 1000 save file with
# these pane widths on a wave pane of 980 pixels (its Tcl gtkwave::getWaveWidth).
WINDOW_CHROME_WIDTH = 40
NAMED_MARKERS = 26  # GTKWave's named markers A..Z

# GTKWave's zoom (src/wavewindow.c, calczoom()): a zoom z shows nsperframe = max(zoombase**-z, 1) time units per
# "frame" of pixelsperframe = 200 pixels, i.e. nspx = nsperframe / 200 time units per pixel of the wave pane, whose
# width (wavewidth) sets the visible span; zoombase is 2 unless an rc file changes it. zoom_pow10_snap (off by
# default) would round nsperframe to a power of ten. The time unit is the dump's, brought to a power of 1000 s
# (src/currenttime.c, exponent_to_time_scale(): an FST with timescale 10**e s counts in 10**(3*floor(e/3)) s).
GTKWAVE_PIXELS_PER_FRAME, GTKWAVE_ZOOM_BASE = 200, 2.0


def gtkwave_zoom(span: float, wave_pixels: int) -> float:
    """The zoom at which GTKWave shows ``span`` time units across ``wave_pixels``; ValueError below its finest
    zoom (one time unit per frame of 200 pixels)."""
    frame = span * GTKWAVE_PIXELS_PER_FRAME / wave_pixels
    if frame < 1.0:
        raise ValueError(f"view: {span} time units across {wave_pixels} pixels is finer than GTKWave's finest zoom "
                         f"({wave_pixels / GTKWAVE_PIXELS_PER_FRAME:g} units)")
    return -math.log(frame, GTKWAVE_ZOOM_BASE)


_UNIT_NAMES = {0: "s", -3: "ms", -6: "us", -9: "ns", -12: "ps", -15: "fs", -18: "as", -21: "zs"}


def gtkwave_time_unit(timescale: int) -> tuple[int, int]:
    """GTKWave's time unit for a dump whose unit is ``10**timescale`` s: its exponent (a multiple of 3) and the
    factor from the dump's times to GTKWave's, the times of a save file (src/currenttime.c,
    exponent_to_time_scale())."""
    if not -21 <= timescale <= 2:
        raise ValueError(f"timescale 10**{timescale} s is outside GTKWave's range (10**-21 .. 10**2 s)")
    unit = 3 * (timescale // 3)
    return unit, 10 ** (timescale - unit)


@dataclass(frozen=True)
class View:
    """Where GTKWave opens: ``span`` time units (GTKWave's, see :func:`gtkwave_time_unit`) from ``start`` across
    the wave pane of a ``size`` window, the primary marker at ``marker`` (-1: none), named markers ``(name, time)``
    in order (at most 26); ``label`` says in words what the span is (it goes into a comment of the save file)."""

    start: int
    span: int
    marker: int = -1
    named: tuple[tuple[str, int], ...] = ()
    size: tuple[int, int] = WINDOW_SIZE
    label: str = ""

    def __post_init__(self) -> None:
        if self.start < 0 or self.span <= 0:
            raise ValueError(f"view: start {self.start} must be >= 0 and span {self.span} > 0")
        if len(self.named) > NAMED_MARKERS:
            raise ValueError(f"view: {len(self.named)} named markers, GTKWave has {NAMED_MARKERS}")
        gtkwave_zoom(self.span, self.wave_pixels)

    @property
    def wave_pixels(self) -> int:
        return max(self.size[0] - SIGNALS_WIDTH - SST_WIDTH - WINDOW_CHROME_WIDTH, 100)

    @property
    def zoom(self) -> float:
        """GTKWave's zoom for ``span`` across the wave pane (:func:`gtkwave_zoom`)."""
        return gtkwave_zoom(self.span, self.wave_pixels)

    def lines(self) -> list[str]:
        named = [t for _, t in self.named] + [-1] * (NAMED_MARKERS - len(self.named))
        label = f" ({self.label})" if self.label else ""
        return ([f"[*] view: {self.start} to {self.start + self.span}{label} across {self.wave_pixels} pixels",
                 f"[size] {self.size[0]} {self.size[1]}", "[pos] -1 -1",
                 f"*{self.zoom:.6f} {self.marker} " + " ".join(str(t) for t in named)]
                + [f"[markername] {string.ascii_uppercase[i]}{name}" for i, (name, _) in enumerate(self.named)])


def save_file_text(dumpfile: Path, savefile: Path, groups: Sequence[Group], view: View | None = None) -> str:
    """The text of a save file showing ``groups`` of ``dumpfile`` (the hierarchy tree opened down to the scopes
    of the traces), opening on ``view`` (default: from time 0 at GTKWave's own zoom)."""
    lines = ["[*] GTKWave save file written by sim/drive/gtkwave_save.py",
             f'[dumpfile] "{Path(dumpfile).resolve()}"', f'[savefile] "{Path(savefile).resolve()}"',
             *(view.lines() if view else []), f"[timestart] {view.start if view else 0}", "[sst_expanded] 1",
             f"[signals_width] {SIGNALS_WIDTH}", f"[sst_width] {SST_WIDTH}"]
    scopes = {t.path.split("[")[0].rsplit(".", 1)[0] for g in groups for t in g.traces}
    opened = sorted({".".join(s.split(".")[:k]) for s in scopes for k in range(1, s.count(".") + 2)})
    lines += [f"[treeopen] {scope}." for scope in opened]
    for group in groups:
        lines += [f"@{GROUP_BEGIN}", f"-{group.name}"]
        for trace in group.traces:
            lines += [f"@{trace.flags}", trace.path]
        lines += [f"@{GROUP_END}", f"-{group.name}"]
    lines += ["[pattern_trace] 1", "[pattern_trace] 0"]
    return "\n".join(lines) + "\n"


def write_save_file(savefile: Path, dumpfile: Path, groups: Sequence[Group], view: View | None = None) -> Path:
    savefile = Path(savefile)
    savefile.write_text(save_file_text(dumpfile, savefile, groups, view))
    return savefile


@dataclass(frozen=True)
class SavedView:
    """What a save file's text says of its view: ``[timestart]``, the zoom of its ``*`` line, the named markers
    ``(name, time)``, and the span ``claimed`` by the comment this module writes (``(start, end, wave pixels)``,
    None without one)."""

    start: int
    zoom: float
    named: list[tuple[str, int]]
    claimed: tuple[int, int, int] | None


_CLAIM_RE = re.compile(r"\[\*\] view: (\d+) to (\d+)(?: \(.*\))? across (\d+) pixels$")


def save_file_view(text: str) -> SavedView:
    """The view of a save file's text (:class:`SavedView`)."""
    start, zoom, times, names, claimed = 0, 0.0, [], {}, None
    for line in text.splitlines():
        if line.startswith("[timestart] "):
            start = int(line.split()[1])
        elif line.startswith("*"):
            words = line[1:].split()
            zoom, times = float(words[0]), [int(w) for w in words[2:]]
        elif line.startswith("[markername] "):
            tag = line.split(" ", 1)[1]
            names[string.ascii_uppercase.index(tag[0])] = tag[1:]
        elif m := _CLAIM_RE.match(line):
            claimed = (int(m.group(1)), int(m.group(2)), int(m.group(3)))
    return SavedView(start, zoom, [(names.get(i, ""), t) for i, t in enumerate(times) if t >= 0], claimed)


def save_file_traces(text: str) -> list[str]:
    """The trace names of a save file (the lines after a display flag line, group markers excepted)."""
    out, lines = [], text.splitlines()
    for prev, line in zip(lines, lines[1:]):
        if prev.startswith("@") and not line.startswith(("-", "@", "[")) and line:
            out.append(line)
    return out


# --------------------------------------------------------------------------------------------------
# Signal declarations of an RTL module file
# --------------------------------------------------------------------------------------------------

_COMMENT_RE = re.compile(r"//[^\n]*|/\*.*?\*/", re.DOTALL)
_FUNCTION_RE = re.compile(r"\bfunction\b.*?\bendfunction\b", re.DOTALL)  # arguments are not nets
_PARAM_RE = re.compile(r"\b(?:parameter|localparam)\s+(?:int|integer|bit|logic)?\s*(?:\[[^\]]*\]\s*)?(\w+)\s*="
                       r"\s*([^,;\n]+)")
_ENUM_RE = re.compile(r"\btypedef\s+enum\s+(?:logic|bit)\s*\[([^\]:]+):([^\]]+)\]\s*\{[^}]*\}\s*(\w+)\s*;")
_KEYWORDS = r"(?:input|output|inout|wire|logic|reg|bit|var|parameter|localparam)"
_DECL_RE = re.compile(r"(?<![\w$])(?P<dir>(?:input|output|inout)\s+)?(?P<type>wire|logic|reg|bit|var|\w+_t)\b"
                      r"(?:\s+logic\b)?\s*(?:\[(?P<msb>[^\]:]+):(?P<lsb>[^\]]+)\])?\s*"
                      rf"(?P<names>(?!{_KEYWORDS}\b)[A-Za-z_]\w*(?:\s*,\s*(?!{_KEYWORDS}\b)[A-Za-z_]\w*)*)")
_SIZED_RE = re.compile(r"\d*'[sS]?([bodhBODH])([0-9a-fA-F_xXzZ]+)")


def _sv_int(expr: str, env: Mapping[str, int]) -> int:
    """A constant SystemVerilog integer expression of the simple kind parameters use (+ - * / parentheses,
    ``$clog2``, sized literals, names in ``env``)."""
    def sized(m: re.Match) -> str:
        return str(int(m.group(2).replace("_", ""), {"b": 2, "o": 8, "d": 10, "h": 16}[m.group(1).lower()]))

    py = _SIZED_RE.sub(sized, expr).replace("$clog2", "_clog2").replace("/", "//")
    if not re.fullmatch(r"[\w\s+\-*/()]*", py):
        raise ValueError(f"cannot evaluate {expr!r}")
    scope = {"_clog2": lambda x: max(0, math.ceil(math.log2(x))) if x > 0 else 0}
    return int(eval(py, {"__builtins__": {}}, _Env(env, scope)))  # noqa: S307 (checked characters only)


class _Env(dict):
    def __init__(self, env: Mapping[str, int], extra: dict):
        super().__init__(extra)
        self.env = env

    def __missing__(self, key: str) -> int:
        return self.env[key]


class _Params(dict):
    """Parameter values resolved on demand from their declarations (a parameter nobody needs may stay
    unevaluable, e.g. one with a ternary)."""

    def __init__(self, exprs: dict[str, str], overrides: Mapping[str, int]):
        super().__init__({k: int(v) for k, v in overrides.items() if k in exprs})
        self.exprs = exprs

    def __missing__(self, key: str) -> int:
        value = _sv_int(self.exprs[key], self)
        self[key] = value
        return value


@dataclass
class Declarations:
    """Ports and nets declared in a module file, in declaration order, with their range expressions; a range
    is evaluated (with the module's parameters) only when asked for."""

    ranges: dict[str, tuple[str, str] | None]  # name -> (msb, lsb) expressions, None for a scalar
    params: _Params

    @property
    def names(self) -> list[str]:
        return list(self.ranges)

    def range(self, name: str) -> tuple[int, int] | None:
        rng = self.ranges[name]
        return (_sv_int(rng[0], self.params), _sv_int(rng[1], self.params)) if rng else None


def _package_params(module_file: Path, text: str) -> dict[str, str]:
    """The constants of the packages ``text`` imports from (``import pkg::NAME, ...;`` or ``pkg::*``), read from the
    files beside ``module_file`` named after them (``rtl/pgs_seq_pkg.sv``)."""
    out: dict[str, str] = {}
    imports = " ".join(re.findall(r"\bimport\s+([^;]+);", text))
    for pkg in dict.fromkeys(re.findall(r"(\w+)::", imports)):
        path = module_file.parent / f"{pkg}.sv"
        if path.is_file():
            body = _FUNCTION_RE.sub("", _COMMENT_RE.sub("", path.read_text()))
            out.update({m.group(1): m.group(2).strip() for m in _PARAM_RE.finditer(body)})
    return out


def rtl_signals(module_file: Path, parameters: Mapping[str, int] | None = None) -> Declarations:
    """The ports and nets ``module_file`` declares; ranges with the module's parameters (its defaults,
    overridden by ``parameters``)."""
    text = _FUNCTION_RE.sub("", _COMMENT_RE.sub("", Path(module_file).read_text()))
    params = _Params({**_package_params(Path(module_file), text),
                      **{m.group(1): m.group(2).strip() for m in _PARAM_RE.finditer(text)}}, parameters or {})
    types = {m.group(3): (m.group(1), m.group(2)) for m in _ENUM_RE.finditer(text)}
    ranges: dict[str, tuple[str, str] | None] = {}
    for m in _DECL_RE.finditer(text):
        if re.search(r"\b(?:parameter|localparam|typedef\s+enum)$", text[:m.start()].rstrip()):
            continue
        typ = m.group("type")
        if typ.endswith("_t") and typ not in types:
            continue
        rng = types[typ] if typ in types else ((m.group("msb"), m.group("lsb")) if m.group("msb") else None)
        for name in re.split(r"\s*,\s*", m.group("names").strip()):
            ranges.setdefault(name, rng)
    return Declarations(ranges, params)


def resolve(scope: str, declared: Declarations, patterns: Sequence[str]) -> list[Trace]:
    """Traces for the signals matching ``patterns`` (fnmatch, declaration order within a pattern) under the FST
    scope ``scope``, named as GTKWave names them (:func:`gtkwave_name`: a one-bit vector ``[0:0]`` is ``[0]``);
    single bits in binary, vectors in hexadecimal. Raises KeyError for a pattern no declared signal matches."""
    out = []
    for pat in patterns:
        names = [n for n in declared.names if fnmatch.fnmatchcase(n, pat)]
        if not names:
            raise KeyError(f"{scope}: no signal declared matches {pat!r}")
        for name in names:
            rng = declared.range(name)
            if rng is None or rng[0] == rng[1]:
                out.append(Trace(f"{scope}.{name}" + (f"[{rng[0]}]" if rng else ""), BIN))
            else:
                out.append(Trace(f"{scope}.{name}[{rng[0]}:{rng[1]}]", HEX))
    return out


# --------------------------------------------------------------------------------------------------
# The kernel's save file
# --------------------------------------------------------------------------------------------------

KERNEL_TOP = "pgs_kernel"  # the kernel's scope in an FST of Verilator 5.48 (cocotb's or a compiled harness)
# (group, [(instance path below the kernel, RTL file, signal patterns)]): the pipeline on the first screen
KERNEL_LAYOUT: list[tuple[str, list[tuple[str, str, list[str]]]]] = [
    ("Control", [("", "pgs_kernel.sv", ["ap_clk", "ap_rst_n", "ap_start", "ap_done", "ap_idle", "interrupt"])]),
    ("Pipeline", [("u_seq", "pgs_sequencer.sv",
                   ["phase", "crec_valid", "rkind", "hazard"]),
                  ("u_seq.u_hazards", "pgs_seq_hazards.sv", ["cam_full", "may_issue"]),
                  ("u_seq", "pgs_sequencer.sv",
                   ["issue", "i_pass", "i_slot", "l_go", "l_issue", "l_reject", "retire", "l_retire"]),
                  ("u_seq.u_integrate", "pgs_seq_integrate.sv", ["int_issue", "io_valid", "credits"]),
                  ("", "pgs_kernel.sv",
                   ["trace_valid", "stat_cycles", "stat_stalls", "stat_bubbles", "stat_issued", "err_set"])]),
    ("DMA streams", [("", "pgs_kernel.sv", ["s_axis_body_*", "s_axis_cons_*", "m_axis_body_*"])]),
    ("Registers (AXI4-Lite)", [("", "pgs_kernel.sv", ["s_axi_control_*"])]),
]
_DECIMAL = {"i_pass", "i_slot", "credits", "stat_cycles", "stat_stalls", "stat_bubbles",
            "stat_issued"}


def kernel_groups(parameters: Mapping[str, int] | None = None, top: str = KERNEL_TOP) -> list[Group]:
    """The save-file groups of ``pgs_kernel`` built with ``parameters`` (``EXP_BITS``, ``MAN_BITS``, ``CONS_W``,
    ...; the sequencer gets the same names), the kernel being the FST scope ``top``."""
    groups = []
    for name, parts in KERNEL_LAYOUT:
        traces: list[Trace] = []
        for inst, rtl_file, patterns in parts:
            scope = f"{top}.{inst}" if inst else top
            for t in resolve(scope, rtl_signals(RTL_DIR / rtl_file, parameters), patterns):
                base = t.path.rsplit(".", 1)[1].split("[")[0]
                traces.append(Trace(t.path, DEC) if base in _DECIMAL else t)
        groups.append(Group(name, tuple(traces)))
    return groups


# The kernel's view: the cycles shown before the solve phase starts, and in all (about 25 pixels a cycle in the wave
# pane of the default window: each clock edge and handshake visible, a 32-bit word's hex value mostly readable)
VIEW_LEAD_CYCLES, VIEW_CYCLES = 4, 40


def read_phases(path: Path) -> tuple[int, list[tuple[str, int]]]:
    """The clock period (ps) and the ``(name, cycle)`` lines of a harness's ``.phases`` file."""
    clock_ps, marks = 0, []
    for line in Path(path).read_text().splitlines():
        name, value = line.split()
        if name == "clock_ps":
            clock_ps = int(value)
        else:
            marks.append((name, int(value)))
    if clock_ps <= 0:
        raise ValueError(f"{path}: no clock_ps line")
    return clock_ps, marks


def kernel_view(clock: int, marks: Sequence[tuple[str, int]], end_time: int, unit: str = "ps") -> View:
    """The view of a kernel dump that ends at ``end_time``, times and the clock period ``clock`` in GTKWave's time
    unit ``unit``: ``VIEW_CYCLES`` clock periods from ``VIEW_LEAD_CYCLES`` before the solve phase starts (the first
    phase when there is no solve), the primary marker at that start, a named marker at each phase start from
    ``start`` (the ap_start write) on that the dump holds."""
    names = [name for name, _ in marks]
    first = names.index("start") if "start" in names else 0  # the phase of the reset cycles is no phase start
    named = tuple((name, cycle * clock) for name, cycle in marks[first:] if cycle * clock <= end_time)
    named = named[:NAMED_MARKERS]
    solve = next((t for name, t in named if name == "SOLVE"), named[0][1] if named else 0)
    start = max(0, min(solve - VIEW_LEAD_CYCLES * clock, end_time - VIEW_CYCLES * clock))
    label = f"{VIEW_CYCLES} clock cycles of {clock} {unit}"
    return View(start, VIEW_CYCLES * clock, solve, named, label=label)


def _clock_in_units(clock_ps: int, unit: int) -> int:
    """A clock period in ps in GTKWave's time unit ``10**unit`` s; ValueError when it is no whole number of them."""
    if unit <= -12:
        return clock_ps * 10 ** (-12 - unit)
    clock, rest = divmod(clock_ps, 10 ** (unit + 12))
    if rest or not clock:
        raise ValueError(f"clock period {clock_ps} ps is no whole number of the dump's time unit ({_UNIT_NAMES[unit]})")
    return clock


def write_kernel_save_file(fst: Path, top: str = KERNEL_TOP, parameters: Mapping[str, int] | None = None) -> Path:
    """``<fst without suffix>.gtkw`` for a dump of ``pgs_kernel`` (scope ``top``) built with ``parameters``; when the
    harness wrote ``<fst without suffix>.phases`` beside it, the view of :func:`kernel_view`."""
    fst = Path(fst)
    phases = fst.with_suffix(".phases")
    view = None
    if phases.exists():
        clock_ps, marks = read_phases(phases)
        times = fst_times(fst)
        unit, factor = gtkwave_time_unit(times.timescale)
        view = kernel_view(_clock_in_units(clock_ps, unit), marks, times.end * factor, _UNIT_NAMES[unit])
    return write_save_file(fst.with_suffix(".gtkw"), fst, kernel_groups(parameters, top), view)


# --------------------------------------------------------------------------------------------------
# Names in a real dump
# --------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class FstTimes:
    start: int
    end: int
    timescale: int  # the time unit as a power of ten of seconds (-12: ps)


FST_BL_HDR, FST_BL_HIER, FST_BL_HIER_LZ4, FST_BL_HIER_LZ4DUO, FST_BL_ZWRAPPER = 0, 4, 6, 7, 254  # fstapi.h block types
FST_ST_ATTRBEGIN, FST_ST_ATTREND, FST_ST_SCOPE, FST_ST_UPSCOPE = 252, 253, 254, 255  # hierarchy record tags
FST_VT_MAX = 29  # variable record tags are 0 .. FST_VT_MAX


def fst_times(fst: Path) -> FstTimes:
    """The first and last time and the time unit of an FST, from its header block (block type, section length,
    start and end time as big-endian u64, an endianness double, memory used, scope / hierarchy-var / var /
    value-change-section counts as u64, the timescale exponent as i8)."""
    with _open_fst(fst) as f:
        head = f.read(1 + 8 * 9 + 1)
    if len(head) < 1 + 8 * 9 + 1 or head[0] != FST_BL_HDR:
        raise ValueError(f"{fst}: not an FST file (no header block)")
    start, end = struct.unpack(">QQ", head[9:25])
    return FstTimes(start, end, struct.unpack(">b", head[-1:])[0])


def _fst_blocks(f: BinaryIO, name: Path) -> Iterator[tuple[int, int, int]]:
    """``(block type, payload offset, payload length)`` of each block of an open FST: a type byte, then a
    big-endian u64 section length that counts itself and the payload."""
    offset = 0
    while head := f.read(9):
        if len(head) < 9:
            raise ValueError(f"{name}: FST truncated in a block header at byte {offset}")
        typ, length = head[0], struct.unpack(">Q", head[1:])[0]
        if length < 8:
            raise ValueError(f"{name}: FST block at byte {offset} has length {length}")
        yield typ, offset + 9, length - 8
        offset += 1 + length
        f.seek(offset)


def _lz4_block(src: bytes, size: int) -> bytes:
    """An LZ4 block (no frame) decompressed to ``size`` bytes: sequences of a token (literal length, match
    length - 4; 15 continues in bytes up to 255), the literals, a little-endian u16 match offset."""
    try:
        out = _lz4_sequences(src)
    except IndexError:
        raise ValueError("LZ4: the block ends inside a sequence") from None
    if len(out) != size:
        raise ValueError(f"LZ4: {len(out)} bytes decoded, {size} expected")
    return bytes(out)


def _lz4_sequences(src: bytes) -> bytearray:
    out, i, n = bytearray(), 0, len(src)
    while i < n:
        token = src[i]
        i += 1
        lit = token >> 4
        if lit == 15:
            while src[i] == 255:
                lit, i = lit + 255, i + 1
            lit, i = lit + src[i], i + 1
        out += src[i:i + lit]
        i += lit
        if i >= n:
            break
        back = src[i] | src[i + 1] << 8
        i += 2
        match = token & 15
        if match == 15:
            while src[i] == 255:
                match, i = match + 255, i + 1
            match, i = match + src[i], i + 1
        match += 4
        if not 0 < back <= len(out):
            raise ValueError(f"LZ4: match offset {back} outside the {len(out)} bytes decoded")
        pattern = out[len(out) - back:len(out) - back + match]  # overlapping: repeats the last ``back`` bytes
        out += (pattern * (match // len(pattern) + 1))[:match]
    return out


def _varint(data: bytes, i: int) -> tuple[int, int]:
    """An FST varint (7 bits a byte, least significant first, the high bit set on all but the last) at ``i``:
    its value and the offset after it."""
    value, shift = 0, 0
    while True:
        byte = data[i]
        value |= (byte & 0x7F) << shift
        i, shift = i + 1, shift + 7
        if byte < 0x80:
            return value, i


def _open_fst(fst: Path) -> BinaryIO:
    """An FST opened for reading; one gzip-wrapped as a whole (a first block of type 254: its uncompressed length
    as a u64, then the gzip stream of the plain file) unwrapped in memory."""
    f = Path(fst).open("rb")
    head = f.read(17)
    if head[:1] != bytes([FST_BL_ZWRAPPER]):
        f.seek(0)
        return f
    with f:
        return io.BytesIO(zlib.decompress(f.read(), wbits=47))


def fst_hierarchy(fst: Path) -> bytes:
    """The uncompressed hierarchy block of an FST (gzip, LZ4 or twice LZ4, after its uncompressed length as a
    big-endian u64)."""
    fst = Path(fst)
    with _open_fst(fst) as f:
        for typ, offset, length in _fst_blocks(f, fst):
            if typ not in (FST_BL_HIER, FST_BL_HIER_LZ4, FST_BL_HIER_LZ4DUO):
                continue
            f.seek(offset)
            payload = f.read(length)
            if len(payload) < max(length, 8):
                raise ValueError(f"{fst}: FST truncated in its hierarchy block")
            size = struct.unpack(">Q", payload[:8])[0]
            if typ == FST_BL_HIER:
                data = zlib.decompress(payload[8:], wbits=47)  # a gzip (gzdopen) stream
            elif typ == FST_BL_HIER_LZ4:
                data = _lz4_block(payload[8:], size)
            else:
                first, i = _varint(payload, 8)
                data = _lz4_block(_lz4_block(payload[i:], first), size)
            if len(data) != size:
                raise ValueError(f"{fst}: hierarchy of {len(data)} bytes, the block says {size}")
            return data
    raise ValueError(f"{fst}: no hierarchy block (not an FST, or one still being written)")


FST_VT_PORT = 18  # a port's length is 3 * width + 2
_GTKWAVE_UNRANGED = {1, 2, 3, 4, 20, 21, 24, 25, 26, 29}  # integer, parameter, real, string types: name without range
_TRAILING_RANGE_RE = re.compile(r"\[(-?\d+)(?::(-?\d+))?\]$")


def gtkwave_name(name: str, width: int, vartype: int = 16) -> str:
    """The name GTKWave 3.3 gives an FST variable ``name`` (the leaf, as the FST holds it) of ``width`` bits and FST
    type ``vartype`` (src/fst.c, extractNextVar() and fst_main()): spaces dropped; a trailing ``[msb:lsb]`` or
    ``[bit]`` taken off (kept on a multi-bit ``[n]``, an array element) and put back as ``[msb:lsb]`` on a bit
    vector of more than one bit (``[width-1:0]`` without a range), as ``[msb]`` on a one-bit one with a range
    (Verilator's ``l_go [0:0]`` is ``l_go[0]``), not at all on integers, reals and strings (and variable-length
    values, width 0)."""
    name = name.replace(" ", "")
    m = _TRAILING_RANGE_RE.search(name)
    if m and not (width > 1 and m.group(2) is None):
        base, msb = name[:m.start()], int(m.group(1))
        lsb = int(m.group(2)) if m.group(2) is not None else msb
    else:
        base, msb, lsb = name, (width - 1 if width > 1 else -1), 0
    if vartype in _GTKWAVE_UNRANGED or width == 0 or (msb < 0 and width == 1):
        return base
    return f"{base}[{msb}:{lsb}]" if width > 1 else f"{base}[{msb}]"


def fst_signal_names(fst: Path) -> set[str]:
    """The full names of an FST's variables as GTKWave shows them (and a save file must name them): scopes joined
    by ``.``, then :func:`gtkwave_name`. Hierarchy records: scope (tag 254, scope type, name and component
    NUL-terminated), upscope (255), attribute begin (252, type, subtype, name, varint argument) and end (253),
    variable (tag 0..29 = its type, direction, name, varint length, varint alias)."""
    data = fst_hierarchy(fst)
    names: set[str] = set()
    scope: list[str] = []
    i, n = 0, len(data)
    while i < n:
        tag = data[i]
        if tag == FST_ST_SCOPE:
            end = data.index(0, i + 2)
            scope.append(data[i + 2:end].decode())
            i = data.index(0, end + 1) + 1
        elif tag == FST_ST_UPSCOPE:
            if not scope:
                raise ValueError(f"{fst}: hierarchy closes a scope it did not open at byte {i}")
            scope.pop()
            i += 1
        elif tag == FST_ST_ATTRBEGIN:
            i = _varint(data, data.index(0, i + 3) + 1)[1]
        elif tag == FST_ST_ATTREND:
            i += 1
        elif tag <= FST_VT_MAX:
            end = data.index(0, i + 2)
            leaf = data[i + 2:end].decode()
            length, i = _varint(data, end + 1)
            i = _varint(data, i)[1]  # the alias
            width = (length - 2) // 3 if tag == FST_VT_PORT else length
            names.add(".".join(scope + [gtkwave_name(leaf, width, tag)]))
        else:
            raise ValueError(f"{fst}: unknown hierarchy record {tag} at byte {i}")
    return names
