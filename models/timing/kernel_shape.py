"""What the cycle model (``models/timing/cycle_model.py``) reads off the RTL and the harness: the timing structure of a
kernel build (pipe latencies from ``rtl/generated/pipe_latency.json``, beats per record, queue depths), the
harness's DMA model and the shape of a step (the bodies of every slot, which are dynamic, the passes)."""

from __future__ import annotations

import functools
import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from models.golden.contact_solver import CONTACT_PASS, SolverParams, is_shock_pass, pass_sequence
from models.kernel.body_banks import check_banks
from models.timing.platforms import DmaPreset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import NumberFormat
from models.golden.shock_propagation import ShockConstraintSet
from models.kernel.stream_format import KERNEL_INERTIA_WORDS, RecordBits, StreamLayout

RTL_DIR = Path(__file__).resolve().parents[2] / "rtl"
HAZARD_DEPTH = 256  # pgs_kernel defaults
OUT_FIFO_DEPTH = 64
IMPULSE_FIFO_DEPTH = 256  # IMP_FIFO_DEPTH: impulse-out records between take and handshake (impulses in the records)

# written by `python -m rtl.gen` with the datapaths (rtl/gen/pipe_latency.py)
PIPE_LATENCY_FILE = RTL_DIR / "generated" / "pipe_latency.json"
SHARED_PIPE = "pgs_shared_pipe"  # the shared datapath of a lane (every variant has its latency: rtl/gen/kernel_graphs.py)


@functools.lru_cache(maxsize=None)
def _latency_terms(latency_file: Path) -> dict[str, tuple[tuple[int, int], ...]]:
    """Each module's latency terms ``(cycles, per_man_bit)`` from the generator's JSON."""
    try:
        pipes = json.loads(latency_file.read_text())["pipes"]
        return {module: tuple((int(t["cycles"]), int(t["per_man_bit"])) for t in entry["terms"])
                for module, entry in pipes.items()}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ValueError(f"{latency_file}: not a pipe latency file of rtl/gen ({exc}); run `python -m rtl.gen`") from exc


def rtl_latency(module: str, fmt: NumberFormat, latency_file: Path = PIPE_LATENCY_FILE) -> int:
    """The ``LATENCY`` of a generated datapath (``rtl/generated/<module>.sv``) for ``fmt``, from
    ``rtl/generated/pipe_latency.json``: the maximum over its terms of ``cycles + per_man_bit * MAN_BITS``
    (e.g. ``4*MAN_BITS + 94``)."""
    terms = _latency_terms(latency_file)
    if module not in terms or not terms[module]:
        raise ValueError(f"{latency_file} has no latency of {module} (modules: {', '.join(sorted(terms))})")
    return max(cycles + per_man_bit * fmt.man_bits for cycles, per_man_bit in terms[module])


@dataclass(frozen=True)
class KernelShape:
    """The timing structure of one kernel build: pipe latencies, beats per record, queue depths."""

    contact_latency: int
    friction_latency: int
    integrate_latency: int
    contact_beats: int
    friction_beats: int
    body_in_beats: int
    body_out_beats: int
    cons_beat_bytes: int
    body_beat_bytes: int = 16  # BODY_IN_W = BODY_OUT_W = 128
    hazard_depth: int = HAZARD_DEPTH
    out_fifo_depth: int = OUT_FIFO_DEPTH
    impulse_fifo_depth: int = IMPULSE_FIFO_DEPTH

    impulses_in_records: bool = False  # IMPULSES_IN_RECORDS: the read-after-write rule across passes applies
    body_banks: int = 0  # BODY_BANKS: banked body velocities, a busy bank stalls the issue (models.kernel.body_banks)
    window_beats: int = 0  # beats of one lane's combined record of the window kernel (WR_BEATS; 0: no such layout)
    # SHARED_DATAPATH: one datapath per lane takes both kinds at one latency (no drain at a switch of kinds); else a
    # contact and a friction pipe, drained at a switch in the streaming kernel
    shared_datapath: bool = True

    @staticmethod
    def of(fmt: NumberFormat, cons_bits: int = 512, body_bits: int = 128,
           inertia_words: int = KERNEL_INERTIA_WORDS, impulses_in_records: bool = False,
           friction_words: int = 0, body_banks: int = 0, tangents_on_chip: bool = False,
           record_bits: RecordBits | None = None, shared_datapath: bool = True) -> "KernelShape":
        """The shape of a build; ``inertia_words`` (1, 3 or 6) sets the body-in record's beats,
        ``impulses_in_records`` the records' (with the impulses they carry), ``friction_words`` (0 or 1, the
        build's MU_W) the friction record's (every friction pipe has the same latency), ``body_banks`` the
        build's BODY_BANKS, ``tangents_on_chip`` the friction record without t0, t1 and the friction pipe that
        derives them (``pgs_friction_pipe_tb``, its own latency), ``record_bits`` the records' bits of mixed
        storage (``models/sizing/mixed_layout.py``; the pipes' latencies stay the format's), ``shared_datapath`` the
        build's SHARED_DATAPATH (both kinds at the shared datapath's latency, ``pgs_shared_pipe``; else each kind at
        its pipe's)."""
        lay = StreamLayout(fmt, cons_beat_bits=cons_bits, body_beat_bits=body_bits, inertia_words=inertia_words,
                           impulses_in_records=impulses_in_records, friction_words=friction_words,
                           tangents_on_chip=tangents_on_chip, record_bits=record_bits)
        friction = "pgs_friction_pipe_tb" if tangents_on_chip else "pgs_friction_pipe"
        contact, friction = (SHARED_PIPE, SHARED_PIPE) if shared_datapath else ("pgs_contact_pipe", friction)
        return KernelShape(rtl_latency(contact, fmt), rtl_latency(friction, fmt),
                           rtl_latency("pgs_integrate_pipe", fmt), lay.contact_beats, lay.friction_beats,
                           lay.body_in_beats, lay.body_out_beats, cons_bits // 8, body_bits // 8,
                           impulses_in_records=impulses_in_records, body_banks=check_banks(body_banks),
                           window_beats=lay.window_beats if record_bits is None else 0,
                           shared_datapath=shared_datapath)

    def latency(self, kind: int) -> int:
        return self.contact_latency if kind == CONTACT_PASS else self.friction_latency

    def beats(self, kind: int) -> int:
        return self.contact_beats if kind == CONTACT_PASS else self.friction_beats


def harness_ddr_millibytes(preset: DmaPreset, read_share: float = 1.0) -> int:
    """The DDR rate argument of the harness (1/1000 bytes per cycle; 0 = uncapped), as sim.drive.harness_run passes it:
    the ``read_share`` of the preset's rate (``StreamLayout.ddr_read_share``: the impulse writes take the rest)."""
    if not 0.0 < read_share <= 1.0:
        raise ValueError(f"DDR read share must be in (0, 1], got {read_share}")
    rate = preset.ddr_bytes_per_cycle
    return 0 if rate == math.inf else max(1, round(rate * read_share * 1000))


@dataclass(frozen=True)
class DmaTiming:
    """The harness's DMA model: DDR token bucket (``rate`` bytes per cycle, 0 = uncapped; capped at two
    constraint beats) and the start-up latency of each transfer. ``prefetched``: the first body-in and
    constraint transfers are already under way at ap_start with a full bucket (the cocotb host arms them
    before it starts the kernel), which makes the prediction a lower bound for that path."""

    rate: float
    startup: int
    prefetched: bool = False
    turnaround: int = 1  # impulses in the records: an impulse-out record to the first beat of its reader

    @staticmethod
    def of(preset: DmaPreset, prefetched: bool = False, read_share: float = 1.0) -> "DmaTiming":
        return DmaTiming(harness_ddr_millibytes(preset, read_share) / 1000.0, preset.startup_cycles, prefetched,
                         preset.impulse_turnaround_cycles)


@dataclass(frozen=True)
class StepShape:
    """What of a step the timing depends on: the bodies of every slot, which bodies are dynamic, the passes."""

    num_bodies: int
    body_a: np.ndarray  # (M,) per slot (record index within a pass)
    body_b: np.ndarray
    dynamic: np.ndarray  # (N,) the body RAM's flag: the inverse mass's exponent is not zero (after rounding)
    passes: tuple[tuple[int, int], ...]  # (kind, iteration) in stream order
    # shock propagation (models/golden/shock_propagation.py): per pass whether it is a shock pass, and per slot the body
    # a shock pass does not write (FREEZE_NONE / FREEZE_A / FREEZE_B); the hazards are those of the other passes
    shock_passes: tuple[bool, ...] = ()
    frozen: np.ndarray | None = None

    @staticmethod
    def of(fmt: NumberFormat, inv_mass: np.ndarray, body_a: np.ndarray, body_b: np.ndarray,
           params: SolverParams, frozen: np.ndarray | None = None) -> "StepShape":
        exp = (np.asarray(fmt.encode(inv_mass), dtype=np.uint64) >> np.uint64(fmt.man_bits)) & \
            np.uint64((1 << fmt.exp_bits) - 1)
        passes = tuple(pass_sequence(params))
        shock = tuple(is_shock_pass(params, kind, it) for kind, it in passes)
        return StepShape(len(inv_mass), np.asarray(body_a, np.int64), np.asarray(body_b, np.int64), exp != 0,
                         passes, shock if any(shock) else (), frozen if any(shock) else None)

    @staticmethod
    def of_job(job: "KernelJob") -> "StepShape":
        """The step of ``job``'s slots; an empty lane of the window kernel (slot -1) names no body (-1, -1)."""
        slots = job.slots
        real = slots >= 0
        idx = np.where(real, slots, 0)
        frozen = job.cons.frozen[idx] if isinstance(job.cons, ShockConstraintSet) else None
        return StepShape.of(job.fmt, job.bodies.inv_mass, np.where(real, job.cons.body_a[idx], -1),
                            np.where(real, job.cons.body_b[idx], -1), job.params, frozen)

    @property
    def num_slots(self) -> int:
        return int(self.body_a.shape[0])

    def rejected_slots(self) -> np.ndarray:
        """Slots the kernel rejects in every pass: a body index out of range, the same body twice, or no
        dynamic body (bad body-in records are not modeled)."""
        a, b, n = self.body_a, self.body_b, self.num_bodies
        bad = (a >= n) | (b >= n) | (a == b) | (a < 0) | (b < 0)
        dyn = np.zeros(len(a), dtype=bool)
        ok = ~bad
        dyn[ok] = self.dynamic[a[ok]] | self.dynamic[b[ok]]
        return bad | ~dyn
