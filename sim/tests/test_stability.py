"""The quick subset of the hard-case suite (`make stability` runs all of it), and a closed loop on the RTL kernel."""

from __future__ import annotations

import csv

from pathlib import Path

import numpy as np
import pytest

from models.closed_loop.loop import Remedy, run_closed_loop
from models.timing.platforms import get_preset
from models.formats.number_format import FP16, FP32
from models.closed_loop.hard_cases import CASES, REMEDIES, call_iterations, judge
from sim.drive.rtl_stepper import RtlCall, ShockUnsupported, SoftContactUnsupported, WarmStartUnsupported, rtl_stepper
from sim.stability import main as stability_main


@pytest.mark.parametrize("case,fmt,iters,failing", [
    ("incline20", FP32, 4, ()),  # static friction holds the box: no excursion past the slop, at rest net of g dt
    # it slides past tan(angle) = mu (the slide check passes), but its contact is 1.04 cm deep (fp16: 1.17 cm),
    # past twice Bullet's slop: a finding of the stricter judge, asserted so that a change shows
    ("incline40", FP32, 4, ("max_penetration",)),
    ("incline40", FP16, 4, ("max_penetration",)),
    # 1- and 2-point manifolds, near-parallel faces: no NaN, settles (final speed 0.010 m/s net of g dt), but one
    # iteration lets a contact sink 2.0 cm, past twice the slop (4 iterations: 5.6 mm, passes)
    ("degenerate", FP32, 1, ("max_penetration",)),
])
def test_hard_case_quick_subset(case: str, fmt, iters: int, failing: tuple[str, ...]) -> None:
    v = judge(CASES[case], *CASES[case].run(fmt, iters))
    print(case, fmt.name, iters, v.figures, v.failures)
    assert v.figures["NaN/Inf values"] == 0
    assert v.failed_checks == list(failing), v.failures


# docs/stability.md's verdicts on the two hardest cases, each decided within 10 measured steps after the case's 30
# warm-up steps (the full runs measure 120): shock propagation passes in fp32 where the cold scheme and the warm
# start fail on every check at rest; fp16 misses on speed (the positions do not move: v h is below half an fp16 ulp
# of them). stack20 in fp16 misses too (speed, and 3.1 cm deep), measured, not run here: 90 s more.
AT_REST_FAILURES = ["max_penetration", "max_excursion", "max_path", "max_speed"]
HARD_CASE_VERDICTS = [
    ("mass_ratio", FP32, "cold", AT_REST_FAILURES), ("mass_ratio", FP32, "warm", AT_REST_FAILURES),
    ("mass_ratio", FP32, "warm+sub4+shocklrh", []), ("mass_ratio", FP16, "warm+sub4+shocklrh", ["max_speed"]),
    ("stack20", FP32, "cold", AT_REST_FAILURES), ("stack20", FP32, "warm", AT_REST_FAILURES),
    ("stack20", FP32, "warm+sub4+shocklrh", []),
]


@pytest.mark.parametrize("case,fmt,remedy,failing", HARD_CASE_VERDICTS,
                         ids=[f"{c}-{f.name}-{r}" for c, f, r, _ in HARD_CASE_VERDICTS])
def test_hard_case_verdicts_of_the_remedies(case: str, fmt, remedy: str, failing: list[str]) -> None:
    """The judge's limits (``models.closed_loop.hard_cases.LIMITS``) on 10 measured steps at 4 iterations (8
    manifold-passes) per step: the checks each remedy fails, exactly."""
    v = judge(CASES[case], *CASES[case].run(fmt, 4, steps=10, remedy=REMEDIES[remedy]), iterations=4)
    print(case, fmt.name, remedy, v.failures,
          {k: v.figures[k] for k in ("max penetration (m)", "max speed net of g dt (m/s)")})
    assert v.figures["NaN/Inf values"] == 0 and v.figures["passes per step"] == 8
    assert v.failed_checks == failing, v.failures


def test_closed_loop_on_the_rtl_kernel(tmp_path: Path) -> None:
    """Five closed-loop steps of the sliding box with the RTL kernel doing the dynamics: every step bit-exact with
    the golden model (the stepper fails otherwise), and the final state equal to the golden loop's."""
    kw = dict(angle_deg=40.0, friction=0.7)
    rtl = run_closed_loop("incline", 5, FP32, 4, stepper=rtl_stepper(get_preset("zcu102"), tmp_path), **kw)
    gold = run_closed_loop("incline", 5, FP32, 4, **kw)
    for f in ("position", "orientation", "linear_velocity", "angular_velocity"):
        assert np.array_equal(getattr(rtl.final, f), getattr(gold.final, f)), f


def test_make_stability_writes_table_and_plots(tmp_path: Path) -> None:
    assert stability_main(["--cases", "incline20", "--formats", "fp32", "--iters", "2", "--steps", "5",
                           "--remedies", "cold,warm+sub2", "--jobs", "1", "--out", str(tmp_path)]) == 0
    md = (tmp_path / "stability.md").read_text()
    assert "| incline20 | fp32 | 2 | cold | 4 |" in md and "| incline20 | fp32 | 2 | warm+sub2 | 4 |" in md
    assert "| incline20 | fp32 | 2 | pass (" in md and (tmp_path / "incline20.png").stat().st_size > 0
    assert "| matched points | new points |" in md.split("Warm-start matching")[1]  # the warm run's report
    assert stability_main(["--cases", "nope", "--out", str(tmp_path / "bad")]) == 2
    assert stability_main(["--cases", "incline20", "--remedies", "hot", "--out", str(tmp_path / "bad")]) == 2
    assert not (tmp_path / "bad").exists()


def test_the_soft_remedy_is_a_column_priced_per_call(tmp_path: Path) -> None:
    """Box2D's soft step through the command: 8 manifold-passes at 4 iterations (2 substeps x a solve and a relax
    call of 1 iteration), priced on the cycle model over its 4 kernel calls, dearer than one call of 4."""
    assert stability_main(["--cases", "incline20", "--formats", "fp16", "--iters", "4", "--steps", "3",
                           "--remedies", "warm,warm1+soft15z1+sub2+relax", "--jobs", "1", "--out", str(tmp_path)]) == 0
    rows = {r["remedy"]: r for r in csv.DictReader((tmp_path / "stability.csv").open())}
    soft, warm = rows["warm1+soft15z1+sub2+relax"], rows["warm"]
    assert float(soft["passes per step"]) == 8 == float(warm["passes per step"])
    assert float(soft["kernel cycles per step"]) > float(warm["kernel cycles per step"]) > 0


def test_the_rtl_kernel_refuses_a_warm_start(tmp_path: Path) -> None:
    """The kernel with on-chip impulses reads no initial impulses: a warm-started loop on it stops at its first step,
    by name."""
    with pytest.raises(WarmStartUnsupported, match="reads no initial impulses"):
        run_closed_loop("incline", 2, FP32, 4, stepper=rtl_stepper(get_preset("zcu102"), tmp_path),
                        remedy=Remedy("warm", 0.85))
    assert not any(tmp_path.iterdir())  # nothing was written for the refused step


def test_the_rtl_kernel_refuses_an_unsupported_soft_step(tmp_path: Path) -> None:
    """A soft remedy on a stepper without the soft contact build stops before its first kernel call, by name, on
    either impulse store; on the soft build with on-chip impulses the warm start (and the relax call, which continues
    the solve call's impulses) is refused by name. Nothing is written."""
    soft = REMEDIES["warm1+soft15z1+sub2+relax"]
    for records in (False, True):
        with pytest.raises(SoftContactUnsupported, match="needs the kernel build with the soft contact pipe"):
            run_closed_loop("incline", 2, FP32, 4, remedy=soft,
                            stepper=rtl_stepper(get_preset("zcu102"), tmp_path, impulses_in_records=records))
    with pytest.raises(WarmStartUnsupported, match="reads no initial impulses"):
        run_closed_loop("incline", 2, FP32, 4, remedy=soft,
                        stepper=rtl_stepper(get_preset("zcu102"), tmp_path, soft_contact=True))
    assert not any(tmp_path.iterdir())


def test_soft_closed_loop_on_the_rtl_kernel(tmp_path: Path) -> None:
    """Box2D's soft step through the RTL: three closed-loop steps of the box on the 20 degree slope (a hard case of
    the suite) in fp32, each 2 substeps of a soft solve call and a relax call, on the soft contact build with the
    impulses in the records: every call bit-exact with the golden model and cycle-exact with the cycle model, the
    final state equal to the golden loop's."""
    remedy, kw = REMEDIES["warm1+soft15z1+sub2+relax"], dict(angle_deg=20.0, friction=0.7)
    calls: list[RtlCall] = []
    iters = call_iterations(4, remedy)
    stepper = rtl_stepper(get_preset("zcu102"), tmp_path, impulses_in_records=True, soft_contact=True, calls=calls)
    rtl = run_closed_loop("incline", 3, FP32, iters, remedy=remedy, stepper=stepper, **kw)
    gold = run_closed_loop("incline", 3, FP32, iters, remedy=remedy, **kw)
    for f in ("position", "orientation", "linear_velocity", "angular_velocity"):
        assert np.array_equal(getattr(rtl.final, f), getattr(gold.final, f)), f
    assert len(calls) == 3 * remedy.calls_per_step and [c.soft for c in calls[:2]] == [True, False]
    assert all(c.rtl_cycles == c.model_cycles and c.differing_bits == 0 and c.trace_records > 0 for c in calls)


def test_warm_started_closed_loop_on_the_kernel_with_impulses_in_the_records(tmp_path: Path) -> None:
    """Warm starting through the RTL: three closed-loop steps of the sliding box in fp16 on the streaming kernel whose
    impulses travel with the records (the build the impulses-in-records tests use), each step's first passes reading
    the carried impulses; every step bit-exact with the golden model and the final state equal to the golden loop's."""
    kw = dict(angle_deg=40.0, friction=0.7)
    warm = Remedy("warm", 0.85)
    rtl = run_closed_loop("incline", 3, FP16, 4, remedy=warm, **kw,
                          stepper=rtl_stepper(get_preset("zcu102"), tmp_path, impulses_in_records=True))
    gold = run_closed_loop("incline", 3, FP16, 4, remedy=warm, **kw)
    for f in ("position", "orientation", "linear_velocity", "angular_velocity"):
        assert np.array_equal(getattr(rtl.final, f), getattr(gold.final, f)), f


def test_shock_closed_loop_on_the_rtl_kernel(tmp_path: Path) -> None:
    """Shock propagation through the RTL: two closed-loop steps of the 20-cube stack in fp32 with the remedy that
    passes every hard case in the golden model (warm start, 4 substeps of one iteration, every contact pass a linear
    shock pass, the frozen rows' impulses returned), on the build the soft loop uses (the soft bit clear: the rigid
    kernel) with the impulses in the records and banked body velocities: every call bit-exact with the golden model
    and cycle-exact with the cycle model, the final state the golden loop's and not the loop's without the shock."""
    remedy = REMEDIES["warm+sub4+shocklr"]
    calls: list[RtlCall] = []
    iters = call_iterations(4, remedy)
    stepper = rtl_stepper(get_preset("zcu102"), tmp_path, impulses_in_records=True, soft_contact=True, calls=calls)
    rtl = run_closed_loop("stack", 2, FP32, iters, remedy=remedy, stepper=stepper, **CASES["stack20"].params)
    gold = run_closed_loop("stack", 2, FP32, iters, remedy=remedy, **CASES["stack20"].params)
    unshocked = run_closed_loop("stack", 2, FP32, iters, remedy=REMEDIES["warm+sub4"], **CASES["stack20"].params)
    for f in ("position", "orientation", "linear_velocity", "angular_velocity"):
        assert np.array_equal(getattr(rtl.final, f), getattr(gold.final, f)), f
    assert not np.array_equal(rtl.final.linear_velocity, unshocked.final.linear_velocity)
    assert len(calls) == 2 * remedy.calls_per_step
    assert all(c.rtl_cycles == c.model_cycles and c.differing_bits == 0 and c.trace_records > 0 for c in calls)


def test_the_rtl_kernel_refuses_a_shock_pass_that_drops_its_impulses(tmp_path: Path) -> None:
    """A shock remedy whose frozen rows keep the impulses they held stops before its first kernel call, by name."""
    with pytest.raises(ShockUnsupported, match="golden-model only"):
        run_closed_loop("stack", 2, FP32, 4, remedy=REMEDIES["warm+shockv"],
                        stepper=rtl_stepper(get_preset("zcu102"), tmp_path, impulses_in_records=True))
    assert not any(tmp_path.iterdir())

