"""make sweep with several designs: IMPULSE_STORES=onchip,records gives a row per design with the same golden
errors (the same solve) and each design's own cycles (the cycle model's of that job) and fit; bytes streamed from
the 1-iteration files equal the N-iteration files'; a resumed sweep's ladders solve only the counts still to do;
bad designs are refused before any work; --replot draws a finished sweep's csv again; the Pareto front keeps exactly
the non-dominated fitting points and says by how much it beats the thesis's designs."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any

import pytest

from models import scenes
from models.timing import cycle_model
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.formats.frame import save
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from models.published import thesis as baselines
from sim.report import pareto_front
from sim.report import sweep_plot
from sim import sweep as sim_sweep
from sim.parallel.executor import parse_executor
from sim.drive.harness_run import write_inputs
from sim.compile.kernel_build import KernelBuild, default_window
from sim.parallel.point_results import PointLog


@pytest.fixture(scope="module")
def frame_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    return save(frame, tmp_path_factory.mktemp("frames") / "pile_small.npz")


def _plan(frame_file: Path, *extra: str) -> tuple[list[sim_sweep.SweepPoint], str, dict[str, bytes]]:
    return sim_sweep.plan(sim_sweep.parse_args(["--frame", str(frame_file), "--mode", "model", *extra]))


def test_two_designs_share_the_solve_and_differ_in_cycles(frame_file: Path, tmp_path: Path) -> None:
    points, name, _ = _plan(frame_file, "--formats", "fp16", "--iters", "1,3", "--impulse-stores", "onchip,records")
    assert name.endswith("-onchip-records-model")
    assert sorted((p.impulse_store, p.iterations) for p in points) == [("onchip", 1), ("onchip", 3), ("records", 1),
                                                                        ("records", 3)]
    assert len({p.key for p in points}) == 4 and all(p.ladder == (1, 3) for p in points)
    exact = sim_sweep.frame_exact(points[0].frame, tmp_path, 600.0)
    rows = {(r["design"], r["iterations"]): r for r in (dataclasses.replace(p, exact=exact).run() for p in points)}
    for n in (1, 3):
        onchip, records = rows[("onchip", n)], rows[("records", n)]
        for col in sim_sweep.COLUMNS:
            if "_vs_" in col or col.endswith(("_rounding", "_iteration")):
                assert onchip[col] == records[col], col  # the same solve, bit for bit
        assert isinstance(onchip["max_dv_vs_exact"], float)
        assert "impulses in records" in sweep_plot.series(records) and sweep_plot.series(onchip) == "fp16"
        for row in (onchip, records):  # the small pile's memories: both streaming designs fit, by the same figures
            assert row["fits"] is True
            # at the pessimistic end of the estimate's band, one datapath per lane
            assert row["fit"] == ("FITS the zcu102: 42.6 points to spare at the pessimistic end (LUT 42.4% of usable "
                                  "85.0%) (LUT 35.8% (band 28.9%-42.4%), vendor-anchored 27.2%; FF 11.9% (band "
                                  "11.3%-13.1%), vendor-anchored 11.8%; DSP 9.6%, vendor-anchored 33.9%; BRAM36 "
                                  "2.2%)"), row["fit"]
            # the streaming control's deepest path fails 275 MHz by the estimate: the latency at the clock it allows
            assert row["timing"].startswith("fails 275 MHz (estimate)") and 0 < row["clock_mhz"] < 275
            assert row["ms_at_estimated_clock"] == pytest.approx(row["cycles"] / (row["clock_mhz"] * 1e6) * 1e3,
                                                                 rel=1e-3)
    job = KernelJob.from_frame(scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"]), FP16, SolverParams(3),
                               window=default_window(FP16, get_preset("zcu102").stream_bits))
    preset = get_preset("zcu102")
    assert rows[("onchip", 3)]["cycles"] == cycle_model.predict_job(job, preset).cycles
    assert rows[("records", 3)]["cycles"] == cycle_model.predict_job(job.impulses_travelling(), preset).cycles
    assert rows[("records", 3)]["bytes_streamed"] > rows[("onchip", 3)]["bytes_streamed"]  # the impulse writes
    sim_sweep.write_csv(list(rows.values()), tmp_path / "sweep.csv")  # --replot draws the csv's rows again
    again = sim_sweep.read_csv(tmp_path / "sweep.csv")
    assert [r["max_dv_vs_exact"] for r in again] == [r["max_dv_vs_exact"] for r in rows.values()]
    assert pareto_front.report(again) == pareto_front.report(list(rows.values()))
    assert sim_sweep.main(["--replot", str(tmp_path)]) == 0 and (tmp_path / "pareto.png").is_file()
    assert sim_sweep.main(["--replot", str(tmp_path / "nothing")]) == 2


@pytest.mark.parametrize("design", ["onchip", "records", "window-0", "window-4", "window-1", "window-records-5",
                                    "window-records-1"])
def test_stream_bytes_from_one_iteration(frame_file: Path, tmp_path: Path, design: str) -> None:
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    job = KernelJob.from_frame(frame, FP16, SolverParams(5))
    job = job.impulses_travelling() if "records" in design else job
    if design.startswith("window"):  # each fetch streams the window records again: 10 passes in 2, 3 or 10 fetches
        job = job.windowed(1024, fetch_passes=int(design.rsplit("-", 1)[1]) or None, lanes=2)
    kb = KernelBuild.for_job(job, get_preset("zcu102"))
    assert sim_sweep.model_stream_bytes(job, kb, tmp_path / "one") == sum(write_inputs(tmp_path / "all", job,
                                                                                      kb).values())


def test_resumed_sweep_solves_only_the_counts_left(frame_file: Path, tmp_path: Path) -> None:
    points, _, frames = _plan(frame_file, "--formats", "fp32,fp16", "--iters", "1,2,4")
    by_cost = sorted(points, key=lambda p: p.cost, reverse=True)  # the order the executor starts them in
    assert [(p.fmt, p.iterations) for p in by_cost] == [("fp32", 4), ("fp32", 2), ("fp32", 1), ("fp16", 4),
                                                        ("fp16", 2), ("fp16", 1)]  # one format, then the next
    exact = sim_sweep.frame_exact(points[0].frame, tmp_path, 600.0)
    log = PointLog(tmp_path / "points.jsonl")
    first = [p for p in points if p.iterations < 4]
    rows = sim_sweep.run_sweep(first, exact, parse_executor("local:1"), log, frames, "first")
    cut = sim_sweep.remaining_ladders(points, set(log.load()))
    assert {(p.fmt, p.iterations): p.ladder for p in cut if p.key not in log.load()} == {("fp32", 4): (4,),
                                                                                         ("fp16", 4): (4,)}
    assert [p.key for p in cut] == [p.key for p in points]  # the ladder is no part of a point's key
    resumed = sim_sweep.run_sweep(points, exact, parse_executor("local:1"), log, frames, "resumed")
    assert [r for r in resumed if r["iterations"] < 4] == rows
    alone = [dataclasses.replace(p, exact=exact, ladder=(p.iterations,)).run() for p in points]
    assert resumed == alone  # the ladder's rows are those of points solved alone


@pytest.mark.parametrize("stores, message", [("onchip,flash", "IMPULSE_STORES"), (",", "IMPULSE_STORES")])
def test_bad_designs_are_refused(frame_file: Path, stores: str, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        _plan(frame_file, "--formats", "fp32", "--iters", "1", "--impulse-stores", stores)


def test_window_designs_and_the_schedule(frame_file: Path) -> None:
    """The window kernel's two designs (impulses on chip, in the records) in one sweep, in the sweep order: each a
    point, the order in the sweep's name and in the points' keys (the hazard order keeps the keys it had)."""
    args = sim_sweep.parse_args(["--frame", str(frame_file), "--formats", "fp32", "--iters", "1",
                                 "--record-window", "64", "--impulse-stores", "onchip,records", "--schedule", "sweep"])
    points, name, _ = sim_sweep.plan(args)
    assert [p.impulse_store for p in points] == ["onchip", "records"] and {p.schedule for p in points} == {"sweep"}
    assert "-sweep-ring64" in name and "--schedule sweep" in points[0].command
    hazard = dataclasses.replace(points[0], schedule="hazard")
    assert hazard.key != points[0].key and "schedule" not in json.dumps(dataclasses.asdict(hazard)["source"])
    with pytest.raises(SystemExit):
        sim_sweep.parse_args(["--frame", str(frame_file), "--schedule", "spiral"])


def test_the_adders_and_the_inverse_inertia_reach_the_points(frame_file: Path) -> None:
    """--add-dsp and --inertia (make sweep ADD_DSP, INERTIA) reach every point, its key, its command and the sweep's
    name, and the job each point runs (the pile's cubes: the 1-word build); the defaults keep the keys they had."""
    base, _, _ = _plan(frame_file, "--formats", "fp32", "--iters", "1")
    points, name, _ = _plan(frame_file, "--formats", "fp32", "--iters", "1", "--add-dsp", "1", "--inertia", "scene")
    assert (points[0].add_dsp, points[0].inertia) == (1, "scene") and name.endswith("-dsp-adders-scene-inertia-model")
    assert "--add-dsp 1 --inertia scene" in points[0].command and points[0].key != base[0].key
    assert base[0].key == dataclasses.replace(base[0], add_dsp=0, inertia="build").key
    job = sim_sweep.kernel_job(KernelJob.from_frame(scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"]),
                                                    FP16, SolverParams(1)), points[0])
    assert job.add_dsp and job.inertia_words == 1


def _row(fmt: str, design: str, iterations: int, x: float, dv: float, fits: bool) -> dict[str, Any]:
    return {"format": fmt, "design": design, "iterations": iterations, "cycles_per_manifold_pass": x,
            "cycles": int(x * 100 * 2 * iterations), "manifolds": 100, "max_dv_vs_exact": dv,
            "max_dw_vs_exact": dv / 10, "fits": fits}


def test_pareto_front_and_dominance() -> None:
    rows = [_row("fp32", "onchip", 4, 2.5, 0.10, False),  # fast and accurate, but does not fit: not on the front
            _row("fp32", "records", 4, 2.7, 0.10, True),
            _row("fp16", "records", 4, 1.4, 0.12, True),
            _row("fp16", "records", 8, 2.6, 0.05, True),
            _row("fp16", "onchip", 8, 3.0, 0.06, True),  # dominated by fp16 records 8
            _row("fp16", "onchip", 4, 1.3, 0.12, False)]
    pts = pareto_front.design_points(rows, "max_dv_vs_exact")
    line = pareto_front.front(pts)
    assert [(p.x, p.y) for p in line] == [(1.4, 0.12), (2.6, 0.05)]
    thesis = pareto_front.thesis_points(rows, "max_dv_vs_exact")
    assert [t.x for t in thesis] == [f.cycles_per_manifold_pass for f in baselines.THESIS_FPGA.values()]
    assert [t.y for t in thesis] == [0.10, 0.12]  # the same format's 4-iteration error
    d32, d16 = pareto_front.dominance(pts, thesis)
    assert d32.at_error is not None and d32.at_error.x == 2.6  # error <= 0.10 first at 2.6 cycles/mp
    assert d32.at_cycles is not None and d32.at_cycles.y == 0.12  # at <= 2.03 cycles/mp only the 1.4 point
    assert d16.at_error is not None and d16.at_error.x == 1.4 and d16.at_cycles is not None and d16.at_cycles.y == 0.12
    text = pareto_front.report(rows)
    assert "cycles/mp against max |v - v_exact| over dynamic bodies (m/s): fitting designs' front (2 of 4 fitting " \
           "points, 6 in all)" in text and "thesis ZCU102 fp16" in text


def test_front_per_step_time() -> None:
    """On the step's time (cycles per manifold, iterations included) the thesis designs sit at their cycles over
    their 127,000 manifolds, and more iterations cost more."""
    rows = [{**_row("fp16", "records", n, 1.0 + 1 / n, 0.1 / n, True), "cycles": 1000 * n, "manifolds": 100}
            for n in (1, 2, 4)]
    step = pareto_front.AXES[1]
    pts = pareto_front.design_points(rows, "max_dv_vs_exact", step)
    assert [p.x for p in pts] == [10.0, 20.0, 40.0] and len(pareto_front.front(pts)) == 3
    (t16,) = pareto_front.thesis_points(rows, "max_dv_vs_exact", step)
    assert t16.x == baselines.THESIS_FPGA["fp16"].cycles / baselines.THESIS_MANIFOLDS
    assert len(pareto_front.front(pareto_front.design_points(rows, "max_dv_vs_exact"))) == 1  # per pass: 4 it wins
