"""The banked body velocities (``BODY_BANKS`` of ``rtl/pgs_kernel.sv``, ``rtl/pgs_body_vel_banks.sv``): which builds
use them, and the port rule the sequencer and the cycle model share.

The streaming kernel reads the velocities of a record's bodies A and B in its issue cycle and writes the dynamic
ones of the manifold retiring in that cycle (two reads and up to two writes a cycle; the window kernel with L lanes
reads bodies A and B of the offered record's issuing lanes and writes those of the retiring one's: 2 L each). With
``banks > 0`` the
velocities are one copy in ``banks`` true dual-port banks, body k in bank ``k mod banks``, two ports per bank per
cycle. The writes are served first; a record does not issue in a cycle where a bank would be asked for more than
two accesses (it stalls one cycle and tries again; the retire writes of that cycle are then done).
``banks = 0``: the velocities as a multiport memory (a live-value table on a board), no such stall.
"""

from __future__ import annotations

from models.formats.number_format import NumberFormat

PORTS_PER_BANK = 2  # a true dual-port RAMB36E2 / URAM
RECORDS_BANKS = 2  # the records design's banks (docs/resources.md: cycles and LUTs per bank count)
# the window kernel's banks per lane with the impulses in the records: it issues a record every cycle, so the banks'
# ports meet a retire's writes and the offered record's reads (2 each per lane) every cycle; on the thesis frame
# (cycle model, docs/results/kernel_speed.md) one lane in fp32 (ring 8,192) stalls 0.65 cycles per manifold-pass on
# a busy bank with 2 banks, 0.32 with 4, 0.0003 with 8; two lanes in fp16 (ring 8,192) 0.24 with 8 banks, 0.034
# with 16, 0.0075 with 32 (which do not fit the ZCU102's LUTs)
WINDOW_BANKS = 8


def default_body_banks(fmt: NumberFormat, impulses_in_records: bool, window: bool, lanes: int = 1) -> int:
    """The banks of the build that runs a step: the streaming kernel with the impulses in the records in a format of
    32 bits or more banks its velocities (its live-value table's four copies overflow the ZCU102's block RAM there:
    134% of it on the thesis frame in fp32), and so does the window kernel with the impulses in the records in every
    format and with any lanes (beside its ring, the four copies of one lane overflow the block RAM on the thesis
    frame, and two lanes' live-value table needs 16) in :data:`WINDOW_BANKS` banks per lane; every other build keeps
    the multiport memory (0)."""
    if not impulses_in_records:
        return 0
    if window:
        return WINDOW_BANKS * lanes
    return RECORDS_BANKS if fmt.width >= 32 else 0


def check_banks(banks: int) -> int:
    """``banks``, or a ValueError unless it is 0 or a power of two."""
    if banks < 0 or banks & (banks - 1):
        raise ValueError(f"body banks must be 0 or a power of two, got {banks}")
    return banks


def over_ports(banks: int, accesses: tuple[int, ...]) -> bool:
    """Whether the bodies ``accesses`` (reads and writes of one cycle, ``banks > 0``) ask some bank for more than
    its ports. A record of several lanes must not by its reads alone (bodies A and B of its lanes, static ones
    too): the host's lane plan closes a record before it would, the kernel rejects such a lane."""
    acc = [b % banks for b in accesses]
    return any(acc.count(k) > PORTS_PER_BANK for k in set(acc))


def busy(banks: int, reads: tuple[int, ...], writes: tuple[int, ...]) -> bool:
    """Whether a bank is asked for more than its ports by the bodies read (``reads``) and written (``writes``) in
    one cycle (``banks > 0``)."""
    return over_ports(banks, writes + reads)
