"""The warm-start price: errors against the exact reference cold and warm on a step captured through the loop, the
records design's cycles, the speed-against-error plot, and bad warm-start input on the priced path."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from models.closed_loop.loop import run_closed_loop
from models.golden.contact_solver import Impulses, SolverParams
from models.exact.reference import exact_reference
from models.formats.number_format import FLOAT64, FP16, FP32
from models.golden.contact_solver import solve
from models.order.manifold_schedule import make_schedule
from models.golden.warm_start import apply_impulses
from models.scenes.frame_cache import load_or_capture
from models.timing.cycle_model import predict_job
from models.timing.platforms import get_preset
from sim.compile.kernel_build import default_window
from sim.remedies.remedy_price import (ERROR_KEYS, SHOCK_HAZARD_SUFFIX, SHOCK_SUFFIX, capture, capture_from_frames,
                                       main, price, shock_job, solve_series, verdict)

TINY = ["--scene", "stack", "--scene-args", "n=4", "--settle", "0", "--steps", "12", "--iters", "1,4"]


def _stack_step():
    last, report = capture("stack", 0, 12, 4, 0.85, n=4)
    return last, report, exact_reference(last.bodies, last.cons, SolverParams())


def test_price_of_a_warm_start_on_a_resting_stack() -> None:
    last, report, ref = _stack_step()
    assert report["matched points"] > 0
    for fmt in (FP32, FP16):
        rows = price(last, fmt, [1, 4], ref)
        assert [(r["remedy"], r["iterations"]) for r in rows] == [("cold", 1), ("warm", 1), ("cold", 4), ("warm", 4)]
        by = {(r["remedy"], r["iterations"]): r for r in rows}
        assert by["cold", 1]["cycles"] < by["cold", 4]["cycles"]
        for it in (1, 4):
            print(fmt.name, by["cold", it], by["warm", it])
            assert by["warm", it]["max |dv|"] < by["cold", it]["max |dv|"]
            assert by["warm", it]["cycles"] == by["cold", it]["cycles"]  # the same records, no extra beat
            assert all(np.isfinite(by["warm", it][k]) for k in ERROR_KEYS)
        # the resting stack's warm start: lower on all six error figures at the same cycles, the target met
        [line] = verdict(rows, 4, 4)
        assert line.startswith(f"{fmt.name}: warm 4 max |dv| ") and "lower in 6 of 6" in line, line
        assert "cycles warm 4 / cold 4 1.0000" in line and line.endswith("cycles) MET"), line


@pytest.mark.parametrize("fmt", [FP32, FP16])
def test_the_series_of_iteration_counts_is_the_solve_of_each_bit_for_bit(fmt) -> None:
    last, _, _ = _stack_step()
    bodies, cons = last.bodies.rounded(fmt), last.cons.rounded(fmt)
    order = make_schedule("hazard", cons, bodies.dynamic, 8)
    initial = Impulses(fmt.round(last.initial.normal), fmt.round(last.initial.friction))
    warm = apply_impulses(bodies, cons, initial, fmt)
    for start, init in ((bodies, None), (warm, initial)):
        series = solve_series(start, cons, order, fmt, [1, 2, 3, 8], init)
        assert sorted(series) == [1, 2, 3, 8]
        for it, got in series.items():
            want = solve(start, cons, order, fmt, SolverParams(iterations=it), initial=init).bodies
            for f in ("linear_velocity", "angular_velocity"):
                assert np.array_equal(getattr(got, f), getattr(want, f)), (it, f)
        assert not np.array_equal(series[1].linear_velocity, series[8].linear_velocity)


def test_the_verdict_compares_warm_against_more_cold_iterations() -> None:
    row = {k: 1.0 for k in ERROR_KEYS}
    rows = [{"format": "fp16", "remedy": "cold", "iterations": 4, **row, "cycles": 100},
            {"format": "fp16", "remedy": "cold", "iterations": 8, **row, "max |dv|": 0.5, "cycles": 200},
            {"format": "fp16", "remedy": "warm", "iterations": 4, **row, "max |dv|": 0.4, "cycles": 104}]
    assert verdict(rows)[0].endswith("cycles) MET") and "warm 4 / cold 4 1.0400" in verdict(rows)[0]
    rows[2]["cycles"] = 106  # more than 5% extra cycles
    assert verdict(rows)[0].endswith("cycles) MISSED")
    rows[2]["cycles"], rows[2]["max |dv|"] = 100, 0.6  # not lower than cold 8
    assert verdict(rows)[0].endswith("cycles) MISSED")


def test_bad_warm_start_impulses_on_the_priced_path_are_refused() -> None:
    last, _, ref = _stack_step()
    m = last.cons.num_manifolds
    short = replace(last, initial=Impulses(last.initial.normal[:-1], last.initial.friction[:-1]))
    with pytest.raises(ValueError, match=rf"for {m} manifolds \(expected \({m}, 4\)"):
        price(short, FP32, [1], ref)
    nan = last.initial.normal.copy()
    nan[1, 0] = np.nan
    with pytest.raises(ValueError, match="not finite in 1 manifold"):
        price(replace(last, initial=Impulses(nan, last.initial.friction)), FP32, [1], ref)


def test_the_plot_the_report_and_the_step_cache(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    png = tmp_path / "price.png"
    assert main(TINY + ["--format", "fp32,fp16", "--cache-dir", str(tmp_path), "--plot", str(png)]) == 0
    out = capsys.readouterr().out
    assert png.stat().st_size > 10_000 and png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the warm start's matching reaches the report, every drop reason counted (zero where none)
    for reason in ("matched points", "new points", "dropped: point no longer exists",
                   "dropped: manifold no longer exists", "dropped: non-finite value"):
        assert reason in out
    assert "step captured" in out and out.count("cycles) M") == 0  # 1,4 iterations: no cold 8 to compare with
    assert len(list(tmp_path.glob("remedy_step_*.npz"))) == 1 and len(list(tmp_path.glob("exact_*.npz"))) == 1
    assert main(TINY + ["--cache-dir", str(tmp_path)]) == 0
    assert "step from the cache" in capsys.readouterr().out
    next(tmp_path.glob("remedy_step_*.npz")).write_bytes(b"truncated")  # unusable: captured again
    assert main(TINY + ["--cache-dir", str(tmp_path)]) == 0
    assert "step captured" in capsys.readouterr().out


def test_a_cold_capture_or_bad_arguments_are_refused() -> None:
    cold = run_closed_loop("stack", 2, FLOAT64, 4, n=2).extra["last step"]
    with pytest.raises(ValueError, match="no warm-start impulses"):
        price(cold, FP32, [1], exact_reference(cold.bodies, cold.cons, SolverParams()))
    assert main(["--steps", "1"]) == 2
    assert main(["--iters", "0"]) == 2
    assert main(["--format", "fp99"]) == 2
    assert main(["--preset", "nope"]) == 2
    assert main(["--more-factors", "1.5"]) == 2 and main(["--factor", "0"]) == 2


def test_the_shock_variant_is_its_own_curve_priced_in_its_layer_order() -> None:
    """--shock: each warm remedy's one-call shock variant (the last contact pass a linear shock pass, the frozen rows'
    impulses returned) is its own curve, priced by the cycle model in the step's ground-up order."""
    last, _, ref = _stack_step()
    rows = price(last, FP32, [1, 4], ref, shock=True)
    by = {(r["remedy"], r["iterations"]): r for r in rows}
    assert {r["remedy"] for r in rows} == {"cold", "warm", "warm" + SHOCK_SUFFIX, "warm" + SHOCK_HAZARD_SUFFIX}
    bodies, cons = last.bodies.rounded(FP32), last.cons.rounded(FP32)
    window = default_window(FP32, get_preset("zcu102").stream_bits)
    order = make_schedule("hazard", cons, bodies.dynamic, window)
    for it in (1, 4):
        for suffix, w in ((SHOCK_SUFFIX, 0), (SHOCK_HAZARD_SUFFIX, window)):
            job = shock_job(FP32, bodies, cons, order, it, w)
            assert job.params.shock_contact and job.params.shock_impulses == "return" and job.cons.linear
            assert by["warm" + suffix, it]["cycles"] == predict_job(job, get_preset("zcu102")).cycles
            assert by["warm" + suffix, it]["max |dv|"] != by["warm", it]["max |dv|"]
    assert len(verdict(rows, 4, 4)) == 3  # one line per warm remedy, the shock variants' included


def test_further_warm_start_factors_are_their_own_remedies() -> None:
    last, _, ref = _stack_step()
    rows = price(last, FP32, [1, 4], ref, warm={"warm": 1.0, "warm1": 1.0 / 0.85})
    by = {(r["remedy"], r["iterations"]): r for r in rows}
    assert {r["remedy"] for r in rows} == {"cold", "warm", "warm1"}
    assert by["warm", 4] == {**by["warm", 4], **price(last, FP32, [4], ref)[1]}  # the default warm, bit for bit
    assert by["warm1", 1]["max |dv|"] != by["warm", 1]["max |dv|"]
    assert len(verdict(rows, 1, 4)) == 2  # one line per warm remedy
    with pytest.raises(ValueError, match="positive and finite"):
        price(last, FP32, [1], ref, warm={"warm": float("nan")})


def test_points_that_no_longer_exist_are_counted_in_the_report(tmp_path: Path,
                                                               capsys: pytest.CaptureFixture[str]) -> None:
    """A falling box bounces: some remembered points are not in the next step's manifold; the report counts them."""
    assert main(["--scene", "impact", "--settle", "0", "--steps", "8", "--iters", "1", "--cache-dir",
                 str(tmp_path)]) == 0
    out = capsys.readouterr().out
    gone = int(out.split("dropped: point no longer exists ")[1].split()[0].rstrip(",").replace(",", ""))
    new = int(out.split("new points ")[1].split(",")[0].replace(",", ""))
    print(out)
    assert gone > 0 and new > 0


def test_the_captured_frame_warm_started_from_the_step_before(tmp_path: Path) -> None:
    """--from-frames prices the very frame the frame cache holds (what make sim reports on), its warm start matched
    from our solve of the frame one step earlier."""
    last, report = capture_from_frames("stack", None, 4, 0.85, tmp_path, n=4)
    frame = load_or_capture("stack", seed=1, cache_dir=tmp_path, n=4)  # make sim's seed, remedy_price's default
    assert np.array_equal(last.bodies.position, frame.position) and last.cons.num_manifolds == frame.num_manifolds
    assert report["matched points"] == int(frame.num_points.sum()) and report["new points"] == 0
    assert np.all(last.initial.normal >= 0) and last.initial.normal.sum() > 0
    assert len(list(tmp_path.glob("stack_*.npz"))) == 2  # the frame and the one before, cached
    with pytest.raises(ValueError, match="no 1 earlier step"):
        capture_from_frames("stack", 1, 4, 0.85, tmp_path, n=4)
    assert main(["--scene", "stack", "--scene-args", "n=4", "--from-frames", "--step", "1", "--cache-dir",
                 str(tmp_path)]) == 2


def test_a_cached_step_with_bad_impulses_is_refused_before_the_exact_reference(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from sim.remedies.remedy_step_cache import load_step, save_step

    assert main(TINY + ["--cache-dir", str(tmp_path)]) == 0
    path = next(tmp_path.glob("remedy_step_*.npz"))
    for exact in tmp_path.glob("exact_*.npz"):
        exact.unlink()
    step, report = load_step(path)
    normal = step.initial.normal.copy()
    normal[0, 0] = np.nan
    save_step(replace(step, initial=Impulses(normal, step.initial.friction)), report, path)
    capsys.readouterr()
    assert main(TINY + ["--cache-dir", str(tmp_path)]) == 1
    assert "not finite in 1 manifold" in capsys.readouterr().err
    assert not list(tmp_path.glob("exact_*"))  # nothing solved, nothing written
