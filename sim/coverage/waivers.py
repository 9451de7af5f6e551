"""The line points of ``rtl/`` that no run can reach or that Verilator does not count, each with its reason.

A waiver names the file and the source text of its line (stripped), not the line number, so that it follows the
line when the file changes; one the source no longer has waives nothing (``make coverage`` lists it as stale).
The report gives each configuration's line coverage both as measured and with the waived points set aside.
A waiver may hold for some configurations only (``applies``: e.g. the body of a loop over the lanes after the
first, which a one-lane build never runs); :func:`waivers_for` gives those of one configuration."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from sim.coverage.configurations import Configuration


def every_configuration(config: Configuration) -> bool:
    return True


@dataclass(frozen=True)
class Waiver:
    file: str  # relative to the repository, e.g. rtl/pgs_sequencer.sv
    source: str  # the line's text, stripped (a prefix of it)
    reason: str
    applies: Callable[[Configuration], bool] = every_configuration  # the configurations it holds for

    def matches(self, file: str, text: str) -> bool:
        return file == self.file and text.strip().startswith(self.source)


def one_lane(config: Configuration) -> bool:
    return config.lanes == 1


def no_bank_check(config: Configuration) -> bool:
    """Builds whose lanes never meet in the body banks: one lane, or the velocities as a multiport memory."""
    return config.lanes == 1 or config.build().body_banks == 0


INLINED_FUNCTION = ("an arm of the function mapped(), which Verilator inlines into the expressions that call it "
                    "and then never counts; both arms run (the register test reads every mapped register and "
                    "unmapped addresses, and the bad-input run `registers` writes an unmapped address: error 9)")
UNUSED_STATE = ("the default arm of a state machine whose state encodings are all named: unreachable; it returns "
                "the machine to idle after an upset")

WAIVERS: tuple[Waiver, ...] = (
    Waiver("rtl/pgs_control_s_axi.sv", "A_FP_STAT, A_LAG, A_FETCH", INLINED_FUNCTION),
    Waiver("rtl/pgs_control_s_axi.sv", "default:   return a[2:0] == 3'd4", INLINED_FUNCTION),
    Waiver("rtl/pgs_control_s_axi.sv", "default: wstate <= WR_IDLE;", UNUSED_STATE + " (write channel, 3 states)"),
    Waiver("rtl/pgs_control_s_axi.sv", "default: rstate <= RD_IDLE;", UNUSED_STATE + " (read channel, 3 states)"),
    Waiver("rtl/pgs_sequencer.sv", "default: phase <= S_IDLE;", UNUSED_STATE + " (the sequencer's phases)"),
    Waiver("rtl/pgs_seq_issue.sv", "for (int k = 0; k < l; k++) begin",
           "the lane-collision loop over the lanes before lane l: with one lane (LANES = 1) it has no iteration "
           "(the window kernel's lanes run it: `lanes_collide` edit)", one_lane),
    Waiver("rtl/pgs_seq_issue.sv", "function automatic logic [BANK_W-1:0] bank_of(",
           "a body's bank, called only by the lanes' bank-port check, which a build with one lane or without body "
           "banks (BODY_BANKS = 0) never runs (window-fp16-records-l2 runs it)", no_bank_check),
    Waiver("rtl/pgs_seq_issue.sv", "for (int k = 0; k < l; k++) begin   // the earlier issuing lanes' reads",
           "the bank-port check's loop over the lanes before lane l: a build with one lane or without body banks "
           "(BODY_BANKS = 0) never runs it (window-fp16-records-l2 runs it)", no_bank_check),
)


def waivers_for(config: Configuration, waivers: Iterable[Waiver] = WAIVERS) -> tuple[Waiver, ...]:
    """The waivers that hold for ``config``."""
    return tuple(w for w in waivers if w.applies(config))


@dataclass(frozen=True)
class ToggleWaiver:
    """The uncovered toggle points of one signal of one file (its name before the first ``[``, as the report
    groups them) that no bounded run can toggle, with the reason."""

    file: str
    signal: str
    reason: str
    applies: Callable[[Configuration], bool] = every_configuration  # the configurations it holds for


def impulses_on_chip(config: Configuration) -> bool:
    return not config.impulses_in_records


TIED_OFF_IMPULSE_OUT = ("the impulse-out stream of a build whose impulses stay on chip (IMPULSES_IN_RECORDS = 0): "
                        "its data, valid and last are tied to 0 and its ready is unused (the records builds, "
                        "stream-fp16-records and stream-fp32-records, drive it)")
COUNTER_HIGH_BITS = ("the upper bits of a run counter (64-bit cycles, 32-bit event counters): bit k first "
                     "toggles after 2^k counts, far beyond the regression's runs of thousands of cycles; their "
                     "read paths are toggled in full by the register file's test (all-ones / all-zeros)")
DIGIT_RECURRENCE = ("a digit recurrence's stage values: zeros shifted in and zero-padded operands keep the low "
                    "bits of later stages and the high bits of the trial values constant by construction "
                    "(the operator vectors run every 16-bit square-root input and every special pair)")
COUNTERS = ("stat_cycles", "stat_stalls", "stat_bubbles", "stat_issued", "stat_rejected", "stat_fp_overflow",
            "stat_fp_underflow", "stat_fp_invalid")
TOGGLE_WAIVERS: tuple[ToggleWaiver, ...] = (
    *(ToggleWaiver(f, c, COUNTER_HIGH_BITS) for c in COUNTERS
      for f in ("rtl/pgs_kernel.sv", "rtl/pgs_run_counters.sv", "rtl/pgs_sequencer.sv")),
    *(ToggleWaiver("rtl/fp/fp_sqrt.sv", s, DIGIT_RECURRENCE) for s in ("st_rad", "trial", "st_rem", "cur", "st_root")),
    ToggleWaiver("rtl/fp/fp_div.sv", "st_quo", DIGIT_RECURRENCE),
    *(ToggleWaiver("rtl/pgs_kernel.sv", f"m_axis_imp_{p}", TIED_OFF_IMPULSE_OUT, impulses_on_chip)
      for p in ("TDATA", "TVALID", "TREADY", "TLAST")),
    *(ToggleWaiver("rtl/pgs_sequencer.sv", f"m_imp_{p}", TIED_OFF_IMPULSE_OUT, impulses_on_chip)
      for p in ("tdata", "tvalid", "tready", "tlast")),
)


def toggle_waivers_for(config: Configuration,
                       waivers: Iterable[ToggleWaiver] = TOGGLE_WAIVERS) -> tuple[ToggleWaiver, ...]:
    """The toggle waivers that hold for ``config``."""
    return tuple(w for w in waivers if w.applies(config))


def waiver_for(file: str, text: str, waivers: Iterable[Waiver] = WAIVERS) -> Waiver | None:
    """The waiver of the line ``text`` of ``file``, if any."""
    return next((w for w in waivers if w.matches(file, text)), None)
