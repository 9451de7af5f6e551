"""``make bench`` option checks (sim/bench_sim_speed.py): bad options end with one clear error, exit status 2."""

from __future__ import annotations

import pytest

from models.number_format import FP32
from sim import bench_sim_speed as bench
from sim.kernel_build import COMPILE_PROFILES, KernelBuild


def test_default_profiles_are_known_and_distinct() -> None:
    profiles = bench.check_args(bench.parse_args([]))
    assert len(profiles) == 2 and profiles[0] != profiles[1]
    assert all(p in COMPILE_PROFILES for p in profiles)


def test_each_profile_builds_apart() -> None:
    """The profile is a field of the build description: each one names a build directory of its own, the default
    keeps the historic name."""
    names = {p: KernelBuild(FP32, compile_profile=p).name for p in COMPILE_PROFILES}
    assert len(set(names.values())) == len(names), names
    assert names["quick"] == KernelBuild(FP32).name == "pgs_kernel_e8m23_c512"
    assert all(names[p] == f"pgs_kernel_e8m23_c512_{p}" for p in COMPILE_PROFILES if p != "quick")


@pytest.mark.parametrize("argv, message", [
    (["--profiles", "quick,nosuch"], "unknown ['nosuch']"),
    (["--profiles", "quick,quick"], "names a profile twice"),
    (["--profiles", ","], "none given"),
    (["--runs", "0"], "--runs must be in 1..100"),
    (["--iters", "0"], "--iters must be >= 1"),
    (["--format", "float64"], "not a kernel format"),
])
def test_bad_options_are_named(argv: list[str], message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        bench.check_args(bench.parse_args(argv))


def test_main_reports_bad_options(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--profiles", "nosuch"]) == 2
    assert "error: --profiles: unknown ['nosuch']" in capsys.readouterr().err
