"""python -m sim.studies.exact_survey: one line per world (bodies, manifolds, seconds, residual, method or the reason
there is no reference) and a summary; exit status 1 when a world has no reference."""

from __future__ import annotations

import pytest

from sim.studies import exact_survey


def test_survey_prints_a_line_per_world_and_sums_up(capsys: pytest.CaptureFixture[str]) -> None:
    assert exact_survey.main(["--scenes", "stack,incline", "--seeds", ""]) == 0
    out = capsys.readouterr().out.splitlines()
    stack = next(line for line in out if line.startswith("stack "))
    incline = next(line for line in out if line.startswith("incline "))
    assert stack.split()[1:3] == ["11", "10"] and stack.endswith("QP")
    assert float(stack.split()[4]) <= 1e-9
    assert "Gauss-Seidel 1; unique" in incline  # the incline's damped direction: the non-symmetric problem, a P-matrix
    assert out[-1].startswith("2 of 2 worlds have an exact reference")


def test_a_world_without_a_reference_gives_its_reason_and_exit_status_1(capsys: pytest.CaptureFixture[str]) -> None:
    assert exact_survey.main(["--scenes", "stack", "--seeds", "", "--budget", "0"]) == 1
    out = capsys.readouterr().out
    assert "no exact reference (time budget of 0 s spent" in out and "0 of 1 worlds" in out
    assert exact_survey.main(["--scenes", "stack", "--seeds", "", "--budget", "0", "--allow-missing"]) == 0


def test_worlds_named_by_group() -> None:
    got = exact_survey.worlds("builtin,assets,docs/jenga_heap_world.py", "3-4")
    assert ("pile", "") in got and ("thesis", "") not in got
    assert ("jenga_tower", "") in got and ("random_world", "") not in got
    assert got[-3:] == [("docs/jenga_heap_world.py", ""), ("random_world", "seed=3"), ("random_world", "seed=4")]
