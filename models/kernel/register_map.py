"""The kernel's host interface, defined once: s_axi_control registers, their bits, and the error codes.

Every other copy is generated from this module (the SystemVerilog package ``pgs_regs_pkg`` and the HLS
header ``pgs_regs.h``, written by ``python -m rtl.gen``) or imports it (the Verilator harness driver, the
cocotb host driver, the coverage regression). The layout follows a Vitis HLS ``s_axilite port=return
bundle=control`` export: ap_ctrl_hs at 0x00 and one 8-byte slot per scalar argument from 0x10.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum


@dataclass(frozen=True)
class Register:
    """One 32-bit register of the control interface."""

    name: str
    offset: int  # byte address
    access: str  # "RW", "R", "W1C", "COR" (as in rtl/README.md)
    doc: str


# Scalar arguments in HLS argument order (sampled at ap_start; 8-byte stride, upper word reserved).
ARGUMENTS: tuple[Register, ...] = (
    Register("num_bodies", 0x10, "RW", "bodies (<= MAX_BODIES)"),
    Register("num_manifolds", 0x18, "RW", "manifolds per pass = slots per pass (<= MAX_MANIFOLDS)"),
    Register("iterations", 0x20, "RW", "contact and friction passes each (< 65536)"),
    Register("dt", 0x28, "RW", "format bit pattern"),
    Register("gravity_x", 0x30, "RW", "format bit pattern"),
    Register("gravity_y", 0x38, "RW", "format bit pattern"),
    Register("gravity_z", 0x40, "RW", "format bit pattern"),
    Register("damping", 0x48, "RW", "angular damping per step (format bit pattern)"),
    Register("options", 0x50, "RW", "bit 0: interleaved pass order; bit 1: soft contact (SOFT_CONTACT build)"),
    Register("lag", 0x90, "RW", "window kernel: slots a pass trails the pass before it"),
    Register("fetch_passes", 0x98, "RW", "window kernel: passes served by one fetch of the records"),
    Register("keep_dyn", 0xA0, "RW", "soft contact kernel: keep factor of a row between two dynamic bodies "
                                     "(format bit pattern)"),
    Register("keep_static", 0xA8, "RW", "soft contact kernel: keep factor of a row with a static body "
                                        "(format bit pattern)"),
)

# Control, status and counters.
CONTROL: tuple[Register, ...] = (
    Register("ap_ctrl", 0x00, "RW", "bit0 ap_start, bit1 ap_done, bit2 ap_idle, bit3 ap_ready, bit7 auto_restart, "
                                   "bit9 interrupt"),
    Register("gie", 0x04, "RW", "bit0 global interrupt enable"),
    Register("ier", 0x08, "RW", "bit0 ap_done, bit1 ap_ready interrupt enable"),
    Register("isr", 0x0C, "TOW", "bit0 ap_done, bit1 ap_ready interrupt status"),
    Register("status", 0x58, "W1C", "sticky error flags; bits 15:8 the first error code"),
    Register("cycles_lo", 0x60, "R", "cycles ap_start to ap_done, low word"),
    Register("cycles_hi", 0x64, "R", "cycles ap_start to ap_done, high word"),
    Register("stalls", 0x68, "R", "solve-phase stall cycles"),
    Register("bubbles", 0x70, "R", "solve-phase bubble cycles"),
    Register("issued", 0x78, "R", "manifold-passes issued"),
    Register("rejected", 0x7C, "R", "manifold-passes rejected"),
    Register("fp_overflow", 0x80, "R", "floating-point overflow events"),
    Register("fp_underflow", 0x84, "R", "floating-point underflow events"),
    Register("fp_invalid", 0x88, "R", "floating-point invalid (NaN) events"),
    Register("fp_status", 0x8C, "W1C", "sticky event flags: bit0 overflow, bit1 underflow, bit2 invalid"),
)

REGISTERS: dict[str, Register] = {r.name: r for r in CONTROL + ARGUMENTS}
OFFSET: dict[str, int] = {r.name: r.offset for r in REGISTERS.values()}
ARG_NAMES: tuple[str, ...] = tuple(r.name for r in ARGUMENTS)

# AP_CTRL bits
AP_START, AP_DONE, AP_IDLE, AP_READY, AUTO_RESTART = 1 << 0, 1 << 1, 1 << 2, 1 << 3, 1 << 7
AP_INTERRUPT = 1 << 9  # read only: the interrupt output (GIE && ISR != 0)
# options bits
OPT_INTERLEAVED = 1 << 0
OPT_SOFT_CONTACT = 1 << 1  # SOFT_CONTACT build: lam * keep before the add (keep_dyn, keep_static); ignored otherwise
# fp_status bits
FP_OVERFLOW_FLAG, FP_UNDERFLOW_FLAG, FP_INVALID_FLAG = 1 << 0, 1 << 1, 1 << 2
MAX_ITERATIONS = (1 << 16) - 1


class ErrorCode(IntEnum):
    """Codes of the status register (rtl/README.md, "Error codes")."""

    CONS_TLAST = 1  # constraint TLAST not on the last beat of a pass
    BODY_TLAST = 2  # body-in TLAST not on the last beat of the last body
    BAD_ARGS = 3  # an argument out of range (or a window plan that cannot progress)
    BODY_INDEX = 4  # a record names a body >= num_bodies, the same body twice, or a lane collision
    NON_FINITE = 5  # an infinity or NaN in a constraint or body record
    NEGATIVE_MASS = 6  # a negative inverse mass or inertia component
    STATIC_PAIR = 7  # a record joins two static bodies
    START_WHILE_BUSY = 8  # ap_start written while a run is pending or busy
    UNMAPPED = 9  # an AXI4-Lite access to an unmapped address


def status_flag(code: int) -> int:
    """The status register bit of an error code: bit k-1 for codes 1..8, bit 24+k-9 for codes 9..16."""
    if not 1 <= code <= 16:
        raise ValueError(f"error code {code} outside 1..16")
    return 1 << (code - 1) if code <= 8 else 1 << (24 + code - 9)


def status_codes(status: int) -> list[int]:
    """The error codes whose sticky flags are set in a status word."""
    return [c for c in range(1, 17) if status & status_flag(c)]


def first_error(status: int) -> int:
    """The code of the first error since the flags were last all clear (0 = none)."""
    return (status >> 8) & 0xFF
