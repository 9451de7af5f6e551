"""The kernel's waveforms: FST time in the platform's clock period, the save file's view and phase markers."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import pytest

from models import scenes
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP32
from sim.drive.gtkwave_save import (NAMED_MARKERS, VIEW_CYCLES, VIEW_LEAD_CYCLES, View, fst_times, kernel_view,
                                    read_phases, save_file_traces, save_file_view, write_kernel_save_file)
from sim.drive.harness_run import clock_period_ps, harness_cycle_limit, run_harness, write_inputs
from sim.compile.kernel_build import KernelBuild, build_kernel, default_window

P = 3636  # ps: 275 MHz
MARKS = [("IDLE", 1), ("start", 40), ("LOAD", 45), ("SOLVE", 300), ("DRAIN", 900), ("INTEG", 1000), ("DONE", 1200)]


def test_clock_period_comes_from_the_preset() -> None:
    assert clock_period_ps(get_preset("zcu102")) == P
    assert clock_period_ps(get_preset("u280")) == 3333


def test_kernel_view_opens_before_the_solve_phase_with_a_marker_at_each_phase() -> None:
    view = kernel_view(P, MARKS, end_time=1500 * P)
    assert view.start == (300 - VIEW_LEAD_CYCLES) * P and view.span == VIEW_CYCLES * P
    assert view.marker == 300 * P
    assert [name for name, _ in view.named] == ["start", "LOAD", "SOLVE", "DRAIN", "INTEG", "DONE"]
    assert dict(view.named)["INTEG"] == 1000 * P
    assert 2 ** -view.zoom * view.wave_pixels == pytest.approx(VIEW_CYCLES * P)


def test_kernel_view_keeps_only_the_markers_the_dump_holds() -> None:
    view = kernel_view(P, MARKS, end_time=950 * P)
    assert [name for name, _ in view.named] == ["start", "LOAD", "SOLVE", "DRAIN"]
    short = kernel_view(P, MARKS, end_time=350 * P)  # the view still ends inside the dump
    assert short.start + short.span <= 350 * P


def test_view_rejects_more_markers_than_gtkwave_has() -> None:
    with pytest.raises(ValueError, match="named markers"):
        View(0, 10, named=tuple((f"m{i}", i) for i in range(NAMED_MARKERS + 1)))


def _fst_header(start: int, end: int, timescale: int) -> bytes:
    return (bytes([0]) + struct.pack(">QQQ", 329, start, end) + struct.pack("<d", 1.0) + struct.pack(">5Q", 0, 1, 2, 3, 1)
            + struct.pack(">b", timescale) + bytes(255))


def test_fst_times_reads_the_header_block(tmp_path: Path) -> None:
    f = tmp_path / "x.fst"
    f.write_bytes(_fst_header(0, 123 * P + P // 2, -12))
    t = fst_times(f)
    assert (t.start, t.end, t.timescale) == (0, 123 * P + P // 2, -12)
    f.write_bytes(b"\x01" + bytes(100))
    with pytest.raises(ValueError, match="not an FST"):
        fst_times(f)


def test_harness_waves_run_in_clock_periods_and_open_on_the_solve_phase(tmp_path: Path) -> None:
    """A waves build of the harness on the stack scene: the FST's unit is ps, its last time a rising edge at
    clock-period steps, the .phases file names each phase, the save file opens on the solve phase."""
    preset = get_preset("zcu102")
    frame = scenes.load_or_capture("stack", seed=1)
    job = KernelJob.from_frame(frame, FP32, SolverParams(iterations=2), "hazard", default_window(FP32, preset.stream_bits))
    kb = KernelBuild(FP32, cons_bits=preset.stream_bits, waves=True, compile_profile="o0")
    exe, _ = build_kernel(kb)
    write_inputs(tmp_path, job, kb)
    fst = tmp_path / "waves.fst"
    regs = run_harness(exe, tmp_path, 1, preset, harness_cycle_limit(job),
                       env=dict(os.environ, PGS_WAVES=str(fst), PGS_WAVE_CYCLES="0"))
    period = clock_period_ps(preset)
    times = fst_times(fst)
    assert times.timescale == -12 and times.start == 0
    assert times.end % period == period // 2
    clock_ps, marks = read_phases(tmp_path / "waves.phases")
    assert clock_ps == period
    names = [name for name, _ in marks]
    assert all(p in names for p in ("start", "LOAD", "SOLVE", "DRAIN", "INTEG", "DONE"))
    cycle = dict(marks)
    assert cycle["start"] < cycle["LOAD"] < cycle["SOLVE"] < cycle["DRAIN"] < cycle["INTEG"] < cycle["DONE"]
    # the whole run is dumped: the last edge is a few cycles (register reads) after the kernel finished
    assert cycle["DONE"] * period < times.end
    assert cycle["DONE"] - cycle["start"] <= regs["harness_cycles"] + 100
    text = write_kernel_save_file(fst, top="pgs_kernel.pgs_kernel", parameters=kb.parameters).read_text()
    start, zoom, named = save_file_view(text)
    assert start == (cycle["SOLVE"] - VIEW_LEAD_CYCLES) * period
    assert dict(named)["SOLVE"] == cycle["SOLVE"] * period and all(t % period == 0 for _, t in named)
    assert "[size] " in text and save_file_traces(text)
