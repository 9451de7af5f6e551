"""Cycle model of the PGS kernel (``rtl/pgs_kernel.sv``) behind the compiled harness's DMA model.

It predicts, without running Verilator, the cycle at which every manifold-pass retires (the ``trace.bin`` cycle
of ``sim/harness/pgs_kernel_main.cpp``), the kernel's stall and bubble counters and its total cycles
(register 0x60). Everything below is read off the RTL and the harness; cycles count from 0 = the first cycle in
LOAD (the harness's ``s.cycle - start_cycle``), the cycle in which a value is visible before the clock edge.

Harness (deterministic streams: random gap 0 and backpressure 0)
    * DDR: a token bucket of bytes, ``rate`` = the preset's bytes per cycle rounded to 1/1000 byte, capped at
      two constraint beats, in IEEE doubles (the model repeats the harness's additions in its order, so a
      credit that lands exactly on a beat size resolves the same way). Each cycle: refill, then the body-in
      beat is offered (and spends), then the constraint beat, then m_axis TREADY = credit for a body-out beat.
    * A beat is offered when the previous one was taken, its transfer's start-up latency ``S`` has run out
      (the body-in transfer and each pass's transfer: first beat offered ``S`` cycles after the previous
      pass's last beat was taken, at cycle ``S - 1`` for the first transfers) and the bucket holds its bytes.
Kernel
    * LOAD: body-in records (``body_in_beats`` each) take one beat per cycle; the last body's final beat at
      cycle ``L`` is written at ``L + 2``, SOLVE starts at ``L + 3``.
    * Constraint assembler (``pgs_record_asm``): one accumulation register and the record register; the first
      beat of record ``r`` is taken no earlier than ``m(r-1)``, the cycle record ``r-1`` moves into the record
      register, ``m(r) = max(final beat(r) + 1, issue(r-1))``; record ``r`` is valid (assembled) from
      ``m(r) + 1``. A contact record of two beats thus issues at most every other cycle.
    * Issue of record ``r`` at the first cycle >= its valid cycle and SOLVE's start with: no dynamic body in
      flight (a manifold is in the hazard CAM from its issue to its retire cycle inclusive: a conflicting
      record issues at ``retire + 1`` at the earliest), at a contact/friction switch the other pipe drained
      (``retire of the last issued + 1``), fewer than ``HAZARD_DEPTH`` in flight. It retires at
      ``issue + 1 + LATENCY`` of its pipe (``LATENCY`` from ``rtl/generated/pipe_latency.json``).
      With banked body velocities (``BODY_BANKS``, :mod:`models.kernel.body_banks`) it also waits while a bank cannot
      serve the reads of its bodies A and B beside the writes of the manifold retiring in that cycle
      (:class:`BankWrites`).
      Records the kernel rejects (a body index >= num_bodies, the same body twice, two static bodies; such a
      slot stays rejected for the whole step) are consumed at their valid cycle without issuing.
    * Impulses in the records (:class:`ImpulseOut`): every take queues an impulse-out record, taken the cycle after
      its retire (a rejected record's: after its take) and after the one before; a take waits while the order FIFO
      (``IMP_FIFO_DEPTH``) is full, which with TREADY up never happens (a record leaves at most LATENCY + 2 cycles
      after its take). Record s of pass p > 0 is offered no earlier than the turnaround after pass p - 1's
      impulse-out record of slot s was taken; DONE waits for the last impulse-out record.
    * DRAIN until the last retire ``R``; INTEG from ``R + 2``: body ``k`` issues one per cycle while fewer than
      ``OUT_FIFO_DEPTH`` bodies are in the pipe or the output FIFO, leaves the integrate pipe ``LATENCY + 1``
      cycles later, and its ``body_out_beats`` beats follow one per cycle (the first at ``issue + 2 +
      LATENCY``). The last beat at ``P`` ends the step: DONE at ``P + 1``, cycles register ``P + 3``.
Counters: a stall cycle is a SOLVE cycle with a record valid that does not issue; a bubble a SOLVE cycle
without one (SOLVE ends with the last issue).

Not modeled: bad input other than rejected slots (a bad body-in record, non-finite words and truncated
records change only which records issue, see rtl/README.md) and the random gaps/backpressure of the harness:
with those the model's figures are lower bounds (:func:`lower_bound`). The cocotb path
(``cocotb_tests/tb/host_driver.py``) arms the first transfers before ap_start: ``DmaTiming(prefetched=True)``
is its lower bound.

The window kernel (a job with ``record_window``) has its own model, ``models/timing/window_cycle_model.py``, on the pieces
here (the DDR bucket, LOAD, DRAIN, INTEG and DONE); :func:`predict_job` dispatches to it.

    pred = predict_job(job, get_preset("zcu102"))
    pred.cycles, pred.retire, pred.explain(812)
"""

from __future__ import annotations

from array import array
from collections import deque
from itertools import chain
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol, Sequence

import numpy as np

from models.kernel.body_banks import busy as bank_busy
from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS
from models.timing.platforms import DmaPreset
from models.kernel.kernel_job import KernelJob
from models.timing.kernel_shape import DmaTiming, KernelShape, StepShape
from models.golden.shock_propagation import FREEZE_A, FREEZE_B

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


def predict(shape: KernelShape, dma: DmaTiming, step: StepShape) -> Prediction:
    """Run the cycle model (O(cycles of streaming) in plain Python, seconds for the thesis frame)."""
    nb = step.num_bodies
    if nb == 0:  # IDLE -> INTEG -> DONE: nothing is streamed
        return _empty(shape, done=1)
    load_end = _load_end(shape, dma, nb)
    solve_start = load_end + 3
    solve = _solve(shape, dma, step, body_beat_cycles(shape, nb, load_end), solve_start)
    tail = Tail.after_solve(shape, nb, solve_start, solve.end if solve.takes else None, solve.last_retire,
                            solve.last_impulse_out)
    pred = solve.prediction(shape, step, solve_start, tail.integ_start, tail.done)
    pred.phases = tail.phases
    return pred


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
        done = max(_integrate(shape, nb, integ_start) + 1, last_impulse_out + 2)
        drain = solve_end + 1 if solve_end is not None else solve_start
        return Tail(integ_start, done, {"LOAD": 0, "SOLVE": solve_start, "DRAIN": drain, "INTEG": integ_start,
                                        "DONE": done})


def _job_shape(job: "KernelJob", preset: DmaPreset, body_bits: int) -> KernelShape:
    return KernelShape.of(job.fmt, preset.stream_bits, body_bits, inertia_words=job.inertia_words,
                          impulses_in_records=job.impulses_in_records, friction_words=job.friction_words,
                          body_banks=job.body_banks, tangents_on_chip=job.tangents_on_chip, record_bits=job.record_bits)


def _job_timing(job: "KernelJob", preset: DmaPreset, prefetched: bool) -> DmaTiming:
    return DmaTiming.of(preset, prefetched, job.ddr_read_share(preset.stream_bits))


def predict_job(job: "KernelJob", preset: DmaPreset, prefetched: bool = False, body_bits: int = 128) -> Prediction:
    """The model of ``job`` run by ``sim.drive.kernel_step.run_kernel_step`` with ``preset`` (gap and backpressure 0) on
    body-in and body-out streams of ``body_bits``-bit beats (``make sim BODY_BITS``); a job with a record window
    (``job.record_window``) runs on the window kernel (``models.timing.window_cycle_model``)."""
    shape, dma, step = _job_shape(job, preset, body_bits), _job_timing(job, preset, prefetched), StepShape.of_job(job)
    if job.record_window is not None:
        from models.timing.window_cycle_model import predict_window  # it builds on this module

        return predict_window(shape, dma, step, job.record_window)
    return predict(shape, dma, step)


def check_body_beats(job: "KernelJob", preset: DmaPreset, body_bits: int) -> None:
    """A ValueError where the model cannot take ``job``'s body beats of ``body_bits`` bits on ``preset``: the DDR
    must give one body beat a cycle."""
    _check_body_rate(_job_shape(job, preset, body_bits), _job_timing(job, preset, False))


def lower_bound(job: "KernelJob", preset: DmaPreset, prefetched: bool = False, body_bits: int = 128) -> int:
    """Cycles no run of ``job`` can beat: random stream gaps and backpressure only delay beats (every step of
    the model is a max of earlier events), so the deterministic prediction bounds them from below. The window
    kernel has no such bound (a ValueError): which pass it offers depends on when records arrive and hazards
    clear, so a delay can shorten its step."""
    if job.record_window is not None:
        raise ValueError("the window kernel's cycles under random stream gaps are not bounded by its deterministic "
                         "prediction (its choice of pass changes with them)")
    return predict_job(job, preset, prefetched, body_bits).cycles


def _empty(shape: KernelShape, done: int) -> Prediction:
    z = np.zeros(0, dtype=np.int64)
    return Prediction(shape, z, z, z, z, z, z, z, z, z, z, z, z, z, z, 0, 0, done - 1, done, 0, 0, 0)


def _check_body_rate(shape: KernelShape, dma: DmaTiming) -> None:
    if dma.rate and dma.rate < shape.body_beat_bytes:
        raise ValueError(f"the DDR's {dma.rate:g} B per cycle are less than one {8 * shape.body_beat_bytes}-bit body "
                         "beat per cycle: not modeled (a narrower BODY_BITS)")


def body_beat_cycles(shape: KernelShape, nb: int, load_end: int) -> tuple[int, int]:
    """The first and last cycle of the body-in beats (one a cycle, the last at ``load_end``)."""
    return load_end - nb * shape.body_in_beats + 1, load_end


def _load_end(shape: KernelShape, dma: DmaTiming, nb: int) -> int:
    """Cycle the last body-in beat is taken: one beat per cycle from the transfer's first (the bucket always
    holds a 16-byte beat: it refills by >= 16 bytes a cycle, and a constraint beat only spends what is there)."""
    _check_body_rate(shape, dma)
    first = 0 if dma.prefetched else max(dma.startup - 1, 0)
    return first + nb * shape.body_in_beats - 1


class _Solve:
    """SOLVE's records in take order, filled by :func:`_solve`; the rare fields (stall causes, rejected
    records) are kept sparse."""

    FIELDS = ("ready", "issue", "first_offer", "last_beat", "ddr_wait")

    def __init__(self) -> None:
        self.cols = {name: array("q") for name in self.FIELDS}
        self.waits: dict[int, tuple[int, int]] = {}  # issued index -> (cause, blocker) when cause != READY
        self.rejected: list[int] = []  # stream indices (pass * slots + slot) of rejected records
        self.takes = self.stalls = 0
        self.end = 0  # the last take
        self.last_retire = -1
        self.last_impulse_out = -1  # impulses in the records: the cycle the last impulse-out record was taken

    @property
    def issued(self) -> int:
        return len(self.cols["issue"])

    def prediction(self, shape: KernelShape, step: StepShape, solve_start: int, integ_start: int,
                   done: int) -> Prediction:
        col = {k: np.frombuffer(v, dtype=np.int64).copy() if len(v) else np.zeros(0, np.int64)
               for k, v in self.cols.items()}
        nm = max(step.num_slots, 1)
        idx = np.setdiff1d(np.arange(self.takes, dtype=np.int64), np.asarray(self.rejected, np.int64),
                           assume_unique=True)
        kinds = np.array([k for k, _ in step.passes] or [0], dtype=np.int64)
        iters = np.array([i for _, i in step.passes] or [0], dtype=np.int64)
        kind, slot = kinds[idx // nm], idx % nm
        cause = np.full(self.issued, READY, dtype=np.int64)
        blocker = np.full(self.issued, -1, dtype=np.int64)
        if self.waits:
            at = np.fromiter(self.waits, dtype=np.int64, count=len(self.waits))
            cb = np.array(list(self.waits.values()), dtype=np.int64)
            cause[at], blocker[at] = cb[:, 0], cb[:, 1]
        latency = np.where(kind == CONTACT_PASS, shape.contact_latency, shape.friction_latency)
        issue, ready = col["issue"], col["ready"]
        prev_issue = np.concatenate([[solve_start - 1], issue[:-1]]) if self.issued else issue
        bubble = np.maximum(0, ready - np.maximum(prev_issue + 1, solve_start))
        dyn_a, dyn_b = _dynamic_bodies(step)
        span = self.end - solve_start + 1 if self.takes else 0
        return Prediction(shape, kind, iters[idx // nm], slot, ready, issue, issue + 1 + latency, cause, blocker,
                          bubble, col["first_offer"], col["last_beat"], col["ddr_wait"], dyn_a[slot], dyn_b[slot],
                          solve_start, self.end, integ_start, done, len(self.rejected), self.stalls,
                          span - self.takes - self.stalls)


def _dynamic_bodies(step: StepShape) -> tuple[np.ndarray, np.ndarray]:
    """Per slot: bodies A and B where the kernel tracks them (dynamic, in range), else -1."""
    nb = step.num_bodies

    def tracked(b: np.ndarray) -> np.ndarray:
        ok = (b >= 0) & (b < nb)
        ok[ok] = step.dynamic[b[ok]]
        return np.where(ok, b, -1)

    return tracked(step.body_a), tracked(step.body_b)


def _solve(shape: KernelShape, dma: DmaTiming, step: StepShape, body_beats: tuple[int, int],
           solve_start: int) -> _Solve:
    """Constraint stream (with the DDR bucket, shared with the body-in beats ``body_beats`` = first, last
    cycle), assembler, issue and retire of every record of every pass, in stream order. One hot loop: the
    bucket is inlined (the harness's operations in its order)."""
    out = _Solve()
    nm = step.num_slots
    if nm == 0 or not step.passes:
        return out
    nb = step.num_bodies
    free = nb  # stands in for static bodies: never in flight
    dyn_a, dyn_b = _dynamic_bodies(step)
    a_list = np.where(dyn_a >= 0, dyn_a, free).tolist()
    b_list = np.where(dyn_b >= 0, dyn_b, free).tolist()
    rej = step.rejected_slots().tolist()
    last_ret = [-1] * (nb + 1)  # per body: retire cycle of the last manifold naming it
    last_who = [-1] * (nb + 1)  # and its retire index
    lat = {CONTACT_PASS: shape.contact_latency, FRICTION_PASS: shape.friction_latency}
    nbeats = {CONTACT_PASS: shape.contact_beats, FRICTION_PASS: shape.friction_beats}
    depth = shape.hazard_depth
    pass_gap = max(1, dma.startup)  # after a pass's last beat: the next transfer's start-up latency
    offer_from = first_offer_cycle(dma)  # earliest iteration of the next offer
    ddr = DdrBucket(shape, dma, body_beats)
    c = out.cols
    ready_a, issue_a, off_a, beat_a, wait_a = (c[k].append for k in _Solve.FIELDS)
    issued_at, waits, rejected = c["issue"], out.waits, out.rejected
    retired = array("q")  # retire cycle per issued record (for CAM_FULL)
    m_prev = -1  # the cycle record r-1 moved into the record register
    issue_prev = -1  # the take cycle of record r-2, then r-1
    prev = None  # record r-1: (stream index, kind, first offer, last beat, DDR wait)
    last_kind, last_retire, n_iss, stalls = CONTACT_PASS, -1, 0, 0
    # impulses in the records: each take (issued or rejected) queues an impulse-out record (ImpulseOut); record s of
    # the next pass is offered no earlier than `turnaround` cycles after slot s's record was taken (the
    # read-after-write rule)
    in_records, turnaround = shape.impulses_in_records, dma.turnaround
    imp = ImpulseOut(shape.impulse_fifo_depth) if in_records else None
    out_taken = [0] * nm  # per slot: the cycle its latest impulse-out record was taken
    # banked body velocities: per slot the bodies read at issue and the dynamic ones written at retire (BankWrites)
    banks = shape.body_banks
    bank_writes = BankWrites(banks)
    reads = list(zip(step.body_a.tolist(), step.body_b.tolist()))
    writes = [tuple(x for x in (a, b) if x >= 0) for a, b in zip(dyn_a.tolist(), dyn_b.tolist())]
    # a shock pass does not write its rows' frozen bodies (the hazards stay: the CAM holds both)
    shock_writes = writes if step.frozen is None else [
        tuple(x for x, frozen in ((a, f == FREEZE_A), (b, f == FREEZE_B)) if x >= 0 and not frozen)
        for a, b, f in zip(dyn_a.tolist(), dyn_b.tolist(), step.frozen.tolist())]
    shock_pass = step.shock_passes or (False,) * len(step.passes)
    stream = ((p * nm + s, kind, s) for p, (kind, _) in enumerate(step.passes) for s in range(nm))
    for rec in chain(stream, (None,)):
        if prev is not None:  # take record r-1: valid from m_prev + 1
            r_idx, kind, f_off, l_beat, wait = prev
            s = r_idx % nm
            ready = m_prev + 1
            t = ready if ready >= solve_start else solve_start
            if rej[s]:
                rejected.append(r_idx)
                if imp is not None and imp.room_from() > t:
                    t = imp.room_from()
                ret = t
            else:
                cause = READY if ready >= solve_start else SOLVE_START
                who = -1
                a, b = a_list[s], b_list[s]
                ha, hb = last_ret[a] + 1, last_ret[b] + 1
                if ha > t or hb > t:
                    t, cause, who = (ha, HAZARD, last_who[a]) if ha >= hb else (hb, HAZARD, last_who[b])
                if kind != last_kind and last_retire + 1 > t:
                    t, cause, who = last_retire + 1, SWITCH, n_iss - 1
                if n_iss >= depth and retired[n_iss - depth] + 1 > t:
                    t, cause, who = retired[n_iss - depth] + 1, CAM_FULL, n_iss - depth
                if imp is not None and imp.room_from() > t:
                    t, cause, who = imp.room_from(), IMP_FULL, -1
                while banks:  # the writes retiring at t are served first (models.kernel.body_banks)
                    writer = bank_writes.blocker(t, reads[s])
                    if writer < 0:
                        break
                    t, cause, who = t + 1, BANK_BUSY, writer
                if cause != READY:
                    waits[n_iss] = (cause, who)
                ret = t + 1 + lat[kind]
                last_ret[a] = last_ret[b] = ret
                last_who[a] = last_who[b] = n_iss
                last_ret[free] = last_who[free] = -1
                last_kind, last_retire = kind, ret
                retired.append(ret)
                if banks:
                    bank_writes.add(ret, shock_writes[s] if shock_pass[r_idx // nm] else writes[s], n_iss)
                ready_a(ready)
                issue_a(t)
                off_a(f_off)
                beat_a(l_beat)
                wait_a(wait)
                n_iss += 1
            stalls += t - (ready if ready >= solve_start else solve_start)
            issue_prev = t
            if imp is not None:
                out_taken[s] = imp.push(ret)
        if rec is None:
            break
        r_idx, kind, s = rec
        # the beats of record r: offered when the previous one was taken and the bucket holds a beat; the
        # first is taken no earlier than the accumulation register frees (m_prev), the rest as offered
        f_off = x = wait = 0
        for j in range(nbeats[kind]):
            y = offer_from
            if j == 0 and in_records and r_idx >= nm and out_taken[s] + turnaround > y:
                y = out_taken[s] + turnaround  # waits for the previous pass's write of the slot's impulses
            y0 = y
            y = ddr.offer(y)
            wait += y - y0
            if j == 0:
                f_off = y
                x = y if y > m_prev else m_prev
            else:
                x = y
            offer_from = x + 1
        if s == nm - 1:  # TLAST taken: the host starts the next pass's transfer
            offer_from = x + pass_gap
        m_prev = x + 1 if x + 1 > issue_prev else issue_prev
        prev = (r_idx, kind, f_off, x, wait)
    out.takes = len(issued_at) + len(rejected)
    out.stalls = stalls
    out.end = issue_prev
    out.last_retire = last_retire
    out.last_impulse_out = imp.last if imp is not None else -1
    return out


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
    """Banked body velocities (:mod:`models.kernel.body_banks`) over time: the dynamic bodies the issued manifolds write at
    their retire, in retire order; a record's reads of bodies A and B are served in a cycle only beside the writes of
    the manifold retiring then. Ask in time order: the writes retired before the cycle asked for are dropped."""

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


def _integrate(shape: KernelShape, nb: int, start: int) -> int:
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


# --- checks against a measured trace ---------------------------------------------------------------------
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


def compare_trace(pred: Prediction, cycle: np.ndarray, kind: np.ndarray, iteration: np.ndarray, slot: np.ndarray,
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
    """:func:`compare_trace` on a kernel run's trace, total and stall / bubble counters."""
    if run.trace is None:
        raise ValueError("the run kept no trace (run_kernel_step(..., keep_trace=True))")
    tr = run.trace
    return compare_trace(pred, tr.cycle, tr.kind, tr.iteration, tr.slot, run.cycles, slots, run.registers)


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
