"""The cycle model against a run of the RTL kernel: every retire cycle of a deterministic run, the total cycles and
the stall and bubble counters (:func:`compare_run`), and the cycle model's section of a run report.

A run with random stream gaps and backpressure is held to the streaming model's lower bound only
(``Prediction.BOUNDS_RANDOM_RUNS``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol, Sequence

import numpy as np

from models.timing.platforms import DmaPreset
from models.timing.prediction import Prediction


@dataclass
class Agreement:
    """The model against a measured trace (retire cycles) and the kernel's counters."""

    records: int
    exact: int  # records whose retire cycle matches
    max_abs_diff: int
    cycles_model: int
    cycles_rtl: int
    first_mismatch: str | None

    @property
    def ok(self) -> bool:
        return self.first_mismatch is None

    def describe(self) -> str:
        d = self.cycles_rtl - self.cycles_model
        return (f"model {self.cycles_model:,} vs RTL {self.cycles_rtl:,} cycles ({d:+,}, "
                f"{100.0 * d / max(self.cycles_rtl, 1):+.3f}%); retire cycles: {self.exact:,} of {self.records:,} "
                f"exact, largest difference {self.max_abs_diff}")


def compare_retire_cycles(pred: Prediction, cycle: np.ndarray, kind: np.ndarray, iteration: np.ndarray, slot: np.ndarray,
                  cycles_rtl: int, manifolds: Sequence[int] | np.ndarray | None = None,
                  counters: dict[str, float] | None = None) -> Agreement:
    """Every retire cycle of a deterministic run against the model (exact), then the total and the stall and
    bubble counters. ``manifolds``: the manifold index of each slot (for the message)."""
    n = min(len(cycle), pred.manifold_passes)
    msg: str | None = None
    if len(cycle) != pred.manifold_passes:
        msg = f"{len(cycle):,} retired manifold-passes, the model expects {pred.manifold_passes:,}"
    hdr = (np.asarray(kind[:n]) != pred.kind[:n]) | (np.asarray(iteration[:n]) != pred.iteration[:n]) | \
        (np.asarray(slot[:n]) != pred.slot[:n])
    diff = np.asarray(cycle[:n], dtype=np.int64) - pred.retire[:n]
    bad = np.flatnonzero(hdr | (diff != 0))
    if bad.size and msg is None:
        k = int(bad[0])
        man = None if manifolds is None else int(manifolds[int(pred.slot[k])])
        if hdr[k]:
            msg = (f"retire #{k}: the kernel retired (kind, iteration, slot) {int(kind[k])}, {int(iteration[k])}, "
                   f"{int(slot[k])}, the model expects {pred.where(k, man)}")
        else:
            msg = mismatch_message(pred, k, int(cycle[k]), man)
    if msg is None and cycles_rtl != pred.cycles:
        msg = (f"kernel cycles {cycles_rtl:,}, model {pred.cycles:,} (every retire cycle matched: the difference "
               f"is in DRAIN/INTEG/body-out, which the model expects from cycle {pred.integ_start:,})")
    if msg is None and counters is not None:
        for name, want in (("stalls", pred.stalls), ("bubbles", pred.bubbles)):
            if int(counters[name]) != want:
                msg = f"{name} counter {int(counters[name]):,}, model {want:,}"
                break
    return Agreement(pred.manifold_passes, int(np.count_nonzero(diff == 0)) - int(np.count_nonzero(hdr & (diff == 0))),
                     int(np.abs(diff).max(initial=0)), pred.cycles, cycles_rtl, msg)


class KernelRun(Protocol):
    """What :func:`compare_run` needs of a kernel run (``sim.drive.kernel_step.KernelResult`` with ``keep_trace``)."""

    trace: Any  # cycle, kind, iteration, slot arrays, or None
    registers: dict[str, float]

    @property
    def cycles(self) -> int: ...


def compare_run(pred: Prediction, run: KernelRun, slots: np.ndarray | None = None) -> Agreement:
    """:func:`compare_retire_cycles` on a kernel run's trace, total and stall / bubble counters."""
    if run.trace is None:
        raise ValueError("the run kept no trace (run_kernel_step(..., keep_trace=True))")
    tr = run.trace
    return compare_retire_cycles(pred, tr.cycle, tr.kind, tr.iteration, tr.slot, run.cycles, slots, run.registers)


def mismatch_message(pred: Prediction, k: int, measured: int, manifold: int | None = None) -> str:
    """``manifold 812 (contact pass, ...) retired at cycle 10,431, model 10,430: unexpected 1-cycle stall or
    bubble; the model: ...``"""
    d = measured - int(pred.retire[k])
    what = (f"unexpected {d}-cycle stall or bubble" if d > 0 else
            f"{-d} cycle{'s' if d < -1 else ''} earlier than the model: a stall or bubble the model expected did "
            "not happen")
    return (f"{pred.where(k, manifold)} retired at cycle {measured:,}, model {int(pred.retire[k]):,}: {what}; "
            f"the model: {pred.explain(k)}")


def report_section(pred: Prediction, preset: DmaPreset, seconds: float, measured: int | None = None,
                   agreement: Agreement | None = None) -> dict[str, int | float | str]:
    """The cycle model's figures for a run report (``seconds``: the model's CPU time). ``agreement``: a
    deterministic run's trace against the model; ``measured`` alone: the cycles of a run with random
    gaps/backpressure, which the model bounds from below."""
    out: dict[str, int | float | str] = {"model: kernel cycles": pred.cycles,
                                         "model: cycles per manifold-pass": pred.cycles / max(pred.manifold_passes, 1),
                                         f"model: latency at {preset.clock_hz / 1e6:g} MHz (ms)":
                                             pred.cycles / preset.clock_hz * 1e3}
    out.update({f"model: {k}": v for k, v in pred.summary().items() if k not in ("cycles", "cycles per manifold-pass")})
    out["model: CPU time (s)"] = seconds
    if agreement is not None:
        out["model vs RTL cycles"] = agreement.describe()
        out["model vs RTL: first difference"] = agreement.first_mismatch or "none"
    elif measured is not None and pred.BOUNDS_RANDOM_RUNS:
        out["model vs RTL cycles"] = (f"RTL {measured:,} with random stalls, model lower bound {pred.cycles:,} "
                                      f"({'holds' if measured >= pred.cycles else 'VIOLATED'}, "
                                      f"{measured / max(pred.cycles, 1) - 1:+.2%})")
    elif measured is not None:
        out["model vs RTL cycles"] = (f"RTL {measured:,} with random stalls, model {pred.cycles:,} without them "
                                      f"({measured / max(pred.cycles, 1) - 1:+.2%}; not a bound: the window kernel's "
                                      "choice of pass changes with the stalls)")
    return out
