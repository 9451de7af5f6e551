"""Bad input to the kernel: steps whose streams break the rules, and what the kernel must do with them.

The cases are catalogued in ``models/kernel/bad_input.py`` (name, error code, response); the kernel's documented
response (``rtl/README.md``, "Bad input") is modelled here on top of the golden model:

* a body-in record with a non-finite word or a negative inverse mass / inertia, or cut short, makes a *frozen*
  body: integration passes its record through unchanged and every manifold naming it is rejected; bodies
  missing from a short body stream are frozen zero records;
* a constraint record that names a body out of range or the same body twice, holds a non-finite word, joins
  two static bodies or names a frozen body is *rejected*, and its manifold slot stays rejected for the rest of
  the step; so are the slots a pass is missing (TLAST early) and a record cut short by TLAST.

The golden model then solves the step with every rejected manifold-pass left out (the passes run one by one
over the slots still accepted, :func:`models.golden.contact_solver.run_pass`), frozen bodies static, and integrates:
its trace (slots numbered as in the stream), body-out stream, issued and rejected counts are what the kernel
must produce, bit for bit. :class:`StepBuilder` makes such steps from one good job; :func:`save_steps` /
:func:`load_steps` carry a scenario (a list of steps run one after the other without a reset) to the cocotb
test through an ``.npz``.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

import numpy as np

from models.kernel import stream_format as sf
from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import CONTACT_PASS, Impulses, PassRecord, pass_sequence, run_pass, schedule_levels
from models.golden.integrator import integrate
from models.kernel.kernel_job import KernelJob

from cocotb_tests.tb.scoreboard import ExpectedTrace, expected_trace
from models.order import manifold_schedule

NEVER = 1 << 30  # "rejected from pass NEVER": accepted in every pass


@dataclass
class Step:
    """One kernel run: arguments, the streams as sent, and what must come back."""

    label: str
    args: dict[str, Any]  # num_bodies, num_manifolds, iterations, dt, gravity, damping, options
    body_in: np.ndarray  # uint8, as streamed
    passes: list[np.ndarray]  # uint8 per pass, as streamed (one MM2S transfer each, TLAST on its last beat)
    body_out: np.ndarray  # uint8, expected (empty: no body-out at all)
    trace: Optional[ExpectedTrace]  # expected trace (None: not checked)
    status: int = 0  # expected status register
    issued: int = 0
    rejected: int = 0
    action: str = ""  # "", "start_busy" (write ap_start during the run), "reset" (reset the kernel and DMAs)
    action_cycle: int = 0  # cycles after ap_start


class StepBuilder:
    """Steps derived from one good job (body table, constraints, schedule, solver and integration parameters)."""

    def __init__(self, job: KernelJob, cons_beat_bits: int):
        self.job = job
        self.fmt = job.fmt
        self.beat_bits = cons_beat_bits
        self.layout = sf.StreamLayout(job.fmt, cons_beat_bits=cons_beat_bits)
        self.slots = manifold_schedule.schedule_manifolds(job.schedule)
        self.passes = pass_sequence(job.params)

    # --- streams ----------------------------------------------------------------------------------------
    def body_stream(self, bodies: BodyTable) -> np.ndarray:
        return sf.pack_body_table(self.fmt, bodies).data.reshape(-1)

    def pass_streams(self, cons: ConstraintSet) -> list[np.ndarray]:
        stream = sf.pack_constraint_stream(self.fmt, cons, self.job.schedule, self.job.params, self.beat_bits)
        return [p.reshape(-1) for p in np.split(stream.data, np.flatnonzero(stream.last)[:-1] + 1)]

    def record_bytes(self, p: int) -> int:
        """Bytes of one record of pass ``p``."""
        kind = self.passes[p][0]
        return self.layout.contact_bytes if kind == CONTACT_PASS else self.layout.friction_bytes

    # --- the kernel's checks ------------------------------------------------------------------------------
    def frozen_bodies(self, bodies: BodyTable) -> set[int]:
        """Bodies whose record the kernel freezes: a non-finite word, a negative inverse mass or inertia."""
        words = sf.body_in_words(self.fmt, bodies)
        vals = self.fmt.decode(words)
        bad = ~np.all(np.isfinite(vals), axis=1) | np.any(vals[:, 13:17] < 0, axis=1)
        return {int(b) for b in np.flatnonzero(bad)}

    def rejections(self, bodies: BodyTable, cons: ConstraintSet, frozen: set[int]) -> dict[int, int]:
        """slot -> first pass in which the kernel rejects it (checks of the record and its bodies)."""
        nb = bodies.num_bodies
        dyn = (bodies.inv_mass != 0.0) & ~np.isin(np.arange(nb), list(frozen))
        c_ok = np.all(np.isfinite(self.fmt.decode(sf.contact_words(self.fmt, cons, self.slots))), axis=1)
        f_ok = np.all(np.isfinite(self.fmt.decode(sf.friction_words(self.fmt, cons, self.slots))), axis=1)
        out: dict[int, int] = {}
        for k, m in enumerate(self.slots):
            a, b = int(cons.body_a[m]), int(cons.body_b[m])
            if a >= nb or b >= nb or a == b or a in frozen or b in frozen or not (dyn[a] or dyn[b]):
                out[k] = 0
                continue
            for p, (kind, _) in enumerate(self.passes):
                if not (c_ok[k] if kind == CONTACT_PASS else f_ok[k]):
                    out[k] = p
                    break
        return out

    # --- expectations -------------------------------------------------------------------------------------
    def golden(self, bodies: BodyTable, cons: ConstraintSet, drop_from: dict[int, int],
               frozen: set[int]) -> tuple[list[PassRecord], BodyTable, int]:
        """The golden step without the rejected manifold-passes: (trace records, final bodies, issued)."""
        eff = bodies.copy()
        for b in frozen:
            eff.inv_mass[b] = 0.0
            eff.inv_inertia[b] = 0.0
        out = eff.copy()
        imp = Impulses.zeros(cons.num_manifolds)
        records: list[PassRecord] = []
        issued = 0
        for p, (kind, it) in enumerate(self.passes):
            keep = np.array([m for k, m in enumerate(self.slots) if drop_from.get(k, NEVER) > p], dtype=np.int64)
            issued += len(keep)
            levels = schedule_levels(keep, cons, eff.dynamic)
            run_pass(out, imp, cons, levels, self.fmt, kind, it, self.job.params, keep, records.append)
        return records, integrate(out, self.fmt, self.job.iparams), issued

    def step(self, label: str, status: int = 0, bodies: Optional[BodyTable] = None,
             cons: Optional[ConstraintSet] = None, body_in: Optional[np.ndarray] = None,
             passes: Optional[list[np.ndarray]] = None, extra_drops: Optional[dict[int, int]] = None,
             missing_bodies: int = 0, cut_bodies: tuple[int, ...] = (), action: str = "",
             action_cycle: int = 0) -> Step:
        """A step from (mutated) ``bodies`` / ``cons`` and (edited) streams: ``body_in`` / ``passes`` replace the
        packed streams, ``extra_drops`` adds slot rejections the streams cause (slot -> first pass),
        ``missing_bodies`` says how many trailing bodies the body stream lacks (frozen zero records),
        ``cut_bodies`` which body records it cuts short (frozen; pos, q, v, w sit in their first beats)."""
        job = self.job
        bodies = job.bodies if bodies is None else bodies
        cons = job.cons if cons is None else cons
        nb = bodies.num_bodies
        frozen = self.frozen_bodies(bodies) | set(cut_bodies)
        eff = bodies.copy()
        for b in range(nb - missing_bodies, nb):  # a missing body is loaded as a zero record
            for f in dataclasses.fields(eff):
                getattr(eff, f.name)[b] = 0.0
            frozen.add(b)
        drops = self.rejections(eff, cons, frozen)
        for k, p in (extra_drops or {}).items():
            drops[k] = min(drops.get(k, NEVER), p)
        records, final, issued = self.golden(eff, cons, drops, frozen)
        trace = expected_trace(self.fmt, records, cons.body_a, cons.body_b)
        slot_of = np.empty(cons.num_manifolds, dtype=np.int64)
        slot_of[self.slots] = np.arange(len(self.slots))
        trace = dataclasses.replace(trace, slot=slot_of[trace.manifold])
        args = {"num_bodies": nb, "num_manifolds": len(self.slots), "iterations": job.params.iterations,
                "dt": job.iparams.dt, "gravity": list(job.iparams.gravity), "damping": job.iparams.damping,
                "options": int(job.params.interleaved)}
        total = len(self.slots) * len(self.passes)
        return Step(label, args, self.body_stream(bodies) if body_in is None else body_in,
                    self.pass_streams(cons) if passes is None else passes,
                    sf.pack_body_out(self.fmt, final).data.reshape(-1), trace, status, issued, total - issued,
                    action, action_cycle)


# --- files ----------------------------------------------------------------------------------------------
_TRACE_FIELDS = [f.name for f in dataclasses.fields(ExpectedTrace)]


def save_steps(path: Path, steps: list[Step], meta: dict[str, Any]) -> None:
    """Write a scenario (its steps in order, plus ``meta``: format, DMA preset, seed, ...) to ``path``."""
    arrays: dict[str, np.ndarray] = {}
    info = []
    for i, s in enumerate(steps):
        arrays[f"s{i}_body_in"] = s.body_in
        arrays[f"s{i}_body_out"] = s.body_out
        for p, data in enumerate(s.passes):
            arrays[f"s{i}_pass{p}"] = data
        if s.trace is not None:
            for name in _TRACE_FIELDS:
                arrays[f"s{i}_trace_{name}"] = getattr(s.trace, name)
        info.append({"label": s.label, "args": s.args, "passes": len(s.passes), "trace": s.trace is not None,
                     "status": s.status, "issued": s.issued, "rejected": s.rejected, "action": s.action,
                     "action_cycle": s.action_cycle})
    np.savez(path, meta=np.array(json.dumps({**meta, "steps": info})), **arrays)


def load_steps(path: Path) -> tuple[list[Step], dict[str, Any]]:
    with np.load(path, allow_pickle=False) as npz:
        data = dict(npz)
    meta = json.loads(str(data["meta"]))
    steps = []
    for i, s in enumerate(meta["steps"]):
        trace = ExpectedTrace(*(data[f"s{i}_trace_{n}"] for n in _TRACE_FIELDS)) if s["trace"] else None
        steps.append(Step(s["label"], s["args"], data[f"s{i}_body_in"],
                          [data[f"s{i}_pass{p}"] for p in range(s["passes"])], data[f"s{i}_body_out"], trace,
                          s["status"], s["issued"], s["rejected"], s["action"], s["action_cycle"]))
    return steps, meta


@dataclass
class StepReport:
    """What a step did in the simulator (written to the scenario's result JSON)."""

    label: str
    cycles: int
    status: int
    issued: int
    rejected: int
    records_compared: int
    notes: list[str] = field(default_factory=list)
