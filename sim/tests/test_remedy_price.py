"""The warm-start price: errors against the exact reference cold and warm on a step captured through the loop."""

from __future__ import annotations

import pytest

from models.closed_loop import run_closed_loop
from models.number_format import FLOAT64, FP32
from sim.remedy_price import capture, main, price


def test_price_of_a_warm_start_on_a_resting_stack() -> None:
    last, report = capture("stack", 0, 12, 4, 0.85, n=4)
    assert report["matched points"] > 0
    rows = price(last, FP32, [1, 4])
    assert [r["iterations"] for r in rows] == [1, 4] and rows[0]["cycles"] < rows[1]["cycles"]
    for r in rows:
        print(r)
        assert r["warm max |dv|"] < r["cold max |dv|"]


def test_a_cold_capture_or_bad_arguments_are_refused() -> None:
    cold = run_closed_loop("stack", 2, FLOAT64, 4, n=2).extra["last step"]
    with pytest.raises(ValueError, match="no warm-start impulses"):
        price(cold, FP32, [1])
    assert main(["--steps", "1"]) == 2
    assert main(["--iters", "0"]) == 2
