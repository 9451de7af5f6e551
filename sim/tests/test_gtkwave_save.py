"""The kernel's waveforms: FST time in the platform's clock period, the save file's view (the span GTKWave opens on,
by GTKWave's own zoom rule and, where GTKWave is installed, read back from GTKWave), the phase markers, and the
FST's names as GTKWave shows them."""

from __future__ import annotations

import gzip
import os
import re
import shutil
import struct
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest

from models import scenes
from models.formats.number_format import FP32
from models.golden.contact_solver import SolverParams
from models.kernel.kernel_job import KernelJob
from models.timing.platforms import get_preset
from sim.compile.kernel_build import KernelBuild, build_kernel, default_window
from sim.drive.gtkwave_save import (NAMED_MARKERS, VIEW_CYCLES, VIEW_LEAD_CYCLES, WINDOW_SIZE, View, _lz4_block,
                                    fst_signal_names, fst_times, gtkwave_name, gtkwave_time_unit, kernel_view,
                                    read_phases, save_file_text, save_file_traces, save_file_view,
                                    write_kernel_save_file)
from sim.drive.harness_run import clock_period_ps, harness_cycle_limit, run_harness, write_inputs

P = 3636  # ps: 275 MHz
MARKS = [("IDLE", 1), ("start", 40), ("LOAD", 45), ("SOLVE", 300), ("DRAIN", 900), ("INTEG", 1000), ("DONE", 1200)]


def gtkwave_visible_span(zoom: float, wave_pixels: int) -> float:
    """The time units GTKWave 3.3 shows across a wave pane of ``wave_pixels`` at the save file's zoom, by its own
    rule, written out here apart from the module's: src/wavewindow.c, calczoom(z0):
    ``frame = pow(zoombase, -z0)`` (zoombase 2.0 in src/globals.c), ``nsperframe = max(frame, 1)``,
    ``pixelsperframe = 200``, ``nspx = nsperframe / pixelsperframe``; the pane shows ``wavewidth * nspx``."""
    return wave_pixels * max(2.0 ** -zoom, 1.0) / 200


def test_clock_period_comes_from_the_preset() -> None:
    assert clock_period_ps(get_preset("zcu102")) == P
    assert clock_period_ps(get_preset("u280")) == 3333


def test_kernel_view_opens_a_few_cycles_before_the_solve_phase_with_a_marker_at_each_phase() -> None:
    view = kernel_view(P, MARKS, end_time=1500 * P)
    assert 20 <= VIEW_CYCLES <= 100 and 0 < VIEW_LEAD_CYCLES <= VIEW_CYCLES // 5  # tens of cycles, solve in front
    assert view.start == (300 - VIEW_LEAD_CYCLES) * P and view.span == VIEW_CYCLES * P
    assert view.marker == 300 * P
    assert [name for name, _ in view.named] == ["start", "LOAD", "SOLVE", "DRAIN", "INTEG", "DONE"]
    assert dict(view.named)["INTEG"] == 1000 * P


def test_kernel_view_keeps_only_the_markers_the_dump_holds() -> None:
    view = kernel_view(P, MARKS, end_time=950 * P)
    assert [name for name, _ in view.named] == ["start", "LOAD", "SOLVE", "DRAIN"]
    short = kernel_view(P, MARKS, end_time=310 * P)  # the view still ends inside the dump
    assert short.start + short.span <= 310 * P and short.start < 300 * P


def _claimed_and_shown(text: str) -> tuple[tuple[int, int, int], int, float]:
    """The span a save file's text claims ``(start, end, wave pixels)``, its ``[timestart]``, and the span its zoom
    shows across those pixels by GTKWave's rule."""
    saved = save_file_view(text)
    assert saved.claimed is not None, "the save file states no view"
    return saved.claimed, saved.start, gtkwave_visible_span(saved.zoom, saved.claimed[2])


def test_save_file_zoom_shows_the_span_it_claims(tmp_path: Path) -> None:
    """The kernel's view: its ``*`` zoom shows, by GTKWave's rule, the VIEW_CYCLES clock periods the ``[*] view:``
    comment claims, from its ``[timestart]``, across the wave pane of the window the file asks for."""
    view = kernel_view(P, MARKS, end_time=1500 * P)
    text = save_file_text(tmp_path / "w.fst", tmp_path / "w.gtkw", [], view)
    (start, end, pixels), timestart, shown = _claimed_and_shown(text)
    assert (start, end) == (view.start, view.start + VIEW_CYCLES * P) and timestart == start
    assert pixels == view.wave_pixels and f"[size] {WINDOW_SIZE[0]} {WINDOW_SIZE[1]}" in text
    assert shown == pytest.approx(end - start, rel=1e-5)  # the zoom is written with 6 decimals
    assert f"{VIEW_CYCLES} clock cycles of {P} ps" in text


@pytest.mark.parametrize("span,size", [(1000, (1600, 1000)), (VIEW_CYCLES * P, (1200, 800)),
                                       (10 ** 9, (1920, 1080)), (5000, (800, 600))])
def test_view_zoom_follows_gtkwaves_rule(span: int, size: tuple[int, int]) -> None:
    view = View(7, span, size=size)
    assert gtkwave_visible_span(view.zoom, view.wave_pixels) == pytest.approx(span, rel=1e-12)
    (start, end, pixels), _, shown = _claimed_and_shown("\n".join(view.lines()))
    assert (start, end, pixels) == (7, 7 + span, view.wave_pixels)
    assert shown == pytest.approx(span, rel=1e-5)


def test_view_rejects_what_gtkwave_cannot_show() -> None:
    with pytest.raises(ValueError, match="named markers"):
        View(0, 10_000, named=tuple((f"m{i}", i) for i in range(NAMED_MARKERS + 1)))
    with pytest.raises(ValueError, match="finest zoom"):  # one time unit per 200 pixels at most
        View(0, 2)


@pytest.mark.parametrize("timescale,unit,factor", [(-12, -12, 1), (-11, -12, 10), (-10, -12, 100), (-9, -9, 1),
                                                   (-13, -15, 100), (0, 0, 1), (2, 0, 100), (-21, -21, 1)])
def test_gtkwave_time_unit_is_the_dumps_in_powers_of_1000(timescale: int, unit: int, factor: int) -> None:
    # src/currenttime.c, exponent_to_time_scale(): e.g. -10 -> time_scale 100, time_dimension 'p'
    assert gtkwave_time_unit(timescale) == (unit, factor)


def test_gtkwave_time_unit_rejects_what_gtkwave_has_no_unit_for() -> None:
    with pytest.raises(ValueError, match="outside GTKWave's range"):
        gtkwave_time_unit(-22)


def _fst_header(start: int, end: int, timescale: int) -> bytes:
    """An FST header block: type 0, section length 329, start and end time, an endianness double, memory used,
    scope / variable / handle / section counts, the timescale; version (128), date (119), file type (1) and time
    zero (8) zero."""
    return (bytes([0]) + struct.pack(">QQQ", 329, start, end) + struct.pack("<d", 1.0)
            + struct.pack(">5Q", 0, 1, 2, 3, 1) + struct.pack(">b", timescale) + bytes(128 + 119 + 1 + 8))


def test_fst_times_reads_the_header_block(tmp_path: Path) -> None:
    f = tmp_path / "x.fst"
    f.write_bytes(_fst_header(0, 123 * P + P // 2, -12))
    t = fst_times(f)
    assert (t.start, t.end, t.timescale) == (0, 123 * P + P // 2, -12)
    f.write_bytes(b"\x01" + bytes(100))
    with pytest.raises(ValueError, match="not an FST"):
        fst_times(f)


@pytest.mark.parametrize("timescale,scale,unit", [(-12, 1, "ps"), (-13, 100, "fs"), (-9, 1, "ns")])
def test_kernel_save_file_times_are_gtkwaves(tmp_path: Path, timescale: int, scale: int, unit: str) -> None:
    """Markers, ``[timestart]`` and span in GTKWave's unit of the dump: a dump in 100 fs steps counts in fs, one
    in ns in ns (a clock of 4000 ps is 4 of them)."""
    clock_ps = 4000
    per_cycle = {"ps": clock_ps, "fs": clock_ps * 1000, "ns": clock_ps // 1000}[unit]  # the clock in GTKWave's unit
    fst = tmp_path / "waves.fst"
    fst.write_bytes(_fst_header(0, 1500 * per_cycle // scale, timescale))
    (tmp_path / "waves.phases").write_text(f"clock_ps {clock_ps}\n" + "".join(f"{n} {c}\n" for n, c in MARKS))
    saved = save_file_view(write_kernel_save_file(fst).read_text())
    assert saved.start == (300 - VIEW_LEAD_CYCLES) * per_cycle
    assert dict(saved.named)["SOLVE"] == 300 * per_cycle and dict(saved.named)["DONE"] == 1200 * per_cycle
    assert saved.claimed is not None and saved.claimed[1] - saved.claimed[0] == VIEW_CYCLES * per_cycle
    assert f"{VIEW_CYCLES} clock cycles of {per_cycle} {unit}" in fst.with_suffix(".gtkw").read_text()


def test_kernel_save_file_rejects_a_clock_the_dumps_unit_cannot_count(tmp_path: Path) -> None:
    fst = tmp_path / "waves.fst"
    fst.write_bytes(_fst_header(0, 10 ** 6, -9))
    (tmp_path / "waves.phases").write_text(f"clock_ps {P}\nSOLVE 10\n")
    with pytest.raises(ValueError, match="no whole number"):
        write_kernel_save_file(fst)
    assert not fst.with_suffix(".gtkw").exists()


# --------------------------------------------------------------------------------------------------
# The FST's names, read from its hierarchy block
# --------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("name,width,vartype,shown", [
    ("ap_clk", 1, 16, "ap_clk"),
    ("AWADDR [7:0]", 8, 16, "AWADDR[7:0]"),
    ("l_go [0:0]", 1, 23, "l_go[0]"),  # Verilator's one-lane vector: GTKWave names the bit
    ("bit [5]", 1, 16, "bit[5]"),
    ("mem[3]", 8, 16, "mem[3][7:0]"),  # an array element without a bit range keeps its index
    ("bus", 4, 16, "bus[3:0]"),
    ("count [31:0]", 32, 24, "count"),  # an int: no range
    ("x", 64, 3, "x"),  # a real
    ("s", 0, 21, "s"),  # a variable-length string
    ("down [0:3]", 4, 16, "down[0:3]"),
])
def test_gtkwave_name_follows_gtkwaves_fst_loader(name: str, width: int, vartype: int, shown: str) -> None:
    assert gtkwave_name(name, width, vartype) == shown


def _varint(v: int) -> bytes:
    out = bytearray()
    while v >= 0x80:
        out.append(v & 0x7F | 0x80)
        v >>= 7
    return bytes(out + bytes([v]))


def _var(typ: int, name: str, length: int, direction: int = 0) -> bytes:
    return bytes([typ, direction]) + name.encode() + b"\0" + _varint(length) + _varint(0)


HIERARCHY = (b"\xfe\x00top\0\0"
             + b"\xfc\x07\x00top.state_t 2 A B 0 1\0" + _varint(300) + b"\xfd"  # an attribute (an enum table)
             + _var(16, "clk", 1, 1) + _var(16, "bus [7:0]", 8) + _var(23, "go [0:0]", 1)
             + _var(24, "count [31:0]", 32) + _var(16, "wide [299:0]", 300) + _var(18, "port [3:0]", 3 * 4 + 2)
             + b"\xfe\x00sub\0inst\0" + _var(16, "mem[3]", 8) + b"\xff"
             + b"\xff")
NAMES = {"top.clk", "top.bus[7:0]", "top.go[0]", "top.count", "top.wide[299:0]", "top.port[3:0]",
         "top.sub.mem[3][7:0]"}


def _lz4_literals(data: bytes) -> bytes:
    """An LZ4 block of one sequence, all literals (valid LZ4: the last sequence has no match)."""
    n = len(data)
    if n < 15:
        return bytes([n << 4]) + data
    rest = n - 15
    return b"\xf0" + b"\xff" * (rest // 255) + bytes([rest % 255]) + data


def _block(typ: int, payload: bytes) -> bytes:
    return bytes([typ]) + struct.pack(">Q", len(payload) + 8) + payload


def _fst_with_hierarchy(typ: int, hierarchy: bytes) -> bytes:
    size = struct.pack(">Q", len(hierarchy))
    payload = {4: size + gzip.compress(hierarchy), 6: size + _lz4_literals(hierarchy),
               7: size + _varint(len(_lz4_literals(hierarchy))) + _lz4_literals(_lz4_literals(hierarchy))}[typ]
    return _fst_header(0, 100, -12) + _block(3, b"geometry") + _block(typ, payload)


@pytest.mark.parametrize("typ", [4, 6, 7], ids=["gzip", "lz4", "lz4-twice"])
def test_fst_signal_names_reads_each_kind_of_hierarchy_block(tmp_path: Path, typ: int) -> None:
    f = tmp_path / "h.fst"
    f.write_bytes(_fst_with_hierarchy(typ, HIERARCHY))
    assert fst_signal_names(f) == NAMES


def test_fst_gzip_wrapped_as_a_whole_is_read(tmp_path: Path) -> None:
    plain = _fst_with_hierarchy(6, HIERARCHY)
    f = tmp_path / "z.fst"
    f.write_bytes(_block(254, struct.pack(">Q", len(plain)) + gzip.compress(plain)))
    assert fst_signal_names(f) == NAMES and fst_times(f).end == 100


def test_fst_without_a_hierarchy_or_cut_short_is_an_error(tmp_path: Path) -> None:
    f = tmp_path / "bad.fst"
    f.write_bytes(_fst_header(0, 100, -12))
    with pytest.raises(ValueError, match="no hierarchy block"):
        fst_signal_names(f)
    f.write_bytes(_fst_with_hierarchy(6, HIERARCHY)[:-3])
    with pytest.raises(ValueError, match="truncated in its hierarchy block"):
        fst_signal_names(f)
    lz4 = struct.pack(">Q", len(HIERARCHY)) + _lz4_literals(HIERARCHY)[:-5]  # whole, but its literals cut short
    f.write_bytes(_fst_header(0, 100, -12) + _block(6, lz4))
    with pytest.raises(ValueError, match="LZ4"):
        fst_signal_names(f)
    f.write_bytes(_fst_with_hierarchy(4, HIERARCHY + b"\x63"))  # a record tag no FST has
    with pytest.raises(ValueError, match="unknown hierarchy record 99"):
        fst_signal_names(f)


def test_lz4_block_copies_overlapping_matches() -> None:
    # token 2 literals / match 4+2, "ab", offset 2: the match repeats "ab" three times; then 1 literal "c"
    block = bytes([0x22]) + b"ab" + struct.pack("<H", 2) + bytes([0x10]) + b"c"
    assert _lz4_block(block, 9) == b"ababababc"
    # a long match (15 + 255 + 3 + 4 = 277 bytes) of one byte
    block = bytes([0x1F]) + b"x" + struct.pack("<H", 1) + bytes([255, 3]) + bytes([0x10]) + b"y"
    assert _lz4_block(block, 279) == b"x" * 278 + b"y"
    with pytest.raises(ValueError, match="9 bytes decoded, 10 expected"):
        _lz4_block(bytes([0x22]) + b"ab" + struct.pack("<H", 2) + bytes([0x10]) + b"c", 10)
    with pytest.raises(ValueError, match="match offset 5"):
        _lz4_block(bytes([0x20]) + b"ab" + struct.pack("<H", 5) + bytes([0x10]) + b"c", 9)


# --------------------------------------------------------------------------------------------------
# A real dump of the compiled harness
# --------------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class HarnessWaves:
    fst: Path
    period: int
    marks: dict[str, int]
    harness_cycles: int
    save: Path


@pytest.fixture(scope="module")
def harness_waves(tmp_path_factory: pytest.TempPathFactory) -> HarnessWaves:
    """A waves build of the harness run on the stack scene (2 iterations), its FST and the save file of it."""
    run_dir = tmp_path_factory.mktemp("harness_waves")
    preset = get_preset("zcu102")
    frame = scenes.load_or_capture("stack", seed=1)
    job = KernelJob.from_frame(frame, FP32, SolverParams(iterations=2), "hazard",
                               default_window(FP32, preset.stream_bits))
    kb = KernelBuild(FP32, cons_bits=preset.stream_bits, waves=True, compile_profile="o0")
    exe, _ = build_kernel(kb)
    write_inputs(run_dir, job, kb)
    fst = run_dir / "waves.fst"
    regs = run_harness(exe, run_dir, 1, preset, harness_cycle_limit(job),
                       env=dict(os.environ, PGS_WAVES=str(fst), PGS_WAVE_CYCLES="0"))
    save = write_kernel_save_file(fst, top="pgs_kernel.pgs_kernel", parameters=kb.parameters)
    _, marks = read_phases(run_dir / "waves.phases")
    return HarnessWaves(fst, clock_period_ps(preset), dict(marks), regs["harness_cycles"], save)


def test_harness_waves_run_in_clock_periods_and_open_on_the_solve_phase(harness_waves: HarnessWaves) -> None:
    """The FST's unit is ps, its last time a rising edge at clock-period steps, the .phases file names each phase,
    the save file opens a few cycles before the solve phase on the span its zoom shows."""
    w, period, cycle = harness_waves, harness_waves.period, harness_waves.marks
    times = fst_times(w.fst)
    assert times.timescale == -12 and times.start == 0
    assert times.end % period == period // 2
    clock_ps, _ = read_phases(w.fst.with_suffix(".phases"))
    assert clock_ps == period
    assert all(p in cycle for p in ("start", "LOAD", "SOLVE", "DRAIN", "INTEG", "DONE"))
    assert cycle["start"] < cycle["LOAD"] < cycle["SOLVE"] < cycle["DRAIN"] < cycle["INTEG"] < cycle["DONE"]
    # the whole run is dumped: the last edge is a few cycles (register reads) after the kernel finished
    assert cycle["DONE"] * period < times.end
    assert cycle["DONE"] - cycle["start"] <= w.harness_cycles + 100
    text = w.save.read_text()
    saved = save_file_view(text)
    assert saved.start == (cycle["SOLVE"] - VIEW_LEAD_CYCLES) * period
    assert dict(saved.named)["SOLVE"] == cycle["SOLVE"] * period and all(t % period == 0 for _, t in saved.named)
    (start, end, pixels), _, shown = _claimed_and_shown(text)
    assert (start, end) == (saved.start, saved.start + VIEW_CYCLES * period) and end <= times.end
    assert shown == pytest.approx(end - start, rel=1e-5)
    assert "[size] " in text and save_file_traces(text)


def test_harness_save_file_names_only_what_gtkwave_finds_in_the_fst(harness_waves: HarnessWaves) -> None:
    """Every trace of the save file is a name GTKWave gives a variable of the real dump (GTKWave drops a trace it
    cannot find without a word: Verilator's one-lane ``l_go [0:0]`` is GTKWave's ``l_go[0]``)."""
    names = fst_signal_names(harness_waves.fst)
    traces = save_file_traces(harness_waves.save.read_text())
    assert len(traces) > 50
    missing = [t for t in traces if t not in names]
    assert not missing, f"not in {harness_waves.fst}: {missing}"
    assert "pgs_kernel.pgs_kernel.u_seq.l_go[0]" in traces and "pgs_kernel.pgs_kernel.trace_valid[0]" in traces


GTKWAVE, XVFB_RUN = shutil.which("gtkwave"), shutil.which("xvfb-run")
PROBE_TCL = """puts "PROBE start=[gtkwave::getWindowStartTime] end=[gtkwave::getWindowEndTime] \\
wavewidth=[gtkwave::getWaveWidth] marker=[gtkwave::getMarker] traces=[gtkwave::getTotalNumTraces] \\
unit=[gtkwave::getTimeDimension] named=[gtkwave::getNamedMarker {letter}]"
flush stdout
gtkwave::/File/Quit
"""


@pytest.mark.skipif(GTKWAVE is None or XVFB_RUN is None,
                    reason="gtkwave and xvfb-run not installed (Debian: apt-get install gtkwave xvfb)")
def test_gtkwave_opens_the_save_file_on_the_span_it_claims(harness_waves: HarnessWaves, tmp_path: Path) -> None:
    """GTKWave itself, under Xvfb, on the harness's save file: the visible time range (its Tcl
    getWindowStartTime / getWindowEndTime) is the one the save file claims, the primary and the SOLVE marker where
    the file puts them, every trace of the file shown."""
    text = harness_waves.save.read_text()
    saved = save_file_view(text)
    assert saved.claimed is not None
    start, end, _ = saved.claimed
    solve_letter = "ABCDEFGHIJKLMNOPQRSTUVWXYZ"[[n for n, _ in saved.named].index("SOLVE")]
    script = tmp_path / "probe.tcl"
    script.write_text(PROBE_TCL.format(letter=solve_letter))
    width, height = WINDOW_SIZE
    proc = subprocess.run([XVFB_RUN, "-a", "-s", f"-screen 0 {width}x{height}x24", GTKWAVE, "-S", str(script),
                           str(harness_waves.save)], capture_output=True, text=True, timeout=180,
                          env=dict(os.environ, HOME=str(tmp_path)))  # no ~/.gtkwaverc of the user
    m = re.search(r"^PROBE (.*)$", proc.stdout, re.MULTILINE)
    assert m, f"GTKWave printed no probe line (rc {proc.returncode}):\n{proc.stdout[-2000:]}\n{proc.stderr[-2000:]}"
    got = dict(kv.split("=", 1) for kv in m.group(1).split())
    shown_start, shown_end = int(got["start"]), int(got["end"])
    span = end - start
    assert got["unit"] == "p"
    # GTKWave rounds the start down to its time grid at this zoom (100 ps here): well under a clock period
    assert abs(shown_start - start) < harness_waves.period, got
    assert shown_end - shown_start == pytest.approx(span, rel=0.03), (got, "wave pane of", got["wavewidth"], "px")
    assert int(got["marker"]) == harness_waves.marks["SOLVE"] * harness_waves.period
    assert int(got["named"]) == int(got["marker"])
    groups = text.count("\n@800200\n")
    assert int(got["traces"]) == len(save_file_traces(text)) + 2 * groups, "GTKWave dropped traces it did not find"
