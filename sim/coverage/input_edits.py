"""Bad input made by editing the compiled harness's input files (``sim.drive.harness_run.write_inputs``: registers,
body and constraint streams with their TLAST files), for the coverage regression.

Each :class:`HarnessEdit` names the cases of the bad-input catalogue (``models/kernel/bad_input.py``) it makes (the
bracketed numbers in the edits' descriptions are the error codes, ``models.kernel.register_map.ErrorCode``);
:data:`BAD_INPUT_EDITS` makes every catalogue case the harness can make. The other edits (:func:`edit_gravity`,
:func:`edit_wide_index`, :func:`edit_spin`, :func:`edit_mass_spread`) are not bad input: register operands, body indices
and body state the test scenes never reach.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from models.kernel.register_map import AP_START, ARG_NAMES, AUTO_RESTART, OFFSET
from models.kernel.stream_format import (BODY_ANGULAR_VELOCITY, BODY_INV_INERTIA, BODY_INV_MASS, BODY_LINEAR_VELOCITY,
                                         BODY_POSITION, EMPTY_HEADER)
from sim.compile.kernel_build import KernelBuild

UNMAPPED_ADDRESS = 0xF4  # no register there (rtl/README.md: reads 0, ignores writes, SLVERR, error 9)


def set_bits(rows: np.ndarray, bit: int, nbits: int, value: int) -> None:
    """Bits [bit, bit + nbits) of the record held in ``rows`` (its beats, little-endian from bit 0) := value."""
    v = int.from_bytes(rows.tobytes(), "little")
    mask = ((1 << nbits) - 1) << bit
    v = (v & ~mask) | ((value << bit) & mask)
    rows[...] = np.frombuffer(v.to_bytes(rows.size, "little"), np.uint8).reshape(rows.shape)


class HarnessFiles:
    """The harness's input files of one run (``sim.drive.harness_run.write_inputs``) as arrays, to make bad input."""

    def __init__(self, run_dir: Path, kb: KernelBuild):
        self.dir, self.w = run_dir, kb.fmt.width
        self.regs = np.fromfile(run_dir / "regs.bin", dtype="<u4").reshape(-1, 2)
        self.streams = {s: (np.fromfile(run_dir / f"{f}.bin", dtype=np.uint8).reshape(-1, nbytes),
                            np.fromfile(run_dir / f"{f}_last.bin", dtype=np.uint8))
                        for s, f, nbytes in (("body", "body_in", kb.body_in_bits // 8),
                                             ("cons", "cons", kb.cons_bits // 8))}
        self.body_beats = len(self.streams["body"][1]) // max(self.reg("num_bodies"), 1)

    def save(self) -> None:
        self.regs.tofile(self.dir / "regs.bin")
        for s, f in (("body", "body_in"), ("cons", "cons")):
            data, last = self.streams[s]
            np.ascontiguousarray(data).tofile(self.dir / f"{f}.bin")
            last.tofile(self.dir / f"{f}_last.bin")

    def reg(self, name: str) -> int:
        return int(self.regs[self.regs[:, 0] == OFFSET[name], 1][0])

    def set_reg(self, name: str, value: int) -> None:
        self.regs[self.regs[:, 0] == OFFSET[name], 1] = value

    def record(self, stream: str, p: int, k: int) -> np.ndarray:
        """Beat indices of record ``k`` of pass ``p`` (the body stream has one pass)."""
        last = self.streams[stream][1]
        ends = np.flatnonzero(last) + 1
        lo, hi = (0 if p == 0 else int(ends[p - 1])), int(ends[p])
        per = self.body_beats if stream == "body" else (hi - lo) // self.reg("num_manifolds")
        return np.arange(lo + k * per, lo + (k + 1) * per)

    def word(self, stream: str, p: int, k: int, bit: int, nbits: int) -> int:
        """Bits [bit, bit + nbits) of record ``k`` of pass (fetch) ``p``."""
        v = int.from_bytes(self.streams[stream][0][self.record(stream, p, k)].tobytes(), "little")
        return (v >> bit) & ((1 << nbits) - 1)

    def set_word(self, stream: str, p: int, k: int, bit: int, nbits: int, value: int) -> None:
        data = self.streams[stream][0]
        beats = self.record(stream, p, k)
        rows = data[beats]
        set_bits(rows, bit, nbits, value)
        data[beats] = rows

    def restream(self, stream: str, order: np.ndarray, last_at: Iterable[int]) -> None:
        """The stream made of the beats ``order`` (original indices, repeats allowed), TLAST exactly on the
        positions ``last_at`` of the new stream."""
        data, _ = self.streams[stream]
        last = np.zeros(len(order), np.uint8)
        last[list(last_at)] = 1
        self.streams[stream] = (data[order], last)

    @property
    def passes(self) -> int:
        return int(np.count_nonzero(self.streams["cons"][1]))


Edit = Callable[[HarnessFiles, KernelBuild], None]


def nonfinite_bits(kb: KernelBuild, sign: int = 0, payload: int = 1) -> int:
    return (sign << (kb.fmt.width - 1)) | (((1 << kb.fmt.exp_bits) - 1) << kb.fmt.man_bits) | payload


def edit_body_index(f: HarnessFiles, kb: KernelBuild) -> None:
    """[4] slot 0 names body num_bodies + 3, slot 1 names its body A twice, in every pass."""
    for p in range(f.passes):
        f.set_word("cons", p, 0, 0, 32, f.reg("num_bodies") + 3)
        a = int.from_bytes(f.streams["cons"][0][f.record("cons", p, 1)[0], 0:4].tobytes(), "little")
        f.set_word("cons", p, 1, 32, 31, a)


def edit_nonfinite(f: HarnessFiles, kb: KernelBuild) -> None:
    """[5] NaN in slot 2's normal (first contact pass) and slot 3's (last friction pass); a NaN position (body 1)
    and a -inf angular velocity (body 3): frozen bodies."""
    f.set_word("cons", 0, 2, 64, kb.fmt.width, nonfinite_bits(kb))
    f.set_word("cons", f.passes - 1, 3, 64, kb.fmt.width, nonfinite_bits(kb))
    w = kb.fmt.width
    f.set_word("body", 0, 1, BODY_POSITION * w, w, nonfinite_bits(kb))  # position x
    f.set_word("body", 0, 3, BODY_ANGULAR_VELOCITY * w, w, nonfinite_bits(kb, sign=1, payload=0))  # angular x


def edit_mass(f: HarnessFiles, kb: KernelBuild) -> None:
    """[6] a negative inverse mass (body 2) and inertia (body 4): frozen; [7] inverse mass 0 (body 1): the
    manifold between the ground and body 1 joins two static bodies."""
    w = kb.fmt.width
    f.set_word("body", 0, 2, BODY_INV_MASS * w, w, int(kb.fmt.encode(-1.0)))
    f.set_word("body", 0, 4, (BODY_INV_INERTIA + 1) * w, w, int(kb.fmt.encode(-2.0)))  # inverse inertia y
    f.set_word("body", 0, 1, BODY_INV_MASS * w, w, 0)


def edit_tlast_early(f: HarnessFiles, kb: KernelBuild) -> None:
    """[1] pass 0 ends two records early (its missing slots are rejected); pass 1's last record is cut short by
    TLAST on its first beat (when records take more than one beat: fp32 contact records take two; the window
    kernel's stream of one fetch per step has no second transfer)."""
    nm = f.reg("num_manifolds")
    last = f.streams["cons"][1]
    ends = set(np.flatnonzero(last).tolist())
    drop = [f.record("cons", 0, k) for k in (nm - 2, nm - 1)]
    ends = (ends - {int(drop[-1][-1])}) | {int(f.record("cons", 0, nm - 3)[-1])}
    cut = f.record("cons", 1, nm - 1) if f.passes > 1 else np.zeros(0, np.int64)
    if len(cut) > 1:
        drop.append(cut[1:])
        ends = (ends - {int(cut[-1])}) | {int(cut[0])}
    keep = np.setdiff1d(np.arange(len(last)), np.concatenate(drop))
    f.restream("cons", keep, np.flatnonzero(np.isin(keep, sorted(ends))))


def edit_tlast_late(f: HarnessFiles, kb: KernelBuild) -> None:
    """[1] pass 0 and the last pass carry their last record twice, TLAST only on the copy: the kernel discards
    the extra beats (during SOLVE, and during DRAIN for the last pass)."""
    nm, passes = f.reg("num_manifolds"), f.passes
    parts, lasts, pos = [], [], 0
    for p in range(passes):
        extra = [nm - 1] if p in (0, passes - 1) else []
        beats = np.concatenate([f.record("cons", p, k) for k in [*range(nm), *extra]])
        parts.append(beats)
        pos += len(beats)
        lasts.append(pos - 1)
    f.restream("cons", np.concatenate(parts), lasts)


def edit_tlast_moved(f: HarnessFiles, kb: KernelBuild) -> None:
    """[1] the stream's beats kept (impulses in the records: the harness's DMA model pairs every record with its
    slot and pass, so none may be dropped or repeated): pass 0's TLAST moves from its last record to the end of
    pass 1's first record: pass 0 runs long (the kernel discards that record), pass 1 short (its last slot
    rejected)."""
    moved_to = int(f.record("cons", 1, 0)[-1])
    last = f.streams["cons"][1]
    last[int(np.flatnonzero(last)[0])] = 0
    last[moved_to] = 1


def edit_body_tlast(f: HarnessFiles, kb: KernelBuild) -> None:
    """[2] the body stream ends inside the record of body num_bodies - 3 (TLAST on its second beat): that body
    is cut short (a record of one beat, as fp16's on 512-bit body beats, is whole), the two after it are missing
    (loaded as zero records); all three frozen."""
    nb = f.reg("num_bodies")
    beats = f.record("body", 0, nb - 3)
    cut = int(beats[min(1, len(beats) - 1)])
    f.restream("body", np.arange(cut + 1), [cut])


def edit_body_tlast_late(f: HarnessFiles, kb: KernelBuild) -> None:
    """[2] one body record too many (TLAST on the extra one): its beats are discarded."""
    nb = f.reg("num_bodies")
    order = np.concatenate([np.arange(len(f.streams["body"][1])), f.record("body", 0, nb - 1)])
    f.restream("body", order, [len(order) - 1])


def edit_bad_argument(f: HarnessFiles, kb: KernelBuild) -> None:
    """[3] num_bodies > MAX_BODIES: the step ends at once, the streams untouched."""
    f.set_reg("num_bodies", kb.max_bodies + 1)


def edit_zero_manifolds(f: HarnessFiles, kb: KernelBuild) -> None:
    f.set_reg("num_manifolds", 0)


def edit_zero_iterations(f: HarnessFiles, kb: KernelBuild) -> None:
    f.set_reg("iterations", 0)


def edit_zero_bodies(f: HarnessFiles, kb: KernelBuild) -> None:
    f.set_reg("num_bodies", 0)


def edit_registers(f: HarnessFiles, kb: KernelBuild) -> None:
    """[9] a write to an unmapped address; the reserved upper word of an argument; ISR toggles, W1C writes of
    status and fp_status; then ap_start with auto_restart before the harness's own ap_start write ([8]: start
    while busy, which also clears auto_restart)."""
    extra = [(OFFSET["num_bodies"] + 4, 5), (UNMAPPED_ADDRESS, 1), (OFFSET["isr"], 3), (OFFSET["isr"], 3),
             (OFFSET["status"], 0xFFFFFFFF), (OFFSET["fp_status"], 7), (OFFSET["ap_ctrl"], AP_START | AUTO_RESTART)]
    f.regs = np.concatenate([f.regs, np.array(extra, dtype="<u4")])


def edit_gravity(f: HarnessFiles, kb: KernelBuild) -> None:
    """Gravity with all three components (and of both signs), another time step and damping: the integration's
    register operands other than the scenes' (0, -9.8, 0), 1/240 s."""
    for name, value in (("gravity_x", 3.75), ("gravity_y", -1.0e3), ("gravity_z", -0.0123), ("dt", 1.0 / 61.0),
                        ("damping", 0.5)):
        f.set_reg(name, int(kb.fmt.encode(value)))


def edit_argument_bits(f: HarnessFiles, kb: KernelBuild) -> None:
    """Every argument register written all-zeros, then all-ones, before the run's own writes (the registers this
    kernel does not use written back to 0 after them): every bit of the argument wires into the kernel toggles
    both ways, and the step runs with its own arguments."""
    own = {int(o) for o in f.regs[:, 0]}
    offsets = [OFFSET[n] for n in ARG_NAMES]
    before = [(o, v) for o in offsets for v in (0, 0xFFFFFFFF)]
    after = [(o, 0) for o in offsets if o not in own]
    f.regs = np.concatenate([np.array(before, dtype="<u4"), f.regs, np.array(after, dtype="<u4").reshape(-1, 2)])


def edit_huge_velocity(f: HarnessFiles, kb: KernelBuild) -> None:
    """Every body moving and spinning at the format's largest finite value on every axis, neighbours in the body
    table of opposite signs: finite input the kernel accepts, whose relative velocities and lever-arm products
    overflow to infinity and whose differences of infinities give NaN (the floating-point event bits and counters
    of every pipe)."""
    w = kb.fmt.width
    for b in range(f.reg("num_bodies")):
        value = int(kb.fmt.encode((1 if b % 2 else -1) * kb.fmt.max_finite))
        for field in (BODY_LINEAR_VELOCITY, BODY_ANGULAR_VELOCITY):
            for axis in range(3):
                f.set_word("body", 0, b, (field + axis) * w, w, value)


def edit_huge_sliding(f: HarnessFiles, kb: KernelBuild) -> None:
    """Every body sliding at the format's largest finite value along x and z (y and the spin untouched), the sign
    alternating in pairs of the body table: the stacked scenes' contact normals (about y) see a finite normal
    velocity, the friction rows overflow (opposite signs) or meet infinities of one sign (NaN): the friction
    pipe's events, which :func:`edit_huge_velocity` cannot reach on the kernel whose impulses travel with the
    records (its NaN impulses reject the next passes' records first)."""
    w = kb.fmt.width
    for b in range(f.reg("num_bodies")):
        value = int(kb.fmt.encode((1 if (b // 2) % 2 else -1) * kb.fmt.max_finite))
        for axis in (0, 2):
            f.set_word("body", 0, b, (BODY_LINEAR_VELOCITY + axis) * w, w, value)


def edit_wide_index(f: HarnessFiles, kb: KernelBuild) -> None:
    """num_bodies = MAX_BODIES: the scene's bodies spread over the whole index range (the last at MAX_BODIES - 1),
    static copies of the ground record between them, every manifold's body indices rewritten: every bit of the
    body indices, counters and addresses in use."""
    nb, n = f.reg("num_bodies"), kb.max_bodies
    new_index = np.round(np.arange(nb) * (n - 1) / (nb - 1)).astype(np.int64)
    source = np.zeros(n, np.int64)  # the record each new body takes: the ground (0) unless a scene body lands there
    source[new_index] = np.arange(nb)
    order = (source[:, None] * f.body_beats + np.arange(f.body_beats)).ravel()
    f.restream("body", order, [len(order) - 1])
    data = f.streams["cons"][0]
    for p in range(f.passes):
        for k in range(f.reg("num_manifolds")):
            head = int.from_bytes(data[f.record("cons", p, k)[0], 0:8].tobytes(), "little")
            if head == int(EMPTY_HEADER):  # an empty lane of the window kernel: no bodies
                continue
            f.set_word("cons", p, k, 0, 32, int(new_index[head & 0xFFFFFFFF]))
            f.set_word("cons", p, k, 32, 31, int(new_index[(head >> 32) & 0x7FFFFFFF]))
    f.set_reg("num_bodies", n)


def edit_spin(f: HarnessFiles, kb: KernelBuild) -> None:
    """The top cube of the stack spinning at 2000 rad/s about y: in fp16 its squared angular velocity overflows
    in the integration (floating-point event counters)."""
    w = kb.fmt.width
    f.set_word("body", 0, f.reg("num_bodies") - 1, (BODY_ANGULAR_VELOCITY + 1) * w, w,  # angular velocity y
               int(kb.fmt.encode(2000.0)))


MASS_SPREAD_SEED = 20261204  # the factors of edit_mass_spread (fixed: a coverage run is reproducible)


def edit_mass_spread(f: HarnessFiles, kb: KernelBuild) -> None:
    """Every dynamic body's inverse mass and inverse inertia words scaled by its own factor in [1/4, 4) (seeded,
    :data:`MASS_SPREAD_SEED`): the test scenes' cubes all have one mass and one inertia, so the words (and the delay
    lines that carry them through the pipes) take a single value; a spread of positive finite masses is good
    input whose words differ in every mantissa bit."""
    w, rng = kb.fmt.width, np.random.default_rng(MASS_SPREAD_SEED)
    words = [BODY_INV_MASS, *(BODY_INV_INERTIA + k for k in range(kb.inertia_words))]
    for b in range(f.reg("num_bodies")):
        factors = 2.0 ** rng.uniform(-2.0, 2.0, len(words))
        if kb.inertia_words == 6:  # the symmetric 3x3: one factor for all six words keeps it positive definite
            factors[1:] = factors[1]
        if not is_dynamic(f, kb, b):
            continue
        for word, factor in zip(words, factors):
            value = float(kb.fmt.decode(np.uint64(f.word("body", 0, b, word * w, w))))
            f.set_word("body", 0, b, word * w, w, int(kb.fmt.encode(value * factor)))


def edit_window_lag(f: HarnessFiles, kb: KernelBuild) -> None:
    """[3] window kernel: lag 0 (a pass may overtake the one before): the step ends at once."""
    f.set_reg("lag", 0)


def edit_window_ring(f: HarnessFiles, kb: KernelBuild) -> None:
    """[3] window kernel: a lag the ring cannot hold ((fetch_passes - 1) * lag + 2 > WINDOW)."""
    f.set_reg("lag", kb.window)


def edit_window_fetch(f: HarnessFiles, kb: KernelBuild) -> None:
    """[3] window kernel: more passes per fetch than the pass contexts."""
    f.set_reg("fetch_passes", kb.window_ctx + 1)


def edit_window_mixed_fetch(f: HarnessFiles, kb: KernelBuild) -> None:
    """[3] window kernel with the impulses in the records: 3 passes per fetch of 4 iterations (a fetch would serve
    contact and friction passes)."""
    f.set_reg("fetch_passes", 3)


def edit_window_partial_record(f: HarnessFiles, kb: KernelBuild) -> None:
    """[3] window kernel: num_manifolds (slots) not a multiple of the lanes."""
    f.set_reg("num_manifolds", f.reg("num_manifolds") - 1)


def is_dynamic(f: HarnessFiles, kb: KernelBuild, body: int) -> bool:
    """Whether ``body``'s record in the body stream has a non-zero inverse mass."""
    w = kb.fmt.width
    return 0 <= body < f.reg("num_bodies") and f.word("body", 0, body, BODY_INV_MASS * w, w) != 0


def edit_lanes_collide(f: HarnessFiles, kb: KernelBuild) -> None:
    """[4] window kernel: in the first record whose first two lanes both hold a manifold with a dynamic body,
    lane 1 names lane 0's dynamic body, in every fetch: the kernel rejects lane 1 in every pass."""
    lanes, nm = kb.lanes, f.reg("num_manifolds")
    for r in range(0, nm, lanes):
        heads = [f.word("cons", 0, r + k, 0, 63) for k in (0, 1)]
        ends = [(h & 0xFFFFFFFF, h >> 32) for h in heads]
        shared = [b for b in ends[0] if is_dynamic(f, kb, b)]
        if shared and all(b < f.reg("num_bodies") for b in ends[1]):  # lane 1 not empty
            for p in range(f.passes):
                f.set_word("cons", p, r + 1, 0, 32, shared[0])
            return
    raise ValueError("no record with two manifolds to make collide")


@dataclass(frozen=True)
class HarnessEdit:
    """One edit of a run's harness inputs and the bad-input catalogue cases it makes (none: not bad input)."""

    name: str
    edit: Edit
    cases: tuple[str, ...] = ()


BAD_INPUT_EDITS: tuple[HarnessEdit, ...] = (
    HarnessEdit("body_index", edit_body_index, ("body_index",)),
    HarnessEdit("nonfinite", edit_nonfinite, ("nonfinite_constraint", "nonfinite_body")),
    HarnessEdit("mass", edit_mass, ("negative_inverse_mass", "zero_inverse_mass")),
    HarnessEdit("tlast_early", edit_tlast_early, ("tlast_early",)),
    HarnessEdit("tlast_late", edit_tlast_late, ("tlast_late",)),
    HarnessEdit("body_tlast_early", edit_body_tlast, ("body_tlast_early",)),
    HarnessEdit("body_tlast_late", edit_body_tlast_late, ("body_tlast_late",)),
    HarnessEdit("bad_argument", edit_bad_argument, ("bad_argument",)),
    HarnessEdit("zero_manifolds", edit_zero_manifolds, ("zero_manifolds",)),
    HarnessEdit("zero_iterations", edit_zero_iterations, ("zero_iterations",)),
    HarnessEdit("zero_bodies", edit_zero_bodies, ("zero_bodies",)),
    HarnessEdit("registers", edit_registers, ("unmapped_axi", "start_busy")),
)
# the streaming kernel with the impulses in the records: the constraint stream's TLAST errors without dropped or
# repeated records (in place of tlast_early / tlast_late, which the harness's impulse plan cannot follow)
RECORDS_BAD_INPUT_EDITS: tuple[HarnessEdit, ...] = (
    *(e for e in BAD_INPUT_EDITS if e.name not in ("tlast_early", "tlast_late")),
    HarnessEdit("tlast_moved", edit_tlast_moved),
)
# the window kernel with the impulses in the records, one lane: the records design's edits (its stream's beats kept)
# and the window's argument errors, a fetch of both kinds among them
WINDOW_RECORDS_BAD_INPUT_EDITS: tuple[HarnessEdit, ...] = (
    *RECORDS_BAD_INPUT_EDITS,
    HarnessEdit("window_lag", edit_window_lag),
    HarnessEdit("window_ring", edit_window_ring),
    HarnessEdit("window_fetch", edit_window_fetch),
    HarnessEdit("window_mixed_fetch", edit_window_mixed_fetch),
)
# the window kernel's own bad input (its arguments, its lane plan), beside BAD_INPUT_EDITS on its builds
WINDOW_BAD_INPUT_EDITS: tuple[HarnessEdit, ...] = (
    HarnessEdit("window_lag", edit_window_lag),
    HarnessEdit("window_ring", edit_window_ring),
    HarnessEdit("window_fetch", edit_window_fetch),
    HarnessEdit("window_partial_record", edit_window_partial_record),
    HarnessEdit("lanes_collide", edit_lanes_collide),
)
