"""SCENE_ARGS reach ``make analyze`` and ``make bench`` as they reach ``make sim``: the scene is built with them,
the runs are named after them, and a bad one ends with one clear error (exit status 2), nothing written."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from sim import analyze
from sim import bench

REPO = Path(__file__).resolve().parents[2]


def test_analyze_takes_scene_args(tmp_path: Path) -> None:
    assert analyze.main(["--scene", "stack", "--scene-args", "n=3", "--out", str(tmp_path)]) == 0
    report = json.loads((tmp_path / "stack-n3-s1" / "analysis.json").read_text())
    assert report["scene"]["scene"] == "stack-n3" and report["scene"]["bodies"] == 4  # the ground and 3 cubes


def test_analyze_refuses_a_bad_scene_arg(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert analyze.main(["--scene", "stack", "--scene-args", "nosuch=3", "--out", str(tmp_path / "out")]) == 2
    assert "unknown parameter 'nosuch' for scene 'stack'" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_bench_takes_scene_args() -> None:
    args = bench.parse_args(["--scene", "stack", "--scene-args", "n=3"])
    job, label = bench.scene_job(args, bench.get_preset(args.dma))
    assert label == "stack-n3" and job.bodies.num_bodies == 4


def test_bench_refuses_a_bad_scene_arg(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--scene", "stack", "--scene-args", "n=x"]) == 2
    assert "parameter n of scene 'stack' must be an integer" in capsys.readouterr().err


@pytest.mark.parametrize("target, module", [("analyze", "sim.analyze"), ("bench", "sim.bench")])
def test_make_passes_scene_args(target: str, module: str) -> None:
    dry = subprocess.run(["make", "-n", target, 'SCENE_ARGS=n=3 mass=2'], cwd=REPO, text=True,
                         capture_output=True, check=True).stdout
    line = next(x for x in dry.splitlines() if f"-m {module}" in x)
    assert '--scene-args "n=3 mass=2"' in line
