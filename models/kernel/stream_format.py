"""Bit-level packing of everything that crosses the kernel's AXI4-Stream ports (host side).

All records are packed **little-endian from bit 0**: the first field sits in the lowest bits, each
W-bit word ``k`` of a record's word list at bits ``[base + k*W, base + (k+1)*W)``. A record is padded
with zero bits to a whole number of stream beats (``beat_bits`` wide, e.g. 512 for the constraint
stream = 4 DMA channels of 128 bits, 128 for the body streams); beat ``j`` of a record holds record bits
``[j*beat_bits, (j+1)*beat_bits)``, and a beat's bytes are little-endian (byte 0 = bits 7:0), which is
the byte order of the AXI4-Stream TDATA lanes and of the binary files the Verilator harness streams.
W = ``fmt.width`` (1 + exp_bits + man_bits); a word is the format's bit pattern
(``NumberFormat.encode`` of an already ``.rounded`` value), so any format packs the same way.

Records (word counts; offsets in bits from the record's bit 0):

=================  ======================================================================================
record             layout
=================  ======================================================================================
contact            64-bit header, then 23 words: n(3), p[0..3] xyz (12), jac_inv(4), b(4)
(contact passes)   -> 64 + 23 W bits
friction           64-bit header, then 14 + F words: n(3), c(3), t0(3), t1(3), f_jac_inv(2), and with F = 1 the
(friction passes)  manifold's friction coefficient mu (a scene whose friction varies; F = 0: the kernel's one
                   coefficient, its build without the word) -> 64 + (14 + F) W bits; with the tangents derived on
                   chip (TANGENTS_ON_CHIP) without t0, t1: n(3), c(3), f_jac_inv(2), mu(F) -> 64 + (8 + F) W bits
window             64-bit header, then the 23 contact words and the 14 + F friction words -> 64 + (37 + F) W bits
(window kernel)    (with the impulses in the records: each fetch serves passes of one kind and streams that kind's
                   record with its impulses, below, every one padded to the longer kind's beats)
contact, impulses  the contact record, then lam[0..3] (4 words at word 23) -> 64 + 27 W bits
in the records     (the streaming kernel built with IMPULSES_IN_RECORDS: no impulse RAM on chip)
friction, impulses the friction record, then lam[0..3] (word 14, the friction limit) and lamT[0..1] (word 18)
in the records     -> 64 + 20 W bits
impulse-out        4 words: contact lam[0..3]; friction lamT[0..1], then two zero words; a rejected slot all
(m_axis_imp)       zeros -> 4 W bits rounded up to whole bytes; one per slot of every pass, TLAST on a pass's last
                   (the window kernel: one per window record of the last pass of every fetch, its L lanes' 4 words
                   one after the other -> 4 L W bits rounded up to whole bytes, TLAST on the fetch's last)
header             bits 31:0 body_a, bits 59:32 body_b, bit 60 frozen A, bit 61 frozen B, bit 62 linear shock, bit 63
                   spin_damp (all record kinds; the three shock bits are set only in a shock pass's records of the
                   streaming kernel, models/golden/shock_propagation.py: the frozen body enters the pipe with inverse
                   mass and inertia 0 and is not written; a linear row's bodies with inverse inertia 0, no spin damping)
body-in            14 + I words: pos(3), q(4) (x, y, z, w), v(3), w(3), inv_mass(1), inv_inertia(I): I = 1
                   (scalar), 3 (diagonal xx, yy, zz) or 6 (symmetric: xx, yy, zz, xy, xz, yz), the inverse-inertia
                   mode (models/setup/inertia.py); the kernel's build today: I = 3 (17 words)
body-out           13 words: pos(3), q(4), v(3), w(3)
trace              16 words: impulse[0..3] (friction: lamT, 0, 0), vA, wA, vB, wB (xyz each), then 64 bits:
(trace port)       bits 31:0 slot, bits 47:32 iteration, bit 48 pass kind -> 16 W + 64 bits
=================  ======================================================================================

The constraint stream of one step holds, pass after pass in :func:`models.golden.contact_solver.pass_sequence`
order, one record per manifold in schedule order (``-1`` bubbles are skipped: they are issue-timing
only); a contact pass carries contact records, a friction pass friction records. The kernel's slot index
of a manifold is its record index within the pass. TLAST is set on the last beat of every pass (the
kernel flags a mismatch as a stream error). The body-in stream holds ``num_bodies`` body-in records
in index order (TLAST on the last beat), the body-out stream ``num_bodies`` body-out records in index
order (TLAST on the last beat).

Impulses in the records: the records' impulse words are those the pass starts from. The host writes the
impulses the step starts from (zeros, or a warm start) into the DDR impulse buffer (lam[4], lamT[2] per slot); the
DMA reads each record as its static words with the buffer's words, and writes each impulse-out record into its
slot's field of the pass's kind (contact lam, friction lamT: only those bytes, 4 W and 2 W bits). So
:func:`pack_constraint_stream` packs every pass's records with the host-given impulses, and the DMA model (the
harness) replaces the fields an earlier pass of the step wrote. Read after write: record k of pass p > 0 is read
no earlier than ``DmaPreset.impulse_turnaround_cycles`` after pass p - 1's impulse-out record of slot k left the
kernel (every pass reads only what its predecessor wrote, or older): a pass shorter than the pipeline's depth
plus the turnaround waits for its predecessor; a long one never does. The DDR bandwidth is shared: the reads get
the share :meth:`StreamLayout.ddr_read_share` of it (their bytes over read plus written bytes), the writes the
rest.

The window kernel (``rtl/pgs_window.sv``, ``models/kernel/record_window.py``) reads each manifold's record once per
*fetch* instead: the constraint stream is ``ceil(passes / fetch_passes)`` fetches of one window record per
manifold in schedule order, TLAST on the last beat of each fetch (:func:`pack_window_stream`). With the impulses in
the records every fetch serves passes of one kind (:func:`window_fetch_kinds`) and its records are that kind's records
with the impulses the fetch starts from; the last pass of each fetch writes its impulse-out records, which the next
fetch's records are read with (the same read-after-write rule, fetch by fetch).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from models.setup.constraints import BodyTable, ConstraintSet
from models.golden.contact_solver import (CONTACT_PASS, FRICTION_PASS, Impulses, SolverParams, is_shock_pass,
                                          pass_sequence)
from models.setup.inertia import InertiaMode, inertia_mode
from models.formats.number_format import NumberFormat
from models.golden.shock_propagation import ShockConstraintSet
from models.kernel.record_window import window_fetch_kinds, window_fetches
from models.order.manifold_schedule import schedule_manifolds

HEADER_BITS = 64
CONTACT_WORDS = 23
FRICTION_WORDS = 14
# impulses in the records: lam[0..3] after the contact words; lam[0..3] and lamT[0..1] after the friction words
CONTACT_LAM_WORD = CONTACT_WORDS
FRICTION_LAM_WORD = FRICTION_WORDS
FRICTION_LAMT_WORD = FRICTION_WORDS + 4
CONTACT_IMPULSE_WORDS, FRICTION_IMPULSE_WORDS = 4, 6
TANGENT_WORDS = 6  # t0(3), t1(3) of a friction record: absent with tangents_on_chip (models/setup/tangent_basis.py)
IMPULSE_OUT_WORDS = 4
WINDOW_WORDS = CONTACT_WORDS + FRICTION_WORDS
KERNEL_INERTIA_WORDS = InertiaMode.DIAGONAL.words  # the inverse-inertia words of the kernel's body-in record
BODY_OUT_WORDS = 13
# word offsets of a body-in record's fields (a body-out record is its first BODY_OUT_WORDS words)
BODY_POSITION = 0          # pos(3)
BODY_ORIENTATION = 3       # q(4): x, y, z, w
BODY_LINEAR_VELOCITY = 7   # v(3)
BODY_ANGULAR_VELOCITY = 10  # w(3)
BODY_INV_MASS = 13         # inv_mass(1)
BODY_INV_INERTIA = 14      # inv_inertia(1, 3 or 6)
INERTIA_WORDS = tuple(m.words for m in InertiaMode)


def body_in_word_count(inertia_words: int = KERNEL_INERTIA_WORDS) -> int:
    """Words of a body-in record carrying ``inertia_words`` (1, 3 or 6) inverse-inertia words."""
    if inertia_words not in INERTIA_WORDS:
        raise ValueError(f"a body-in record carries 1, 3 or 6 inverse-inertia words, got {inertia_words}")
    return BODY_INV_INERTIA + inertia_words


BODY_IN_WORDS = body_in_word_count()


def kernel_inertia_words(bodies: BodyTable, scene: bool = False) -> int:
    """The inverse-inertia words of the kernel build that runs ``bodies`` (its ``IINV_W``): 6 where the table is in
    the full mode (a rotated non-cube body), else the default build's 3 (a scalar body repeats its value there), so
    that the built-in scenes and the thesis frame keep their build, their body records and their cycles. ``scene``:
    as few as the table's mode needs (1 where every dynamic body is isotropic, the thesis frame's cubes: a body
    record two words shorter and on chip two words fewer per body)."""
    mode = bodies.inertia_mode
    if scene:
        return mode.words
    return InertiaMode.FULL.words if mode is InertiaMode.FULL else KERNEL_INERTIA_WORDS
TRACE_WORDS = 16
TRACE_TAIL_BITS = 64

# names of the words of a trace record and of a body-out record (as the comparisons report a differing field)
TRACE_FIELDS = [f"impulse[{i}]" for i in range(4)] + [f"{f}.{c}" for f in ("vA", "wA", "vB", "wB") for c in "xyz"]
BODY_OUT_FIELDS = [f"{f}.{c}" for f, cs in (("pos", "xyz"), ("q", "xyzw"), ("v", "xyz"), ("w", "xyz")) for c in cs]

DEFAULT_CONS_BEAT_BITS = 512
DEFAULT_BODY_BEAT_BITS = 128

# the constraint header's fields (bit positions from bit 0; body_a is bits 31:0)
HEADER_BODY_B_LSB = 32
HEADER_BODY_B_BITS = 28
HEADER_FROZEN_A_BIT = 60
HEADER_FROZEN_B_BIT = 61
HEADER_SHOCK_LINEAR_BIT = 62
HEADER_SPIN_DAMP_BIT = 63
_CHUNK_RECORDS = 8192  # records packed or unpacked at a time


# --- generic bit packing ------------------------------------------------------------------------------
def _field_bits(values: np.ndarray, width: int) -> np.ndarray:
    """(R, F) uint64 values -> (R, F*width) uint8 bits, value f's bit i at column f*width + i."""
    v = np.asarray(values, dtype=np.uint64)
    shifts = np.arange(width, dtype=np.uint64)
    bits = ((v[:, :, None] >> shifts[None, None, :]) & np.uint64(1)).astype(np.uint8)
    return bits.reshape(v.shape[0], v.shape[1] * width)


def beats_per_record(record_bits: int, beat_bits: int) -> int:
    if beat_bits <= 0 or beat_bits % 8:
        raise ValueError(f"beat width must be a positive multiple of 8 bits, got {beat_bits}")
    return -(-record_bits // beat_bits)


def pack_records(header: np.ndarray | None, words: np.ndarray, word_bits: int, beat_bits: int) -> np.ndarray:
    """Pack R records into beats: returns (R * beats_per_record, beat_bits // 8) uint8, little-endian.

    ``header``: (R,) uint64 placed at bits 63:0 (or None: no header); ``words``: (R, K) uint64 bit
    patterns (only the low ``word_bits`` bits are used) placed from bit 64 (or 0) on.
    """
    words = np.asarray(words, dtype=np.uint64)
    r = words.shape[0]
    if r > _CHUNK_RECORDS:  # bounded memory: the bit matrices take 8 bytes per bit
        hdr = (lambda lo: None) if header is None else (lambda lo: header[lo:lo + _CHUNK_RECORDS])
        return np.concatenate([pack_records(hdr(lo), words[lo:lo + _CHUNK_RECORDS], word_bits, beat_bits)
                               for lo in range(0, r, _CHUNK_RECORDS)])
    parts = []
    if header is not None:
        parts.append(_field_bits(np.asarray(header, dtype=np.uint64).reshape(r, 1), HEADER_BITS))
    parts.append(_field_bits(words, word_bits))
    bits = np.concatenate(parts, axis=1)
    nbeats = beats_per_record(bits.shape[1], beat_bits)
    padded = np.zeros((r, nbeats * beat_bits), dtype=np.uint8)
    padded[:, :bits.shape[1]] = bits
    return np.packbits(padded, axis=1, bitorder="little").reshape(r * nbeats, beat_bits // 8)


def unpack_records(beats: np.ndarray, num_words: int, word_bits: int, beat_bits: int,
                   header: bool = False) -> tuple[np.ndarray | None, np.ndarray]:
    """Inverse of :func:`pack_records`: (headers or None, (R, num_words) uint64 words)."""
    rec_bits = (HEADER_BITS if header else 0) + num_words * word_bits
    nbeats = beats_per_record(rec_bits, beat_bits)
    data = np.asarray(beats, dtype=np.uint8).reshape(-1, nbeats * beat_bits // 8)
    if data.shape[0] > _CHUNK_RECORDS:
        parts = [unpack_records(data[lo:lo + _CHUNK_RECORDS], num_words, word_bits, beat_bits, header)
                 for lo in range(0, data.shape[0], _CHUNK_RECORDS)]
        hdrs = None if not header else np.concatenate([h for h, _ in parts])  # type: ignore[misc]
        return hdrs, np.concatenate([w for _, w in parts])
    bits = np.unpackbits(data, axis=1, bitorder="little").astype(np.uint64)
    weights = np.uint64(1) << np.arange(64, dtype=np.uint64)
    base = 0
    hdr = None
    if header:
        hdr = (bits[:, :HEADER_BITS] * weights[None, :]).sum(axis=1, dtype=np.uint64)
        base = HEADER_BITS
    w = bits[:, base:base + num_words * word_bits].reshape(-1, num_words, word_bits)
    words = (w * weights[None, None, :word_bits]).sum(axis=2, dtype=np.uint64)
    return hdr, words


# --- record contents ----------------------------------------------------------------------------------
def constraint_header(cons: ConstraintSet, idx: np.ndarray, shock: bool = False) -> np.ndarray:
    """{bit 63 spin_damp, bits 59:32 body_b, bits 31:0 body_a} per manifold of ``idx``; ``shock`` (a shock pass's
    records, ``cons`` a :class:`ShockConstraintSet`): with the frozen-body bits and the linear bit of each row."""
    a = cons.body_a[idx].astype(np.uint64)
    b = cons.body_b[idx].astype(np.uint64)
    if np.any(a >= (1 << 32)) or np.any(b >= (1 << HEADER_BODY_B_BITS)):
        raise ValueError("body index does not fit the record header")
    sd = cons.spin_damp[idx].astype(np.uint64)
    hdr = a | (b << np.uint64(HEADER_BODY_B_LSB)) | (sd << np.uint64(HEADER_SPIN_DAMP_BIT))
    if shock:
        if not isinstance(cons, ShockConstraintSet):
            raise ValueError("a shock pass's records need the shock rows: models.golden.shock_propagation.shock_constraints")
        fa, fb, lin = cons.row_flags(idx)
        hdr |= ((fa.astype(np.uint64) << np.uint64(HEADER_FROZEN_A_BIT))
                | (fb.astype(np.uint64) << np.uint64(HEADER_FROZEN_B_BIT))
                | (lin.astype(np.uint64) << np.uint64(HEADER_SHOCK_LINEAR_BIT)))
    return hdr


def shock_rows(cons: ConstraintSet) -> ConstraintSet:
    """The records a shock pass streams: ``cons`` with its shock rows' ``jac_inv`` and ``f_jac_inv``."""
    if not isinstance(cons, ShockConstraintSet):
        raise ValueError("a shock pass's records need the shock rows: models.golden.shock_propagation.shock_constraints")
    return replace(cons, jac_inv=cons.shock_jac_inv, f_jac_inv=cons.shock_f_jac_inv)


def contact_words(fmt: NumberFormat, cons: ConstraintSet, idx: np.ndarray) -> np.ndarray:
    """(K, 23) bit patterns: n(3), p[0..3] xyz (12), jac_inv(4), b(4)."""
    k = len(idx)
    vals = np.concatenate([cons.normal[idx], cons.points[idx].reshape(k, 12), cons.jac_inv[idx],
                           cons.bias[idx]], axis=1)
    return fmt.encode(vals)


def friction_words(fmt: NumberFormat, cons: ConstraintSet, idx: np.ndarray,
                   tangents_on_chip: bool = False) -> np.ndarray:
    """(K, 14 + F) bit patterns: n(3), c(3), t0(3), t1(3), f_jac_inv(2), then (F = ``ConstraintSet.friction_words``
    = 1) the manifold's friction coefficient; ``tangents_on_chip``: without t0, t1 (K, 8 + F), the kernel derives
    them from n (``models/setup/tangent_basis.py``)."""
    tangents = [] if tangents_on_chip else [cons.tangent[idx, 0], cons.tangent[idx, 1]]
    vals = np.concatenate([cons.normal[idx], cons.center[idx], *tangents, cons.f_jac_inv[idx], cons.friction[idx]],
                          axis=1)
    return fmt.encode(vals)


def inertia_record_words(bodies: BodyTable, inertia_words: int = KERNEL_INERTIA_WORDS) -> np.ndarray:
    """(N, inertia_words) values of the body-in record's inverse inertia; a table whose mode needs more words
    than the record carries is refused (its dynamic bodies' values would be lost)."""
    body_in_word_count(inertia_words)
    v = np.asarray(bodies.inv_inertia, dtype=np.float64)
    mode = inertia_mode(v, bodies.dynamic)
    if mode.words > inertia_words:
        raise ValueError(f"the body table's inverse inertia is in the {mode.value} mode ({mode.words} words: "
                         f"{'rotated non-isotropic bodies' if mode is InertiaMode.FULL else 'non-isotropic bodies'}); "
                         f"the body-in record carries {inertia_words}")
    if inertia_words == 6 and v.shape[1] == 3:
        return np.concatenate([v, np.zeros((v.shape[0], 3))], axis=1)
    return v[:, :inertia_words]


def body_in_words(fmt: NumberFormat, bodies: BodyTable, inertia_words: int = KERNEL_INERTIA_WORDS) -> np.ndarray:
    """(N, 14 + inertia_words) bit patterns: pos(3), q(4), v(3), w(3), inv_mass(1), inv_inertia(inertia_words)."""
    vals = np.concatenate([bodies.position, bodies.orientation, bodies.linear_velocity, bodies.angular_velocity,
                           bodies.inv_mass[:, None], inertia_record_words(bodies, inertia_words)], axis=1)
    return fmt.encode(vals)


def body_out_words(fmt: NumberFormat, bodies: BodyTable) -> np.ndarray:
    """(N, 13) bit patterns: pos(3), q(4), v(3), w(3)."""
    vals = np.concatenate([bodies.position, bodies.orientation, bodies.linear_velocity, bodies.angular_velocity],
                          axis=1)
    return fmt.encode(vals)


def trace_record_bytes(fmt: NumberFormat) -> int:
    """Bytes of one trace record: 16 words of W bits (2 W bytes), then the 64-bit slot / iteration / kind."""
    return TRACE_WORDS * fmt.width // 8 + TRACE_TAIL_BITS // 8


def impulse_out_bytes(fmt: NumberFormat, lanes: int = 1) -> int:
    """Bytes of one impulse-out record (the m_axis_imp TDATA): 4 words per lane rounded up to whole bytes."""
    return -(-lanes * IMPULSE_OUT_WORDS * fmt.width // 8)


def unpack_impulse_out(fmt: NumberFormat, data: bytes | np.ndarray, lanes: int = 1) -> np.ndarray:
    """Impulse-out records -> (R * lanes, 4) uint64 bit patterns, one row per slot (lane)."""
    nbytes, nwords = impulse_out_bytes(fmt, lanes), lanes * IMPULSE_OUT_WORDS
    raw = np.frombuffer(bytes(data), dtype=np.uint8).reshape(-1, nbytes)
    bits = np.unpackbits(raw, axis=1, bitorder="little").astype(np.uint64)[:, :nwords * fmt.width]
    weights = np.uint64(1) << np.arange(fmt.width, dtype=np.uint64)
    words = (bits.reshape(-1, nwords, fmt.width) * weights).sum(axis=2, dtype=np.uint64)
    return words.reshape(-1, IMPULSE_OUT_WORDS)


# --- sizes --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class RecordBits:
    """Unpadded bits of each record where its fields are stored in formats of their own (mixed storage,
    ``models/sizing/mixed_layout.py``): the sizes the streams then carry, each record still padded to whole beats."""

    contact: int
    friction: int
    body_in: int
    body_out: int
    impulse_out_contact: int  # the bits a contact pass writes back per slot (impulses in the records)
    impulse_out_friction: int

    def __post_init__(self) -> None:
        if min(self.contact, self.friction, self.body_in, self.body_out, self.impulse_out_contact,
               self.impulse_out_friction) <= 0:
            raise ValueError(f"record bits must be positive, got {self}")


@dataclass(frozen=True)
class StreamLayout:
    """Record sizes of one format and beat widths."""

    fmt: NumberFormat
    cons_beat_bits: int = DEFAULT_CONS_BEAT_BITS
    body_beat_bits: int = DEFAULT_BODY_BEAT_BITS
    inertia_words: int = KERNEL_INERTIA_WORDS
    impulses_in_records: bool = False  # the records carry the impulses their pass starts from
    friction_words: int = 0  # the friction-coefficient words of a friction record (ConstraintSet.friction_words)
    tangents_on_chip: bool = False  # the friction record omits t0, t1: the kernel derives them from n
    record_bits: RecordBits | None = None  # mixed storage: the records' bits (None: every word fmt.width bits)

    @property
    def _tangent_words(self) -> int:
        return 0 if self.tangents_on_chip else TANGENT_WORDS

    @property
    def word_bits(self) -> int:
        return self.fmt.width

    @property
    def contact_record_words(self) -> int:
        """Words of a contact record after its header (with the impulses it carries)."""
        return CONTACT_WORDS + (CONTACT_IMPULSE_WORDS if self.impulses_in_records else 0)

    @property
    def friction_record_words(self) -> int:
        """Words of a friction record after its header: the 14, the coefficient words, then the impulses."""
        return (FRICTION_WORDS - TANGENT_WORDS + self._tangent_words + self.friction_words
                + (FRICTION_IMPULSE_WORDS if self.impulses_in_records else 0))

    @property
    def friction_lam_word(self) -> int:
        """Word of a friction record (after its header) where the impulses it carries start: after the coefficient."""
        return FRICTION_LAM_WORD - TANGENT_WORDS + self._tangent_words + self.friction_words

    @property
    def friction_lamt_word(self) -> int:
        """Word of a friction record (after its header) where its lamT[0..1] start: after the coefficient and lam."""
        return FRICTION_LAMT_WORD - TANGENT_WORDS + self._tangent_words + self.friction_words

    @property
    def contact_bits(self) -> int:
        if self.record_bits is not None:
            return self.record_bits.contact
        return HEADER_BITS + self.contact_record_words * self.word_bits

    @property
    def friction_bits(self) -> int:
        if self.record_bits is not None:
            return self.record_bits.friction
        return HEADER_BITS + self.friction_record_words * self.word_bits

    def impulse_write_bytes(self, kind: int) -> int:
        """DDR bytes a manifold-pass of ``kind`` writes back (its field of the impulse buffer; 0 on chip)."""
        if not self.impulses_in_records:
            return 0
        if self.record_bits is not None:
            rb = self.record_bits
            return -(-(rb.impulse_out_contact if kind == CONTACT_PASS else rb.impulse_out_friction) // 8)
        return -(-(4 if kind == CONTACT_PASS else 2) * self.word_bits // 8)

    def ddr_read_share(self, params: SolverParams, fetch_passes: int = 0) -> float:
        """The share of the DDR bandwidth the constraint reads get while the impulse writes take the rest (their
        bytes per step over all bytes per step; 1 with on-chip impulses). ``fetch_passes`` > 0: the window kernel's
        stream of fetches (:func:`window_fetch_kinds`), each slot's record read and its impulses written once per
        fetch."""
        if fetch_passes:
            kinds = window_fetch_kinds(params, fetch_passes, self.impulses_in_records)
            reads = len(kinds) * self.window_bytes
            writes = sum(self.impulse_write_bytes(kind) for kind in kinds if kind is not None)
        else:
            reads = self.bytes_per_manifold(params)
            writes = sum(self.impulse_write_bytes(kind) for kind, _ in pass_sequence(params))
        return reads / (reads + writes) if reads + writes else 1.0

    @property
    def window_bits(self) -> int:
        """Bits of one lane's window record: the contact and friction words together; with the impulses in the
        records the longer of the contact and friction records with their impulses (a fetch streams one kind)."""
        if self.record_bits is not None:
            raise ValueError("mixed storage (record_bits) is a layout of the streaming kernel, not the window's")
        if self.impulses_in_records:
            return max(self.contact_bits, self.friction_bits)
        return HEADER_BITS + (WINDOW_WORDS + self.friction_words) * self.word_bits

    @property
    def window_beats(self) -> int:
        return beats_per_record(self.window_bits, self.cons_beat_bits)

    @property
    def window_bytes(self) -> int:
        return self.window_beats * self.cons_beat_bits // 8

    @property
    def contact_beats(self) -> int:
        return beats_per_record(self.contact_bits, self.cons_beat_bits)

    @property
    def friction_beats(self) -> int:
        return beats_per_record(self.friction_bits, self.cons_beat_bits)

    @property
    def body_in_words(self) -> int:
        return body_in_word_count(self.inertia_words)

    @property
    def body_in_beats(self) -> int:
        bits = self.body_in_words * self.word_bits if self.record_bits is None else self.record_bits.body_in
        return beats_per_record(bits, self.body_beat_bits)

    @property
    def body_out_beats(self) -> int:
        bits = BODY_OUT_WORDS * self.word_bits if self.record_bits is None else self.record_bits.body_out
        return beats_per_record(bits, self.body_beat_bits)

    # bytes per record as streamed (padding included)
    @property
    def contact_bytes(self) -> int:
        return self.contact_beats * self.cons_beat_bits // 8

    @property
    def friction_bytes(self) -> int:
        return self.friction_beats * self.cons_beat_bits // 8

    @property
    def body_in_bytes(self) -> int:
        return self.body_in_beats * self.body_beat_bits // 8

    @property
    def body_out_bytes(self) -> int:
        return self.body_out_beats * self.body_beat_bits // 8

    def bytes_per_manifold(self, params: SolverParams) -> int:
        """Constraint-stream bytes one manifold costs over all passes of a step."""
        return sum(self.contact_bytes if kind == CONTACT_PASS else self.friction_bytes
                   for kind, _ in pass_sequence(params))

    def bytes_per_step(self, num_bodies: int, num_manifolds: int, params: SolverParams) -> dict[str, int]:
        """Bytes on each stream for one step (the impulse writes with the impulses in the records)."""
        out = {
            "constraints": num_manifolds * self.bytes_per_manifold(params),
            "body_in": num_bodies * self.body_in_bytes,
            "body_out": num_bodies * self.body_out_bytes,
        }
        if self.impulses_in_records:
            out["impulses_out"] = num_manifolds * sum(self.impulse_write_bytes(k) for k, _ in pass_sequence(params))
        return out


# --- whole streams ------------------------------------------------------------------------------------
@dataclass
class Stream:
    """Beats of one stream: ``data`` (B, beat_bytes) uint8 little-endian, ``last`` (B,) bool (TLAST)."""

    data: np.ndarray
    last: np.ndarray

    @property
    def num_beats(self) -> int:
        return int(self.data.shape[0])

    def to_bytes(self) -> bytes:
        return self.data.tobytes()


def _transfers(blocks: list[np.ndarray], beat_bits: int) -> Stream:
    """The beats of ``blocks`` one after the other, TLAST on the last beat of each block (one DMA transfer each)."""
    if not blocks:
        return Stream(np.zeros((0, beat_bits // 8), np.uint8), np.zeros(0, bool))
    last = []
    for beats in blocks:
        flags = np.zeros(beats.shape[0], dtype=bool)
        if flags.size:
            flags[-1] = True
        last.append(flags)
    return Stream(np.concatenate(blocks), np.concatenate(last))


def pack_constraint_stream(fmt: NumberFormat, cons: ConstraintSet, schedule: np.ndarray, params: SolverParams,
                           beat_bits: int = DEFAULT_CONS_BEAT_BITS, impulses: Impulses | None = None,
                           tangents_on_chip: bool = False) -> Stream:
    """The constraint stream of one step: every pass of ``pass_sequence(params)``, records in schedule order.
    ``impulses`` (per manifold, values of ``fmt``): the records carry them after their words, the impulses the step
    starts from (the kernel built with IMPULSES_IN_RECORDS; the DMA replaces what earlier passes wrote); None: the
    records of the on-chip impulse RAM. ``tangents_on_chip``: the friction records without t0, t1 (the kernel built
    with TANGENTS_ON_CHIP derives them)."""
    idx = schedule_manifolds(schedule)
    lam = lam_t = None
    if impulses is not None:
        lam, lam_t = fmt.encode(impulses.normal[idx]), fmt.encode(impulses.friction[idx])

    def records(kind: int, shock: bool) -> np.ndarray:
        rows = shock_rows(cons) if shock else cons
        if kind == CONTACT_PASS:
            words = contact_words(fmt, rows, idx)
            extra = [] if lam is None else [lam]
        else:
            words = friction_words(fmt, rows, idx, tangents_on_chip)
            extra = [] if lam is None else [lam, lam_t]
        return pack_records(constraint_header(cons, idx, shock), np.concatenate([words, *extra], axis=1),
                            fmt.width, beat_bits)

    packed: dict[tuple[int, bool], np.ndarray] = {}
    blocks = []
    for kind, it in pass_sequence(params):
        key = (kind, is_shock_pass(params, kind, it))
        if key not in packed:
            packed[key] = records(*key)
        blocks.append(packed[key])
    return _transfers(blocks, beat_bits)


EMPTY_HEADER = np.uint64(0xFFFF_FFFF_FFFF_FFFF)  # an empty lane of the window kernel (padding; zero words)


def pack_window_stream(fmt: NumberFormat, cons: ConstraintSet, slots: np.ndarray, params: SolverParams,
                       fetch_passes: int, beat_bits: int = DEFAULT_CONS_BEAT_BITS,
                       impulses: Impulses | None = None) -> Stream:
    """The window kernel's constraint stream: one combined record per slot of ``slots`` (manifold indices; -1 an
    empty lane: all-ones header, zero words), once per fetch. With LANES lanes, window record k is the
    combined records of slots k * LANES .. k * LANES + LANES - 1 one after the other, so the beats are the
    same: ``slots`` (``models.kernel.record_window.lane_slots``) only needs a multiple of LANES entries.
    ``impulses`` (per manifold, values of ``fmt``): the kernel whose impulses travel with the records; every fetch
    serves passes of one kind (:func:`window_fetch_kinds`) and streams that kind's records with the impulses the
    step starts from (the DMA replaces what earlier fetches wrote), each padded to the longer kind's beats."""
    slots = np.asarray(slots, dtype=np.int64)
    real = slots >= 0
    idx = np.where(real, slots, 0)
    header = np.where(real, constraint_header(cons, idx), EMPTY_HEADER)
    if not len(slots):
        return _transfers([], beat_bits)
    if impulses is None:
        words = np.concatenate([contact_words(fmt, cons, idx), friction_words(fmt, cons, idx)], axis=1)
        words[~real] = 0
        return _transfers([pack_records(header, words, fmt.width, beat_bits)]
                          * window_fetches(params, fetch_passes), beat_bits)
    lam, lam_t = fmt.encode(impulses.normal[idx]), fmt.encode(impulses.friction[idx])
    kind_words = {CONTACT_PASS: [contact_words(fmt, cons, idx), lam],
                  FRICTION_PASS: [friction_words(fmt, cons, idx), lam, lam_t]}
    layout = StreamLayout(fmt, beat_bits, impulses_in_records=True, friction_words=cons.friction_words)
    packed: dict[int, np.ndarray] = {}
    for kind, parts in kind_words.items():
        words = np.concatenate(parts, axis=1)
        words[~real] = 0
        beats = pack_records(header, words, fmt.width, beat_bits).reshape(len(slots), -1, beat_bits // 8)
        padded = np.zeros((len(slots), layout.window_beats, beat_bits // 8), np.uint8)
        padded[:, :beats.shape[1]] = beats
        packed[kind] = padded.reshape(-1, beat_bits // 8)
    kinds = window_fetch_kinds(params, fetch_passes, one_kind=True)
    return _transfers([packed[kind] for kind in kinds if kind is not None], beat_bits)


def unpack_constraint_records(fmt: NumberFormat, beats: np.ndarray, kind: int,
                              beat_bits: int = DEFAULT_CONS_BEAT_BITS, friction_words: int = 0) -> dict[str, np.ndarray]:
    """Decode one pass's beats (all of one kind; friction records with ``friction_words`` coefficient words) into
    header fields and float64 values."""
    nwords = CONTACT_WORDS if kind == CONTACT_PASS else FRICTION_WORDS + friction_words
    hdr, words = unpack_records(beats, nwords, fmt.width, beat_bits, header=True)
    assert hdr is not None
    out: dict[str, np.ndarray] = {
        "body_a": (hdr & np.uint64(0xFFFFFFFF)).astype(np.int64),
        "body_b": ((hdr >> np.uint64(HEADER_BODY_B_LSB)) & np.uint64((1 << HEADER_BODY_B_BITS) - 1)).astype(np.int64),
        "frozen_a": ((hdr >> np.uint64(HEADER_FROZEN_A_BIT)) & np.uint64(1)).astype(bool),
        "frozen_b": ((hdr >> np.uint64(HEADER_FROZEN_B_BIT)) & np.uint64(1)).astype(bool),
        "shock_linear": ((hdr >> np.uint64(HEADER_SHOCK_LINEAR_BIT)) & np.uint64(1)).astype(bool),
        "spin_damp": ((hdr >> np.uint64(HEADER_SPIN_DAMP_BIT)) & np.uint64(1)).astype(bool),
    }
    v = fmt.decode(words)
    out["normal"] = v[:, 0:3]
    if kind == CONTACT_PASS:
        out["points"] = v[:, 3:15].reshape(-1, 4, 3)
        out["jac_inv"] = v[:, 15:19]
        out["bias"] = v[:, 19:23]
    else:
        out["center"] = v[:, 3:6]
        out["tangent"] = np.stack([v[:, 6:9], v[:, 9:12]], axis=1)
        out["f_jac_inv"] = v[:, 12:14]
        out["friction"] = v[:, 14:14 + friction_words]
    return out


def _last_flags(nrec: int, beats_per: int) -> np.ndarray:
    last = np.zeros(nrec * beats_per, dtype=bool)
    if last.size:
        last[-1] = True
    return last


def pack_body_table(fmt: NumberFormat, bodies: BodyTable, beat_bits: int = DEFAULT_BODY_BEAT_BITS,
                    inertia_words: int = KERNEL_INERTIA_WORDS) -> Stream:
    """The body-in stream: one body-in record per body in index order, TLAST on the last beat."""
    data = pack_records(None, body_in_words(fmt, bodies, inertia_words), fmt.width, beat_bits)
    nbeats = beats_per_record(body_in_word_count(inertia_words) * fmt.width, beat_bits)
    return Stream(data, _last_flags(bodies.num_bodies, nbeats))


def unpack_body_table(fmt: NumberFormat, beats: np.ndarray, beat_bits: int = DEFAULT_BODY_BEAT_BITS,
                      inertia_words: int = KERNEL_INERTIA_WORDS) -> BodyTable:
    """Inverse of :func:`pack_body_table` (values decoded to float64; a scalar record's inverse inertia comes
    back as the three equal diagonal words of the body table)."""
    _, words = unpack_records(beats, body_in_word_count(inertia_words), fmt.width, beat_bits)
    v = fmt.decode(words)
    inertia = v[:, BODY_INV_INERTIA:BODY_INV_INERTIA + inertia_words]
    return BodyTable(position=v[:, BODY_POSITION:BODY_POSITION + 3],
                     orientation=v[:, BODY_ORIENTATION:BODY_ORIENTATION + 4],
                     linear_velocity=v[:, BODY_LINEAR_VELOCITY:BODY_LINEAR_VELOCITY + 3],
                     angular_velocity=v[:, BODY_ANGULAR_VELOCITY:BODY_ANGULAR_VELOCITY + 3],
                     inv_mass=v[:, BODY_INV_MASS].copy(),
                     inv_inertia=np.repeat(inertia, 3, axis=1) if inertia_words == 1 else inertia.copy())


def pack_body_out(fmt: NumberFormat, bodies: BodyTable, beat_bits: int = DEFAULT_BODY_BEAT_BITS) -> Stream:
    """The body-out stream the kernel produces for ``bodies`` (the expected output, for tests)."""
    data = pack_records(None, body_out_words(fmt, bodies), fmt.width, beat_bits)
    return Stream(data, _last_flags(bodies.num_bodies, beats_per_record(BODY_OUT_WORDS * fmt.width, beat_bits)))


def unpack_body_out(fmt: NumberFormat, beats: np.ndarray, beat_bits: int = DEFAULT_BODY_BEAT_BITS) -> np.ndarray:
    """Body-out beats -> (N, 13) uint64 bit patterns (pos(3), q(4), v(3), w(3))."""
    _, words = unpack_records(beats, BODY_OUT_WORDS, fmt.width, beat_bits)
    return words


def apply_body_out(fmt: NumberFormat, bodies: BodyTable, beats: np.ndarray,
                   beat_bits: int = DEFAULT_BODY_BEAT_BITS) -> BodyTable:
    """A copy of ``bodies`` with pos, q, v, w replaced by the decoded body-out stream."""
    v = fmt.decode(unpack_body_out(fmt, beats, beat_bits))
    out = bodies.copy()
    out.position, out.orientation = v[:, 0:3], v[:, 3:7]
    out.linear_velocity, out.angular_velocity = v[:, 7:10], v[:, 10:13]
    return out
