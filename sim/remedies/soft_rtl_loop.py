"""A hard case's closed loop through the RTL kernel (``sim.drive.rtl_stepper``), every call bit-exact with the golden
model and priced by the kernel's cycle counter beside the cycle model's prediction: Box2D's soft step on the soft
contact build (SOFT_CONTACT, the impulses in the records), or any other remedy of
``models.closed_loop.hard_cases.REMEDIES``.

    python -m sim.remedies.soft_rtl_loop --case incline20 --steps 3 --remedies warm1+soft15z1+sub2+relax,warm1

Per remedy it prints the kernel calls run, the trace and body records compared and the bits that differ (0, or the
stepper stops at the first mismatch), the RTL's cycles per measured step against the cycle model's (and the calls
where they differ), whether the final state equals the golden loop's, and the hard-case judge's verdict over the
measured steps. The case's warm-up steps run on the golden model (bit-identical to the kernel, and the kernel's
figures are those of the measured steps; ``--warmup-on-rtl`` runs them through the RTL too). Every remedy runs on the
SOFT_CONTACT build with the impulses in the records (one build): a rigid call with the soft bit clear, which is the
rigid kernel bit for bit and cycle for cycle.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

from models.closed_loop.loop import StepperFactory, golden_stepper
from models.timing.platforms import get_preset
from models.formats.number_format import KERNEL_FORMATS
from models.closed_loop.hard_cases import CASES, REMEDIES, judge
from sim.drive.rtl_stepper import RtlCall, rtl_stepper
from sim.compile.verilator_build import REPO_ROOT

STATE_FIELDS = ("position", "orientation", "linear_velocity", "angular_velocity")


def golden_first(golden_calls: int, rtl: StepperFactory) -> StepperFactory:
    """A stepper factory whose first ``golden_calls`` kernel calls (over every factory it makes) run on the golden
    model and the rest on ``rtl``."""
    count = [0]

    def factory(ar, solver, ip):  # noqa: ANN001, ANN202 (models.closed_loop.loop.StepperFactory)
        gold, kernel = golden_stepper(ar, solver, ip), rtl(ar, solver, ip)

        def step(*args, **kw):  # noqa: ANN002, ANN003, ANN202
            count[0] += 1
            return (gold if count[0] <= golden_calls else kernel)(*args, **kw)

        return step

    return factory


def run_remedy(case: str, remedy: str, fmt_name: str, iterations: int, steps: int, out: Path,
               warmup_on_rtl: bool = False) -> dict[str, object]:
    """One remedy's loop through the RTL and through the golden model; the figures the command prints."""
    hard, rem, fmt = CASES[case], REMEDIES[remedy], KERNEL_FORMATS[fmt_name]
    calls: list[RtlCall] = []
    stepper = rtl_stepper(get_preset("zcu102"), out / f"{case}-{remedy}-{fmt_name}", impulses_in_records=True,
                          soft_contact=True, calls=calls)
    if not warmup_on_rtl:
        stepper = golden_first(hard.warmup_steps * rem.calls_per_step, stepper)
    t0 = time.perf_counter()
    rtl, _ = hard.run(fmt, iterations, steps, stepper=stepper, remedy=rem)
    rtl_s = time.perf_counter() - t0
    gold, traj = hard.run(fmt, iterations, steps, remedy=rem)
    measured = calls[len(calls) - steps * rem.calls_per_step:]
    verdict = judge(hard, gold, traj)
    return {
        "case": case, "remedy": remedy, "format": fmt_name, "measured steps": steps,
        "kernel calls on the RTL": len(calls),
        "soft calls": sum(c.soft for c in calls),
        "trace records compared": sum(c.trace_records for c in calls),
        "body records compared": sum(c.body_records for c in calls),
        "differing bits": sum(c.differing_bits for c in calls),
        "RTL cycles per measured step": sum(c.rtl_cycles for c in measured) / steps,
        "model cycles per measured step": sum(c.model_cycles for c in measured) / steps,
        "calls where RTL and model cycles differ": sum(c.rtl_cycles != c.model_cycles for c in calls),
        "final state equal to the golden loop's": all(
            np.array_equal(getattr(rtl.final, f), getattr(gold.final, f)) for f in STATE_FIELDS),
        "verdict": "pass" if not verdict.failures else "FAIL: " + "; ".join(verdict.failures),
        "RTL loop wall s": round(rtl_s, 1),
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--case", default="incline20", choices=sorted(CASES))
    ap.add_argument("--remedies", default="warm1+soft15z1+sub2+relax")
    ap.add_argument("--format", default="fp32", choices=sorted(KERNEL_FORMATS))
    ap.add_argument("--iters", type=int, default=4, help="iterations per step (split over the remedy's calls)")
    ap.add_argument("--steps", type=int, default=3, help="measured steps (after the case's warm-up)")
    ap.add_argument("--out", type=Path, default=REPO_ROOT / "build" / "soft_rtl_loop")
    ap.add_argument("--warmup-on-rtl", action="store_true", help="run the case's warm-up steps through the RTL too")
    args = ap.parse_args(argv)
    remedies = args.remedies.split(",")
    unknown = [r for r in remedies if r not in REMEDIES]
    if unknown or args.steps < 1:
        ap.error(f"unknown remedies {unknown} (known: {', '.join(REMEDIES)})" if unknown else "--steps must be >= 1")
    ok = True
    for remedy in remedies:
        row = run_remedy(args.case, remedy, args.format, args.iters, args.steps, args.out, args.warmup_on_rtl)
        for k, v in row.items():
            print(f"{k}: {v:,.1f}" if isinstance(v, float) else f"{k}: {v}")
        print()
        ok &= row["differing bits"] == 0 and row["final state equal to the golden loop's"] is True
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
