"""make sim's typed result (sim/report/run_result.py): what decides the exit status, and the sections it renders into
(the one form the summary and report.md/json are written from), in order."""

from __future__ import annotations

import dataclasses
from typing import Union

from models.exact.solution_error import SolutionError
from sim.report.run_result import (BITS_SECTION, ERROR_SECTION, MODEL_SECTION, VERDICT_SECTION, BitExactness,
                                   KernelSpeed, ModelRunResult, RunResult, SceneFacts, ScheduleFacts, StepErrors,
                                   ThesisComparison, VelocityError, _thesis, sections)
from sim.compare.exact_error import ExactErrors, ExactReferenceFacts, NoExactReference

ERR = VelocityError(1e-3, 2e-3, 0.5)
FACTS = ExactReferenceFacts("clarabel 0.11.1", 3, {"contact": 0.2, "friction": 0.3}, {}, {"max |dv| (m/s)": 1e-9},
                            {"certified max |dv| (m/s)": 1e-6}, "build/frames/stack.exact.npz", True)
EXACT = ExactErrors(FACTS, SolutionError(4e-3, 1e-3, 3e-3, 5e-3, 2e-3, 4e-3, 0.4, 0.6),
                    SolutionError(6e-3, 1e-3, 3e-3, 7e-3, 2e-3, 4e-3, 0.4, 0.6),
                    SolutionError(8e-3, 1e-3, 3e-3, 9e-3, 2e-3, 4e-3, 0.4, 0.6))


def _result(bits: BitExactness | None, exact: Union[ExactErrors, NoExactReference] = EXACT) -> RunResult:
    errors = StepErrors("RTL kernel", ERR, ERR, exact, (10, 4), 1e-10, True, {"max": 0.1}, {"max": 0.2}, ERR)
    thesis = ThesisComparison("fp32", 10, 2, 40, None if bits is None else 400, {}, 10, {"golden (numpy)": 0.01})
    result = RunResult("stack-fp32-it2-s1-zcu102", SceneFacts("stack", 11, 10, 10, 40, 10, 1),
                       ScheduleFacts("hazard", 20, 10, 2, 0, 5, 40), errors, thesis, {"frame load/capture": 0.1})
    if bits is not None:
        result.bits = bits
        result.speed = KernelSpeed("fp32", "zcu102", 400, 40, 7, 8, 2, 5000, 600, 480, 0.25, 1e4, 0.1, 0.0,
                                   {"DDR bandwidth": 300.0, "constraint stream port": 310.0, "compute (II=1)": 62.0})
    return result


def test_exit_status_follows_bit_exactness() -> None:
    assert BitExactness(0, 0, 40, 11, "", 1).ok
    assert not BitExactness(1, 1, 40, 11, "record 3 word 2", 1).ok
    assert not BitExactness(0, 0, 39, 11, "trace ends after 39 records", 1).ok
    assert _result(None).ok and _result(BitExactness(0, 0, 40, 11, "", 1)).ok
    assert not _result(BitExactness(2, 1, 40, 11, "body 3", 1)).ok
    assert ModelRunResult("pile-fp32-it4-s1-zcu102", "pile", 217, 900, "hazard", "zcu102").ok


def test_exit_status_follows_the_cycle_model() -> None:
    """make sim exits 1 when the cycle model disagrees with the RTL kernel, even with every bit equal, and says so in
    the report's first section; a run the model was not compared with (None) does not fail for it."""
    good = BitExactness(0, 0, 40, 11, "", 1)
    for agrees, ok in ((True, True), (None, True), (False, False)):
        result = _result(good)
        result.model_agrees = agrees
        assert result.ok is ok
        verdict = sections(result)[VERDICT_SECTION]
        assert verdict["exit status"] == ("0" if ok else "1 (a check above failed)")
        assert verdict["cycle model against the RTL kernel"] == {True: "agree", None: "not compared",
                                                                False: "DISAGREE (see the cycle model section)"}[agrees]
    bad = _result(BitExactness(2, 1, 40, 11, "body 3", 1))
    bad.model_agrees = True
    assert sections(bad)[VERDICT_SECTION]["RTL kernel against the golden model"] == "DIFFER: body 3"


def test_sections_in_order() -> None:
    rtl = sections(_result(BitExactness(0, 0, 40, 11, "", 1)))
    assert list(rtl) == [VERDICT_SECTION, "scene", "schedule", BITS_SECTION, "kernel speed (RTL in Verilator)",
                         "roofline (lower bounds for this configuration)",
                         "error (velocities after the step; dynamic bodies)",
                         "comparison with the thesis and with software solvers", "wall time of this run (s)"]
    assert rtl[BITS_SECTION]["first mismatch"] == "none"
    assert rtl["roofline (lower bounds for this configuration)"]["bound by"] == "constraint stream port"
    err = rtl[ERROR_SECTION]
    assert err["RTL kernel vs float64 PGS after 10 contact and 4 friction passes: max |dw| (rad/s)"] == 2e-3
    assert "thesis statistic: average relative position difference from fp32" not in err
    plain = sections(_result(None))
    assert BITS_SECTION not in plain and "kernel speed (RTL in Verilator)" not in plain
    assert plain[VERDICT_SECTION]["RTL kernel against the golden model"] == "not run"
    model = sections(ModelRunResult("p", "pile", 217, 900, "hazard", "zcu102", {"model: kernel cycles": 5}))
    assert list(model) == ["scene", MODEL_SECTION] and model["scene"]["bodies"] == 217


def test_errors_against_the_exact_reference() -> None:
    """The step, float64 with the same iterations and the old iterate each against the exact reference, the old
    iterate labelled with its passes; without a reference every one of those lines says why."""
    err = sections(_result(None))[ERROR_SECTION]
    assert err["RTL kernel vs exact reference (rounding + iteration error): max |dv| (m/s)"] == 4e-3
    assert err["float64 with these iterations vs exact reference (iteration error alone): max |dw| (rad/s)"] == 7e-3
    assert err["float64 PGS after 10 contact and 4 friction passes vs exact reference: max |dv| (m/s)"] == 8e-3
    assert err["RTL kernel vs exact reference (rounding + iteration error): p99 |dw| (rad/s)"] == 4e-3
    assert err["exact reference, contact phase, certified max |dv| (m/s)"] == 1e-6
    assert err["exact reference: cache file"] == "build/frames/stack.exact.npz (read from the cache)"
    missing = sections(_result(None, NoExactReference("QP solver hit the time budget")))[ERROR_SECTION]
    why = "no exact reference (QP solver hit the time budget)"
    assert missing["RTL kernel vs exact reference (rounding + iteration error)"] == why
    assert missing["float64 PGS after 10 contact and 4 friction passes vs exact reference"] == why
    assert missing["exact reference"] == why
    assert not any(k.startswith("exact reference:") or "vs exact reference:" in k for k in missing)
    assert missing["RTL kernel vs float64, same schedule and iterations (rounding error): max |dv| (m/s)"] == 1e-3


def test_model_mode_reports_the_errors_against_the_exact_reference() -> None:
    """MODE=model: the golden model's step and float64 with the same iterations against the exact reference (no
    PGS iterate line), or, without a reference, why not."""
    exact = ExactErrors(FACTS, EXACT.ours, EXACT.iteration_only)
    got = sections(ModelRunResult("p", "pile", 217, 900, "hazard", "zcu102", {}, errors=exact,
                                  error_source="fp32 golden model"))
    assert list(got) == ["scene", MODEL_SECTION, ERROR_SECTION]
    err = got[ERROR_SECTION]
    assert err["fp32 golden model vs exact reference (rounding + iteration error): max |dv| (m/s)"] == 4e-3
    assert err["float64 with these iterations vs exact reference (iteration error alone): max |dv| (m/s)"] == 6e-3
    assert err["exact reference: solver"] == "clarabel 0.11.1"
    assert not any("PGS" in k for k in err)
    missing = sections(ModelRunResult("p", "thesis", 38881, 147485, "hazard", "zcu102", {},
                                      errors=NoExactReference("time budget of 600 s spent"),
                                      error_source="fp32 golden model"))[ERROR_SECTION]
    why = "no exact reference (time budget of 600 s spent)"
    assert missing == {"fp32 golden model vs exact reference (rounding + iteration error)": why,
                       "float64 with these iterations vs exact reference (iteration error alone)": why,
                       "exact reference": why}


def test_thesis_comparison_at_the_clock_the_timing_estimate_supports() -> None:
    base = ThesisComparison("fp16", 147485, 4, 1179880, 822865, {}, 10, {})
    at_275 = sections_thesis(dataclasses.replace(base, clock_hz=275e6, clock_why="275 MHz (meets)"))
    assert at_275["this run: RTL fp16, 147,485 manifolds, 4 iterations"].startswith("822,865 cycles, 2.99 ms at 275 MHz")
    slow = sections_thesis(dataclasses.replace(base, clock_hz=71e6, clock_why="71 MHz (the estimate's highest)"))
    assert slow["this run: RTL fp16, 147,485 manifolds, 4 iterations"].startswith("822,865 cycles, 11.59 ms at 71 MHz")
    assert slow["clock of this run's latency"] == "71 MHz (the estimate's highest)"
    # the thesis's own designs keep their clocks
    assert "250 MHz" in next(k for k in slow if k.startswith("thesis ZCU102 fp16"))
    # no timing estimate given: the platform's 275 MHz, no line on why
    assert sections_thesis(base)["this run: RTL fp16, 147,485 manifolds, 4 iterations"].startswith(
        "822,865 cycles, 2.99 ms at 275 MHz (3.29 ms at the thesis fp16 design's 250 MHz)")
    assert "clock of this run's latency" not in sections_thesis(base)


def sections_thesis(t: ThesisComparison) -> dict[str, object]:
    from sim.report.run_result import _thesis

    return _thesis(t)


def test_a_reference_not_certified_unique_is_named_on_every_error_line() -> None:
    """Where the friction phase's non-symmetric problem holds a component whose solution is not certified unique,
    the error lines measure against "the fixed point reached from the kernel's start", named so, not "exact
    reference"; sim.compare.exact_error.reference_name decides from the reference's details."""
    import dataclasses

    from models.exact.damped_friction import DAMPED_KEY, NOT_UNIQUE
    from sim.compare.exact_error import NOT_UNIQUE_NAME, reference_name

    assert reference_name({f"{DAMPED_KEY} {NOT_UNIQUE}": 2.0}) == NOT_UNIQUE_NAME
    assert reference_name({f"{DAMPED_KEY} {NOT_UNIQUE}": 0.0}) == "exact reference" == reference_name({})
    named = dataclasses.replace(EXACT, reference=dataclasses.replace(FACTS, name=NOT_UNIQUE_NAME))
    err = sections(_result(None, named))[ERROR_SECTION]
    assert err[f"RTL kernel vs {NOT_UNIQUE_NAME} (rounding + iteration error): max |dv| (m/s)"] == 4e-3
    assert err[f"float64 PGS after 10 contact and 4 friction passes vs {NOT_UNIQUE_NAME}: max |dv| (m/s)"] == 8e-3
    assert not any(k.startswith("RTL kernel vs exact reference") for k in err)
    model = sections(ModelRunResult("p", "pile", 217, 900, "hazard", "zcu102", {}, errors=named,
                                    error_source="fp32 golden model"))[ERROR_SECTION]
    assert f"fp32 golden model vs {NOT_UNIQUE_NAME} (rounding + iteration error): max |dv| (m/s)" in model


def test_an_unconverged_pgs_line_says_how_many_passes_it_would_still_need() -> None:
    import dataclasses

    result = _result(None)
    result.errors = dataclasses.replace(result.errors, converged=False, converged_projected=(0.0, 2.5e5))
    err = sections(result)[ERROR_SECTION]
    key = ("float64 PGS after 10 contact and 4 friction passes: passes still needed at the last 250 passes' rate "
           "(contact, friction)")
    assert err[key] == "converged, 2.5e+05"
    assert key not in sections(_result(None))[ERROR_SECTION]  # converged: no such line


def test_the_thesis_comparison_gives_a_design_at_the_thesis_clock_of_its_format() -> None:
    fp16 = _thesis(ThesisComparison("fp16", 147_485, 4, 1_179_880, 822_865, {}, 10, {}))
    line = fp16["this run: RTL fp16, 147,485 manifolds, 4 iterations"]
    assert line == ("822,865 cycles, 2.99 ms at 275 MHz (3.29 ms at the thesis fp16 design's 250 MHz), "
                    "0.70 cycles/manifold-pass")
    fp32 = _thesis(ThesisComparison("fp32", 147_485, 4, 1_179_880, 1_436_467, {}, 10, {}))
    assert fp32["this run: RTL fp32, 147,485 manifolds, 4 iterations"].startswith("1,436,467 cycles, 5.22 ms at 275 MHz, ")
