"""make claims (sim/claims.py) and its data (docs/claims.toml): the README's headline table is the data file's
rendering, every run is a make sim command, and the checker passes a figure that rounds to the stated one, fails
one that does not or whose run broke, and exits 1 then (the runs themselves are make claims's, not the suite's)."""

from __future__ import annotations

import dataclasses
import re
from pathlib import Path

import pytest

from models.published import thesis
from sim import claims as cl
from sim.fit import estimate_band as eb
from sim.fit import delays
from sim.fit import resource_model as rm
from sim.fit import timing_estimate as te
from sim.report.run_result import BitExactness, RunResult
from sim.run import MAKE_SIM_OPTIONS, make_sim_argv, parse_args
from sim.tests.test_run_result import EXACT, _result

REPO = Path(__file__).resolve().parents[2]


def test_readme_headline_table_is_the_claims_file() -> None:
    lines = REPO.joinpath("README.md").read_text().splitlines()
    want = cl.readme_lines(cl.load_claims())
    start = lines.index(cl.TABLE_HEADER[0])
    assert lines[start:start + len(want)] == want, "README.md's headline results differ from docs/claims.toml"
    assert len(cl.load_claims().rows) == 6


def test_every_run_is_a_make_sim_command_and_the_makefile_passes_each_variable() -> None:
    claims = cl.load_claims()
    for command in claims.runs.values():
        parse_args(make_sim_argv(command))  # options sim.run takes
    assert make_sim_argv("make sim SCENE=thesis FORMAT=fp16 LANES=2") == ["--scene", "thesis", "--format", "fp16",
                                                                          "--lanes", "2"]
    recipe = REPO.joinpath("Makefile").read_text().split("\nsim: ")[1].split("\n\n")[0]
    for var, option in MAKE_SIM_OPTIONS.items():
        assert re.search(rf"{option} \"?\$\({var}\)", recipe), f"make sim passes {var} as {option}?"
    for bad in ("make test", "make sim SCENE", "make sim COLOR=red"):
        with pytest.raises(ValueError):
            make_sim_argv(bad)


def _timing(mhz: float) -> te.TimingVerdict:
    """A timing estimate of the ZCU102 whose deepest path allows ``mhz``."""
    worst = te.TimedPath("control", 1e3 / mhz - delays.FIGURES.clock_uncertainty, 30, 0, 0, 0, "a", "b", "")
    return te.TimingVerdict("zcu102", delays.budget(275e6), [worst], {})


def _run(fmt: str, cycles: int, manifolds: int, lut: float, max_dv: float, bits: int = 0,
         bram: float = 0.1, lut_high: float | None = None, mhz: float = 275.0) -> RunResult:
    """A make sim result whose figures are these (the rest from test_run_result's example); the band's pessimistic
    ends are the estimate's, the LUT's ``lut_high`` where given."""
    result = _result(BitExactness(bits, bits, manifolds * 8, 11, "record 3" if bits else "", 1))
    result.speed = dataclasses.replace(result.speed, fmt=fmt, cycles=cycles, manifold_passes=manifolds * 8)
    result.scene = dataclasses.replace(result.scene, manifolds=manifolds)
    result.model_agrees = True
    shares = dict.fromkeys(rm.KEYS, 0.1) | {"LUT": lut, "BRAM36": bram}
    result.fit = rm.FitVerdict(rm.platforms.get_platform("zcu102"), rm.Resources(), shares, dict(rm.platforms.USABLE_SHARE),
                               "window")
    result.band = _band(shares, high=1.0, lut_high=lut_high)
    result.timing = _timing(mhz)
    ours = dataclasses.replace(EXACT.ours, max_dv=max_dv)
    result.errors = dataclasses.replace(result.errors, vs_exact=dataclasses.replace(EXACT, ours=ours))
    return result


def _band(shares: dict[str, float], high: float, lut_high: float | None = None) -> eb.BandVerdict:
    """A band verdict around ``shares``: each optimistic end 10% below the estimate, each pessimistic end ``high``
    times it (the LUT's ``lut_high`` where given)."""
    usable = rm.platforms.USABLE_SHARE
    ends = {k: high * v for k, v in shares.items()} | ({"LUT": lut_high} if lut_high is not None else {})
    return eb.BandVerdict(rm.platforms.get_platform("zcu102"), {
        k: eb.BandedShare(k, v, v, 0.9 * v, ends[k], usable[k]) for k, v in shares.items()}, "window")


MHZ = {"fp32": 135.2, "fp16": 135.2}  # the clock each headline design's timing estimate supports (docs/claims.toml)
RUNS = {"thesis-fp32": _run("fp32", 2_299_084, 147_485, 0.5, 0.0939),
        "thesis-fp16": _run("fp16", 1_500_581, 147_485, 0.5, 0.0939),
        "thesis-bf16": _run("bf16", 1_494_499, 147_485, 0.5, 0.0939),
        "fitting-fp32": _run("fp32", 1_397_586, 147_485, 0.6591, 0.08364, bram=0.8383,
                              lut_high=0.7391, mhz=MHZ["fp32"]),
        "fitting-fp16": _run("fp16", 783_984, 147_485, 0.6182, 0.08346, bram=0.8569,
                              lut_high=0.7410, mhz=MHZ["fp16"]),
        "jenga": _run("fp32", 10_633, 100, 0.1, 0.01), "duck-lego": _run("fp32", 4_906, 100, 0.1, 0.01)}


def test_every_figure_passes_on_the_stated_runs(capsys: pytest.CaptureFixture[str]) -> None:
    assert cl.main([], source=lambda name, command: RUNS[name]) == 0
    out = capsys.readouterr().out
    lines = [ln for ln in out.splitlines() if ln.startswith(("PASS", "FAIL"))]
    assert lines and all(ln.startswith("PASS") for ln in lines)
    assert "PASS  fitting fp32 design / speedup: fitting-fp32: measured 1.71, stated 1.71   [make sim SCENE=thesis " \
           "SCHEDULE=sweep RECORD_WINDOW=8192 IMPULSE_STORE=records BODY_BITS=256 ADD_DSP=1 INERTIA=scene]" in lines
    assert f"{thesis.THESIS_FPGA['fp32'].cycles_per_manifold_pass:.2f}" == "2.03"
    assert sum(ln.startswith("PASS  RTL = golden model / records") for ln in lines) == 3  # one per format's run


def test_a_figure_off_by_its_last_digit_or_a_broken_run_fails(capsys: pytest.CaptureFixture[str]) -> None:
    runs = dict(RUNS)
    runs["fitting-fp16"] = _run("fp16", 783_985, 147_485, 0.6182, 0.08346, bram=0.8569, lut_high=0.7410,
                                 mhz=MHZ["fp16"])  # a cycle more
    runs["thesis-bf16"] = _run("bf16", 1_494_499, 147_485, 0.5, 0.0939, bits=3)

    def source(name: str, command: str) -> RunResult:
        if name == "jenga":
            raise RuntimeError("the harness stopped")
        return runs[name]

    assert cl.main([], source=source) == 1
    out = capsys.readouterr().out
    assert "FAIL  fitting fp16 design / cycles: fitting-fp16: measured 783,985, stated 783,984" in out
    assert "FAIL  fitting fp16 design / per_pass: fitting-fp16: measured 0.6645" not in out  # still 0.6645
    assert "FAIL  RTL = golden model / differing: thesis-bf16: measured 3, stated 0" in out
    assert "FAIL  user worlds / jenga: jenga: measured none (the run failed: the harness stopped)" in out
    # fitting-fp16 cycles, thesis-bf16 bits, the broken run's three (cycles, bits, cycle model)
    assert re.search(r"\d+ of \d+ figures PASS, 5 FAIL", out), out[-500:]
    assert cl.main(["--runs", "duck-lego"], source=lambda n, c: RUNS[n]) == 0  # only the figures of that run


def test_a_bad_claims_file_or_run_name_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    good = cl.CLAIMS_FILE.read_text()
    for damage, word in ((lambda s: s.replace('measure = "cycles"', 'measure = "speed"', 1), "unknown measure"),
                         (lambda s: s.replace("{cycles} cycles, {per_pass}", "{cycle} cycles, {per_pass}", 1),
                          "which no figure is"),
                         (lambda s: s.replace('runs = ["jenga"]', 'runs = ["tower"]'), "no run named tower"),
                         (lambda s: s.replace("make sim SCENE=jenga_tower", "make sim TOWER=jenga", 1),
                          "not one of make sim's variables")):
        path = tmp_path / "claims.toml"
        path.write_text(damage(good))
        assert cl.main(["--claims", str(path), "--list"]) == 2
        assert word in capsys.readouterr().err
    assert cl.main(["--runs", "nope", "--list"]) == 2
    assert cl.main(["--list"]) == 0 and "fitting-fp16: make sim SCENE=thesis" in capsys.readouterr().out


def test_fits_is_the_band_verdict_at_its_pessimistic_end() -> None:
    """"fits" in a claim means what make sim's verdict says: every resource's pessimistic end within its usable share,
    not the Yosys estimate alone; a run without the band has no "fits" figure."""
    run = _run("fp32", 1_436_467, 147_485, 0.80, 0.08364, bram=0.90)
    assert run.fit.fits and cl.MEASURES["fits"](run) is True  # type: ignore[union-attr]
    assert cl.MEASURES["fit_margin_points"](run) == pytest.approx(100 * (0.95 - 0.90))
    run.band = _band(run.fit.shares, high=1.10)  # type: ignore[union-attr]
    # the Yosys estimate still fits (LUT 80%, BRAM36 90%); the pessimistic end does not (LUT 88%, BRAM36 99%)
    assert run.fit.fits and cl.MEASURES["fits"](run) is False  # type: ignore[union-attr]
    assert cl.MEASURES["fit_margin_points"](run) == pytest.approx(100 * (0.95 - 0.99))
    run.band = None
    with pytest.raises(ValueError, match="no fit verdict with the estimate's band"):
        cl.MEASURES["fits"](run)


def test_timing_is_the_clock_the_estimate_supports() -> None:
    """A design that fails its clock is quoted at the clock its deepest path allows, one that meets it at the
    platform's; a run without an estimate has no timing figure."""
    assert cl.MEASURES["timing_mhz"](_run("fp32", 1, 1, 0.5, 0.1, mhz=80.4)) == 80
    assert cl.MEASURES["timing_mhz"](_run("fp32", 1, 1, 0.5, 0.1, mhz=300.0)) == 275
    run = _run("fp32", 1, 1, 0.5, 0.1)
    run.timing = te.NoTiming("no figures")
    with pytest.raises(ValueError, match="no timing estimate"):
        cl.MEASURES["timing_mhz"](run)
