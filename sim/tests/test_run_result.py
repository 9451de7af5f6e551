"""make sim's typed result (sim/run_result.py): what decides the exit status, and the sections it renders into
(the one form the summary and report.md/json are written from), in order."""

from __future__ import annotations

from sim.run_result import BITS_SECTION, MODEL_SECTION, BitExactness, KernelSpeed, ModelRunResult, RunResult, \
    SceneFacts, ScheduleFacts, StepErrors, ThesisComparison, VelocityError, sections

ERR = VelocityError(1e-3, 2e-3, 0.5)


def _result(bits: BitExactness | None) -> RunResult:
    errors = StepErrors("RTL kernel", ERR, ERR, ERR, (10, 4), 1e-10, True, {"max": 0.1}, {"max": 0.2}, ERR)
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


def test_sections_in_order() -> None:
    rtl = sections(_result(BitExactness(0, 0, 40, 11, "", 1)))
    assert list(rtl) == ["scene", "schedule", BITS_SECTION, "kernel speed (RTL in Verilator)",
                         "roofline (lower bounds for this configuration)",
                         "error (velocities after the step; dynamic bodies)",
                         "comparison with the thesis and with software solvers", "wall time of this run (s)"]
    assert rtl[BITS_SECTION]["first mismatch"] == "none"
    assert rtl["roofline (lower bounds for this configuration)"]["bound by"] == "constraint stream port"
    err = rtl["error (velocities after the step; dynamic bodies)"]
    assert err["RTL kernel vs converged float64 (rounding + iteration error): max |dw| (rad/s)"] == 2e-3
    assert "thesis statistic: average relative position difference from fp32" not in err
    plain = sections(_result(None))
    assert BITS_SECTION not in plain and "kernel speed (RTL in Verilator)" not in plain
    model = sections(ModelRunResult("p", "pile", 217, 900, "hazard", "zcu102", {"model: kernel cycles": 5}))
    assert list(model) == ["scene", MODEL_SECTION] and model["scene"]["bodies"] == 217
