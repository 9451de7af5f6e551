"""The scene analyzer: ranges, exponent widths, the narrowest kernel format and per-group storage formats."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from models.sizing import format_analyzer as fa
from models import scenes
from models.golden.contact_solver import solve
from models.formats.number_format import FLOAT64, FP32, NumberFormat
from sim.analyze import main as analyze_main
from models.sizing.format_analyzer import problem_of


def test_exp_bits_for() -> None:
    assert fa.exp_bits_for(3e-5, 450.0) == 6  # the thesis's range: fp16's 5 bits stop at 6.1e-5
    assert fa.exp_bits_for(1e-4, 450.0) == 5
    assert fa.exp_bits_for(1e-30, 1.0) == 8
    assert fa.exp_bits_for(0.0, 0.0) == 2


@pytest.fixture(scope="module")
def pile() -> fa.StepProblem:
    return problem_of(scenes.capture_frame("pile", nx=4, ny=3, nz=4, seed=2), 4)


def test_ranges_cover_every_group(pile: fa.StepProblem) -> None:
    solved = solve(pile.bodies, pile.cons, pile.schedule, FLOAT64, pile.params)
    ranges = {r.group: r for r in fa.measure_ranges(pile.bodies, pile.cons, solved.impulses.normal,
                                                    solved.impulses.friction)}
    assert set(ranges) == set(fa.GROUPS) | {fa.IMPULSES}
    for r in ranges.values():
        assert 0 < r.min_abs <= r.p01_abs <= r.max_abs
    assert ranges["positions"].max_abs == pytest.approx(50.0)  # the ground box's centre


def test_narrowest_uniform_is_within_budget_and_tight(pile: fa.StepProblem) -> None:
    budget = 0.01
    fmt, err = fa.narrowest_uniform(pile, 6, budget)
    assert fmt is not None and err <= budget
    narrower = NumberFormat("n", 6, fmt.man_bits - 1)
    assert pile.error(pile.step(narrower)) > budget
    assert pile.error(pile.step(FP32)) < 1e-3
    parts = pile.error_parts(pile.step(fmt))
    assert set(parts) == {"velocity", "position", "orientation"} and max(parts.values()) == err


def test_mixed_storage_fits_the_budget(pile: fa.StepProblem) -> None:
    storage = {"velocities": NumberFormat("e6m4", 6, 4), "solver coefficients": NumberFormat("e5m3", 5, 3)}
    fitted, err = fa.fit_mixed(pile, FP32, storage, 0.01)
    assert err <= 0.01 and all(fitted[g].man_bits >= storage[g].man_bits for g in storage)
    assert fa.record_bits({}, FP32) == {"contact": 64 + 23 * 32, "friction": 64 + 14 * 32, "body-in": 17 * 32}
    narrow = fa.record_bits({"velocities": NumberFormat("e6m9", 6, 9)}, FP32)  # 16-bit words for 6 of body-in's 17
    assert narrow == {"contact": 64 + 23 * 32, "friction": 64 + 14 * 32, "body-in": 11 * 32 + 6 * 16}


def test_make_analyze_writes_the_report(tmp_path: Path) -> None:
    assert analyze_main(["--scene", "incline", "--out", str(tmp_path)]) == 0
    report = json.loads(next(tmp_path.glob("*/analysis.json")).read_text())
    auto = report["one format for the kernel (FORMAT=auto)"]
    assert auto["error"] <= 0.01 and auto["format"].startswith("e")
    assert analyze_main(["--scene", "incline", "--budget", "2", "--out", str(tmp_path / "bad")]) == 2
    assert not (tmp_path / "bad").exists()
