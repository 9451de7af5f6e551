"""Mixed storage's record layout: which field group every word of a streamed record belongs to, the records' bits
when each group is stored in a format of its own (the arithmetic staying in the kernel's format), and the
format converters the kernel would need at unpack (records and body-in) and pack (body-out, impulse-out).

The groups are ``models/sizing/format_analyzer.py``'s (positions, orientations, velocities, mass properties, contact
geometry, solver coefficients) and the impulses the records carry (the streaming kernel built with the impulses
in the records). Word counts per record and group (:func:`group_words`), their sums checked against
``models/kernel/stream_format.py``'s record layouts:

=================  ==========================================================================================
record             groups (words)
=================  ==========================================================================================
contact            contact geometry n(3), p[0..3](12); solver coefficients jac_inv(4), b(4); impulses lam(4)
friction           contact geometry n(3), c(3), t0, t1 (6, none with the tangents derived on chip); solver
                   coefficients f_jac_inv(2), mu (F); impulses lam(4), lamT(2)
body-in            positions (3), orientations (4), velocities (6), mass properties (1 + I)
body-out           positions (3), orientations (4), velocities (6)
impulse-out        impulses: contact lam(4), friction lamT(2) (only the bytes a pass writes back)
=================  ==========================================================================================

Records keep the 64-bit header and stay padded to whole beats (``StreamLayout(record_bits=...)``). No RTL packs
or unpacks such records: this layout feeds the cycle model and the resource model only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Mapping

from models.kernel import stream_format as sf
from models.formats.number_format import NumberFormat

POSITIONS, ORIENTATIONS, VELOCITIES, MASS = "positions", "orientations", "velocities", "mass properties"
GEOMETRY, COEFFICIENTS, IMPULSES = "contact geometry", "solver coefficients", "impulses"
STORED_GROUPS = (POSITIONS, ORIENTATIONS, VELOCITIES, MASS, GEOMETRY, COEFFICIENTS, IMPULSES)
RECORDS = ("contact", "friction", "body-in", "body-out", "impulse-out contact", "impulse-out friction")
UNPACKED = ("contact", "friction", "body-in")  # read by the kernel: stored -> kernel format
PACKED = ("body-out", "impulse-out contact")  # written by the kernel (friction's lamT share contact's lanes)


@dataclass(frozen=True)
class RecordShape:
    """The options of the streaming kernel that change a record's words."""

    impulses_in_records: bool = True
    tangents_on_chip: bool = False
    inertia_words: int = sf.KERNEL_INERTIA_WORDS
    friction_words: int = 0


def group_words(record: str, shape: RecordShape) -> dict[str, int]:
    """Words of each group in ``record`` (the header aside); sums equal ``models/kernel/stream_format.py``'s layouts."""
    imp = shape.impulses_in_records
    tangents = 0 if shape.tangents_on_chip else sf.TANGENT_WORDS
    table = {
        "contact": {GEOMETRY: 15, COEFFICIENTS: 8, IMPULSES: sf.CONTACT_IMPULSE_WORDS if imp else 0},
        "friction": {GEOMETRY: 6 + tangents, COEFFICIENTS: 2 + shape.friction_words,
                     IMPULSES: sf.FRICTION_IMPULSE_WORDS if imp else 0},
        "body-in": {POSITIONS: 3, ORIENTATIONS: 4, VELOCITIES: 6, MASS: 1 + shape.inertia_words},
        "body-out": {POSITIONS: 3, ORIENTATIONS: 4, VELOCITIES: 6},
        "impulse-out contact": {IMPULSES: sf.CONTACT_IMPULSE_WORDS},
        "impulse-out friction": {IMPULSES: 2},
    }
    if record not in table:
        raise ValueError(f"unknown record {record!r} (records: {', '.join(RECORDS)})")
    return {g: n for g, n in table[record].items() if n}


def _check_storage(storage: Mapping[str, NumberFormat]) -> None:
    unknown = sorted(set(storage) - set(STORED_GROUPS))
    if unknown:
        raise ValueError(f"unknown field groups {unknown} (groups: {', '.join(STORED_GROUPS)})")


def word_bits(storage: Mapping[str, NumberFormat], compute: NumberFormat) -> dict[str, int]:
    """Bits of a word of every group: its storage format's width, the kernel format's where none is given."""
    _check_storage(storage)
    return {g: storage[g].width if g in storage else compute.width for g in STORED_GROUPS}


def record_bits(storage: Mapping[str, NumberFormat], compute: NumberFormat, shape: RecordShape) -> sf.RecordBits:
    """The records' unpadded bits with every group in its storage format (the header 64 bits as before)."""
    bits = word_bits(storage, compute)

    def size(record: str, header: int = 0) -> int:
        return header + sum(n * bits[g] for g, n in group_words(record, shape).items())

    return sf.RecordBits(contact=size("contact", sf.HEADER_BITS), friction=size("friction", sf.HEADER_BITS),
                         body_in=size("body-in"), body_out=size("body-out"),
                         impulse_out_contact=size("impulse-out contact"),
                         impulse_out_friction=size("impulse-out friction"))


@dataclass(frozen=True)
class Converters:
    """Format converters of one stored format: ``count`` words converted ``direction`` ("unpack": stored ->
    kernel format as the records arrive; "pack": kernel format -> stored, rounded to nearest even, as results
    leave)."""

    direction: str
    stored: NumberFormat
    count: int


def converters(storage: Mapping[str, NumberFormat], compute: NumberFormat,
               shape: RecordShape) -> tuple[Converters, ...]:
    """One converter per word position of every record the kernel reads or writes whose group is stored in a
    format other than the kernel's (contact and friction records have their own unpackers: they are assembled
    into different word positions)."""
    _check_storage(storage)
    count: dict[tuple[str, NumberFormat], int] = {}
    for direction, records in (("unpack", UNPACKED), ("pack", PACKED)):
        for record in records:
            for g, n in group_words(record, shape).items():
                fmt = storage.get(g, compute)
                if fmt != compute:
                    count[(direction, fmt)] = count.get((direction, fmt), 0) + n
    return tuple(Converters(d, f, n) for (d, f), n in sorted(count.items(), key=lambda kv: (kv[0][0], kv[0][1].name)))
