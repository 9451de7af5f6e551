"""`make band` on the small scenes: the figures file carries D of every order and a budget per configuration;
bad input ends it with one error line and exit status 2."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from models.timing.platforms import PLATFORMS
from models.order.manifold_schedule import BANDED_ORDERS
from sim import band


def test_band_figures(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert band.main(["--scenes", "stack,pyramid", "--budget-scene", "pyramid", "--iters", "2",
                      "--out", str(tmp_path)]) == 0
    figures = json.loads((tmp_path / "band-s1.json").read_text())
    rows = {r["scene"]: r for r in figures["scenes"]}
    assert set(rows) == {"stack", "pyramid"}
    for r in rows.values():
        assert set(r["bands"]) == {"pybullet", *BANDED_ORDERS} and r["best"] in BANDED_ORDERS
        assert r["bands"][r["best"]]["D"] == min(r["bands"][n]["D"] for n in BANDED_ORDERS)
    # platforms x 3 formats x fetch periods {1, 2} x impulse placements
    assert len(figures["budget"]) == len(PLATFORMS) * 3 * 2 * 2 and all(b["fits"] for b in figures["budget"])
    out = capsys.readouterr().out
    assert "does not fit" not in out and "whole kernel (resource model, 1 lane; band and margin" in out
    # the like-for-like ratio of the vendor's fabric adder to Yosys's fp_add (sim/fit/generated/resource_figures.json)
    assert "band of the resource estimate: LUT logic x0.76: fadd no_dsp 338 LUT vs Yosys fp_add fp32 445" in out
    verdicts = [b["kernel_fit"] for b in figures["budget"]]
    assert all(v == "no estimate" or re.match(r"(FITS|FITS at the optimistic end only|DOES NOT FIT) \(\w+ [\d.]+%-"
                                             r"[\d.]+%, margin [+-][\d.]+ pt\)$", v) for v in verdicts), verdicts
    # the pyramid's 55 cubes: every window (one lane, the impulses on chip or in the records) fits both devices
    # at the pessimistic end of the band, with room to spare
    assert all(v.startswith("FITS (") and "margin +" in v for v in verdicts), verdicts


def test_band_bad_input(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert band.main(["--scenes", "nope", "--out", str(tmp_path)]) == 2
    assert "unknown scene 'nope'" in capsys.readouterr().err
    assert not (tmp_path / "band-s1.json").exists()
