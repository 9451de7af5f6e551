"""What a cycle model predicts of a kernel run, and the phases both kernels' models share.

:class:`Prediction` holds, per issued manifold-pass, the cycle it became ready, issued and retired and why it waited
(``CAUSES``), and per step the phase boundaries and the stall and bubble counters. The streaming kernel's model
(``models/timing/stream_cycle_model.py``) and the window kernel's (``models/timing/window_cycle_model.py``) fill one
from the same pieces: the harness's DDR token bucket (:class:`DdrBucket`), LOAD (:func:`load_end_cycle`), the banked
body velocities (:class:`BankWrites`), the impulse-out stream (:class:`ImpulseOut`) and the phases after SOLVE
(:class:`Tail`: DRAIN, INTEG and the body-out stream, DONE). The conventions (cycle 0, the harness's DMA model) are the
streaming model's docstring's.
"""

from __future__ import annotations

from array import array
from collections import deque
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS
from models.kernel.body_banks import busy as bank_busy
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape

# why a record issued later than it was assembled (Prediction.cause)
READY, SOLVE_START, HAZARD, SWITCH, CAM_FULL, BANK_BUSY, IMP_FULL = range(7)
CAUSES = {READY: "none", SOLVE_START: "waiting for SOLVE (body load)", HAZARD: "hazard",
          SWITCH: "contact/friction pipe switch", CAM_FULL: "hazard CAM full",
          BANK_BUSY: "body bank busy with a retire write", IMP_FULL: "impulse-out FIFO full"}
_KIND = {CONTACT_PASS: "contact", FRICTION_PASS: "friction"}


def build_causes(shape: KernelShape) -> tuple[int, ...]:
    """The stall causes a build adds to the hazards and the CAM: a busy body bank (``BODY_BANKS``), a full
    impulse-out FIFO (impulses in the records)."""
    return ((BANK_BUSY,) if shape.body_banks else ()) + ((IMP_FULL,) if shape.impulses_in_records else ())


# --- the prediction -------------------------------------------------------------------------------------
@dataclass
class Prediction:
    """Per issued manifold-pass (retire order = issue order) and per step."""

    BOUNDS_RANDOM_RUNS: ClassVar[bool] = True  # random stream gaps and backpressure only delay: a lower bound

    shape: KernelShape
    kind: np.ndarray  # (R,) 0 contact, 1 friction
    iteration: np.ndarray
    slot: np.ndarray
    ready: np.ndarray  # cycle the record became valid (assembled) in the record register
    issue: np.ndarray
    retire: np.ndarray  # the trace cycle
    cause: np.ndarray  # READY, SOLVE_START, HAZARD, SWITCH, CAM_FULL, BANK_BUSY or IMP_FULL: what set the issue cycle
    blocker: np.ndarray  # the retire index whose retire released a HAZARD / SWITCH / CAM_FULL wait, else -1
    bubble: np.ndarray  # SOLVE cycles without a valid record just before this one became valid
    first_offer: np.ndarray  # cycle the record's first beat was offered by the DMA
    last_beat: np.ndarray  # cycle its last beat was taken
    ddr_wait: np.ndarray  # cycles its beats waited for DDR credit
    body_a: np.ndarray  # the record's bodies (-1: static)
    body_b: np.ndarray
    solve_start: int
    solve_end: int  # the last issue (or rejection) cycle; DRAIN starts one later
    integ_start: int
    done: int  # the DONE cycle
    rejected: int
    stalls: int
    bubbles: int
    phases: dict[str, int] = field(default_factory=dict)

    @property
    def cycles(self) -> int:
        """The kernel's cycle counter (0x60): ap_start to ap_done inclusive."""
        return self.done + 2

    @property
    def manifold_passes(self) -> int:
        return int(self.retire.shape[0])

    def where(self, k: int, manifold: int | None = None) -> str:
        man = f"manifold {manifold} " if manifold is not None else ""
        return (f"{man}({_KIND[int(self.kind[k])]} pass, iteration {int(self.iteration[k])}, slot "
                f"{int(self.slot[k])}; retire #{k})")

    def explain(self, k: int) -> str:
        """Why retire #k happens when the model says: stream arrival, bubbles, stalls and their cause."""
        iss, rdy = int(self.issue[k]), int(self.ready[k])
        parts = [f"issue at cycle {iss:,}, retire at {int(self.retire[k]):,} (pipe latency "
                 f"{self.shape.latency(int(self.kind[k]))} + 1)"]
        beats = self.shape.beats(int(self.kind[k]))
        arrival = (f"record assembled at cycle {rdy:,} (its {beats} beat{'s' if beats > 1 else ''} offered from "
                   f"cycle {int(self.first_offer[k]):,}, last taken at {int(self.last_beat[k]):,}")
        arrival += f", {int(self.ddr_wait[k])} cycles waiting for DDR credit)" if self.ddr_wait[k] else ")"
        parts.append(arrival)
        if self.bubble[k]:
            parts.append(f"{int(self.bubble[k])}-cycle bubble before it (no record assembled)")
        cause, stall = int(self.cause[k]), iss - max(rdy, self.solve_start)
        if cause == READY:
            parts.append("no stall: no hazard, no pipe switch")
        elif cause == SOLVE_START:
            parts.append(self.solve_wait())
        else:
            b = int(self.blocker[k])
            who = self.retire_of(b)
            if cause == HAZARD:
                shared = sorted({int(x) for x in (self.body_a[k], self.body_b[k]) if x >= 0}
                                & {int(x) for x in (self.body_a[b], self.body_b[b]) if x >= 0})
                parts.append(f"{stall}-cycle stall: hazard on body {', '.join(map(str, shared))} with {who}")
            elif cause == BANK_BUSY:
                parts.append(f"{stall}-cycle stall: a body-velocity bank busy with the writes of {who}")
            elif cause == SWITCH:
                parts.append(f"{stall}-cycle stall: pipe switch, waits for the last {_KIND[int(self.kind[b])]} "
                             f"pass record, {who}")
            elif cause == IMP_FULL:
                parts.append(f"{stall}-cycle stall: {self.imp_full_wait()}")
            else:
                parts.append(f"{stall}-cycle stall: hazard CAM full ({self.shape.hazard_depth} in flight) until {who}")
        return "; ".join(parts)

    def retire_of(self, b: int) -> str:
        """``retire #b (its pass and slot) at cycle C``: the record whose retire released a wait."""
        return f"retire #{b} {self.where(b)} at cycle {int(self.retire[b]):,}"

    def solve_wait(self) -> str:
        """What a record ready during LOAD waited for."""
        return f"waited for SOLVE, which starts at cycle {self.solve_start:,} after the body load"

    def imp_full_wait(self) -> str:
        """What a record held by the impulse-out FIFO waited for."""
        return (f"impulse-out FIFO full ({self.shape.impulse_fifo_depth} records taken and not yet out) until its "
                "oldest record left")

    def stall_cycles_by_cause(self) -> dict[str, int]:
        """Stall cycles (the kernel's counter) split by what the waiting record waited for."""
        waited = self.issue - np.maximum(self.ready, self.solve_start)
        causes = (HAZARD, SWITCH, CAM_FULL) + build_causes(self.shape)
        return {CAUSES[c]: int(waited[self.cause == c].sum()) for c in causes}

    def summary(self) -> dict[str, int | float]:
        mp = max(self.manifold_passes, 1)
        out: dict[str, int | float] = {"cycles": self.cycles, "cycles per manifold-pass": self.cycles / mp,
                                       "stall cycles": self.stalls, "bubble cycles": self.bubbles}
        out.update({f"stall cycles: {k}": v for k, v in self.stall_cycles_by_cause().items()})
        out.update({"manifold-passes": self.manifold_passes, "rejected manifold-passes": self.rejected})
        out.update({f"{k} starts at cycle": v for k, v in self.phases.items()})
        return out


@dataclass(frozen=True)
class Tail:
    """The phases after SOLVE: DRAIN until the hazard CAM is empty, INTEG and the body-out stream, DONE."""

    integ_start: int
    done: int
    phases: dict[str, int]

    @staticmethod
    def after_solve(shape: KernelShape, nb: int, solve_start: int, solve_end: int | None, last_retire: int,
                    last_impulse_out: int = -1) -> "Tail":
        """``solve_end``: the last take (None: SOLVE took nothing, LOAD goes straight to INTEG); ``last_retire``:
        the last retire cycle (-1: none); ``last_impulse_out``: the cycle the last impulse-out record was taken
        (impulses in the records; -1: none)."""
        # DRAIN from the last take until the hazard CAM is empty (the last retire has popped), then INTEG
        integ_start = max(last_retire, solve_end) + 2 if solve_end is not None else solve_start
        # DONE after the last body-out beat and (impulses in the records) the last impulse-out record
        done = max(integrate(shape, nb, integ_start) + 1, last_impulse_out + 2)
        drain = solve_end + 1 if solve_end is not None else solve_start
        return Tail(integ_start, done, {"LOAD": 0, "SOLVE": solve_start, "DRAIN": drain, "INTEG": integ_start,
                                        "DONE": done})




def empty(shape: KernelShape, done: int) -> Prediction:
    z = np.zeros(0, dtype=np.int64)
    return Prediction(shape, z, z, z, z, z, z, z, z, z, z, z, z, z, z, 0, 0, done - 1, done, 0, 0, 0)


def check_body_rate(shape: KernelShape, dma: DmaTiming) -> None:
    if dma.rate and dma.rate < shape.body_beat_bytes:
        raise ValueError(f"the DDR's {dma.rate:g} B per cycle are less than one {8 * shape.body_beat_bytes}-bit body "
                         "beat per cycle: not modeled (a narrower BODY_BITS)")


def body_beat_cycles(shape: KernelShape, nb: int, load_end: int) -> tuple[int, int]:
    """The first and last cycle of the body-in beats (one a cycle, the last at ``load_end``)."""
    return load_end - nb * shape.body_in_beats + 1, load_end


def load_end_cycle(shape: KernelShape, dma: DmaTiming, nb: int) -> int:
    """Cycle the last body-in beat is taken: one beat per cycle from the transfer's first (the bucket always
    holds a 16-byte beat: it refills by >= 16 bytes a cycle, and a constraint beat only spends what is there)."""
    check_body_rate(shape, dma)
    first = 0 if dma.prefetched else max(dma.startup - 1, 0)
    return first + nb * shape.body_in_beats - 1



def dynamic_bodies(step: StepShape) -> tuple[np.ndarray, np.ndarray]:
    """Per slot: bodies A and B where the kernel tracks them (dynamic, in range), else -1."""
    nb = step.num_bodies

    def tracked(b: np.ndarray) -> np.ndarray:
        ok = (b >= 0) & (b < nb)
        ok[ok] = step.dynamic[b[ok]]
        return np.where(ok, b, -1)

    return tracked(step.body_a), tracked(step.body_b)



class ImpulseOut:
    """The impulse-out stream of a kernel with the impulses in the records (``g_imp_out`` of ``pgs_sequencer``)
    with TREADY always up: each take that writes a record (every take of the streaming kernel, the takes of a fetch's
    last pass on the window kernel) pushes an entry into the order FIFO of ``depth`` entries, and the record is taken
    (the m_axis_imp handshake) the cycle after its data is in (its retire; a take without an issuing lane: the take)
    and after the record before it. A take waits while the order FIFO is full (a record taken frees its entry from
    the next cycle)."""

    __slots__ = ("depth", "left", "last")

    def __init__(self, depth: int) -> None:
        self.depth = depth
        self.left = array("q")  # per entry: the cycle its record was taken
        self.last = -1

    def push(self, data_in: int) -> int:
        """An entry whose data is in at cycle ``data_in``: the cycle its record is taken."""
        out = data_in + 1 if data_in >= self.last else self.last + 1
        self.left.append(out)
        self.last = out
        return out

    def room_from(self) -> int:
        """The first cycle the order FIFO has room for one more entry."""
        n = len(self.left)
        return self.left[n - self.depth] + 1 if n >= self.depth else 0


class BankWrites:
    """Banked body velocities (:mod:`models.kernel.body_banks`) over time: the dynamic bodies the issued manifolds
    write at their retire, in retire order; a record's reads of bodies A and B are served in a cycle only beside the
    writes of the manifold retiring then. Ask in time order: the writes retired before the cycle asked for are
    dropped."""

    __slots__ = ("banks", "pending")

    def __init__(self, banks: int) -> None:
        self.banks = banks
        self.pending: deque[tuple[int, tuple[int, ...], int]] = deque()  # (retire cycle, bodies written, retire index)

    def add(self, retire: int, writes: tuple[int, ...], who: int) -> None:
        """Manifold ``who`` (a retire index) writes ``writes`` at cycle ``retire``."""
        self.pending.append((retire, writes, who))

    def blocker(self, t: int, reads: tuple[int, ...]) -> int:
        """The retire index whose writes at cycle ``t`` leave a bank no port for ``reads``, else -1."""
        pending = self.pending
        while pending and pending[0][0] < t:
            pending.popleft()
        if pending and pending[0][0] == t and bank_busy(self.banks, reads, pending[0][1]):
            return pending[0][2]
        return -1


def first_offer_cycle(dma: DmaTiming) -> int:
    """The harness iteration of the first constraint beat's offer: after the transfer's start-up latency."""
    return 0 if dma.prefetched else max(dma.startup - 1, 0)


class DdrBucket:
    """The harness's DDR token bucket of bytes (``DdrBucket`` of ``sim/harness/pgs_kernel_main.cpp``), shared by the
    body-in and the constraint stream: each harness iteration refills it (capped at two constraint beats), then the
    body-in beat of that iteration spends (one a cycle in ``body_beats`` = first, last cycle: the bucket always
    holds a body beat), then a constraint beat may be offered. The additions are the harness's, in its order, in
    IEEE doubles, so a credit landing exactly on a beat size resolves the same way. Constraint beats must be asked
    for in stream order (:meth:`offer`), and the body-out beats (INTEG, after the last constraint beat) are not
    counted."""

    __slots__ = ("rate", "cap", "credit", "cyc", "b0", "b1", "body_bytes", "beat_bytes")

    def __init__(self, shape: KernelShape, dma: DmaTiming, body_beats: tuple[int, int]) -> None:
        self.rate, self.cap = dma.rate, 2.0 * shape.cons_beat_bytes
        self.credit = self.cap if dma.prefetched else 0.0  # after harness iteration `cyc`
        self.cyc = -1
        self.b0, self.b1 = body_beats
        self.body_bytes, self.beat_bytes = float(shape.body_beat_bytes), float(shape.cons_beat_bytes)

    def offer(self, y: int) -> int:
        """The harness iteration >= ``y`` at which the next constraint beat is offered (its bytes are spent)."""
        rate = self.rate
        if not rate:
            return y
        credit, cyc, cap, b0, b1, body_bytes = self.credit, self.cyc, self.cap, self.b0, self.b1, self.body_bytes
        while cyc < y:  # refill each iteration up to y (the body-in beat spends first)
            cyc += 1
            credit = credit + rate if credit + rate < cap else cap
            if b0 <= cyc <= b1:
                credit -= body_bytes
            elif credit == cap:  # full: nothing changes before y or the body-in beats
                cyc = y if (cyc > b1 or y < b0) else b0 - 1
        while credit < self.beat_bytes:
            cyc += 1
            credit = credit + rate if credit + rate < cap else cap
            if b0 <= cyc <= b1:
                credit -= body_bytes
        self.credit, self.cyc = credit - self.beat_bytes, cyc
        return cyc


def integrate(shape: KernelShape, nb: int, start: int) -> int:
    """INTEG: the cycle the last body-out beat is taken. TREADY is always up (no backpressure, and the bucket,
    refilled by >= one body beat a cycle, always holds a beat)."""
    lat, beats, depth = shape.integrate_latency, shape.body_out_beats, shape.out_fifo_depth
    pops: list[int] = []  # per body: the cycle its last beat is taken (out_pop)
    issue, last = start - 1, -1
    for k in range(nb):
        issue = max(issue + 1, pops[k - depth] + 1) if k >= depth else issue + 1
        last = max(issue + 2 + lat, last + 1) + beats - 1
        pops.append(last)
    return last
