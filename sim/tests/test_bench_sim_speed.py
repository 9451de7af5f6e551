"""``make bench`` option checks (sim/bench.py): bad options end with one clear error, exit status 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from models.formats.number_format import FP32
from sim import bench
from sim.compile.kernel_build import COMPILE_PROFILES, KernelBuild


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
    (["--max-cycles", "-1"], "--max-cycles must be >= 0"),
    (["--baseline-exe", "/nonexistent/harness"], "--baseline-exe /nonexistent/harness: no such file"),
])
def test_bad_options_are_named(argv: list[str], message: str) -> None:
    with pytest.raises(ValueError, match=message.replace("[", r"\[").replace("]", r"\]")):
        bench.check_args(bench.parse_args(argv))


def test_main_reports_bad_options(capsys: pytest.CaptureFixture[str]) -> None:
    assert bench.main(["--profiles", "nosuch"]) == 2
    assert "error: --profiles: unknown ['nosuch']" in capsys.readouterr().err


def test_report_gives_build_and_speed_ratios_to_the_first_profile() -> None:
    """Build CPU and simulated cycles per CPU second, each against the first profile's; no build ratio when the
    first profile's build was already there (no CPU spent on it)."""
    def runs(profile: str, build_cpu_s: float, cpu_s: float) -> bench.ProfileRuns:
        return bench.ProfileRuns(profile, Path(profile), 10.0, build_cpu_s, 1000, [2.0, 4.0, 3.0], [cpu_s] * 3)

    lines = bench.report([runs("quick", 100.0, 2.0), runs("os", 250.0, 1.0)], "pile").splitlines()
    assert lines[2].split()[:7] == ["quick", "10.0", "100.0", "1.00x", "0.3", "0.5", "1.00x"]
    assert lines[3].split()[:7] == ["os", "10.0", "250.0", "2.50x", "0.3", "1.0", "2.00x"]
    built = bench.report([runs("quick", 0.2, 2.0), runs("os", 0.1, 1.0)], "pile").splitlines()
    assert built[3].split()[3] == "-"


def test_report_puts_a_baseline_harness_first() -> None:
    """A harness from another tree (--baseline-exe) is the reference column: each profile's speed is a ratio to it,
    and its row names the executable instead of compile flags."""
    base = bench.ProfileRuns(bench.BASELINE, Path("/old/harness"), 0.0, 0.0, 1000, [4.0] * 3, [4.0] * 3)
    new = bench.ProfileRuns("quick", Path("quick"), 10.0, 50.0, 1000, [2.0] * 3, [1.0] * 3)
    lines = bench.report([base, new], "pile").splitlines()
    assert lines[2].split()[0] == bench.BASELINE and lines[2].endswith("built elsewhere: /old/harness")
    assert lines[3].split()[6] == "4.00x" and lines[3].split()[3] == "-"
