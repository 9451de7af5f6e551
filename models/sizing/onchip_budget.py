"""The on-chip memory budget of a banded kernel against a platform's block RAM and UltraRAM.

A banded kernel (``models/order/manifold_schedule.py``, band width D) reads each manifold record from DDR once and runs
the passes that trail it over an on-chip window of the last D records per trailing pass. What it keeps on chip:

* body state: the body-in record of every body (``BODY_IN_WORDS`` words: pos, q, v, w, 1/m, I^-1), what
  ``rtl/pgs_body_ram.sv`` holds, counted once (a board build replicates it per read/write port; not counted);
* accumulated impulses: 4 normal + 2 friction words per manifold (``rtl/pgs_impulse_ram.sv``), either
  resident for every manifold of the frame, or travelling with the records (then only the window holds them);
* the record window: ``trailing`` x D records, each a contact record plus a friction record (the two kinds of
  ``models/kernel/stream_format.py``, headers included) in their unpadded bits: on chip a record takes its bits,
  not the stream beats it was padded to.

The platforms (devices and their DMA) are ``models/timing/platforms.py``.
"""

from __future__ import annotations

from dataclasses import dataclass

from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS
from models.timing.platforms import Platform
from models.formats.number_format import NumberFormat
from models.kernel.stream_format import BODY_IN_WORDS, StreamLayout

IMPULSE_WORDS = 6  # lam[0..3] and lamT[0..1] per manifold (rtl/pgs_impulse_ram.sv)
def record_bytes(fmt: NumberFormat) -> int:
    """On-chip bytes of one manifold's records: contact + friction record bits (headers included), in bytes."""
    layout = StreamLayout(fmt)
    return -(-(layout.contact_bits + layout.friction_bits) // 8)


@dataclass(frozen=True)
class Budget:
    """The on-chip bytes of one configuration and whether they fit the platform's data capacity."""

    platform: Platform
    fmt: NumberFormat
    band: int  # D
    trailing: int  # passes trailing the streaming pass, each over its own window of D records
    impulses_resident: bool  # True: every manifold's impulses on chip; False: they travel with the records
    body_bytes: int
    impulse_bytes: int
    window_bytes: int
    num_bodies: int = 0  # the frame's sizes the budget is of
    num_manifolds: int = 0

    @property
    def total_bytes(self) -> int:
        return self.body_bytes + self.impulse_bytes + self.window_bytes

    @property
    def fits(self) -> bool:
        return self.total_bytes <= self.platform.data_bytes


def budget(platform: Platform, fmt: NumberFormat, num_bodies: int, num_manifolds: int, band: int,
           trailing: int = 1, impulses_resident: bool = True) -> Budget:
    """The budget of a frame (``num_bodies``, ``num_manifolds``) scheduled with band width ``band``."""
    if min(num_bodies, num_manifolds, band) < 0 or trailing < 1:
        raise ValueError("budget needs non-negative counts and at least one trailing pass")
    word = fmt.width
    window_records = trailing * band
    impulse_manifolds = num_manifolds if impulses_resident else window_records
    return Budget(platform, fmt, band, trailing, impulses_resident,
                  body_bytes=-(-num_bodies * BODY_IN_WORDS * word // 8),
                  impulse_bytes=-(-impulse_manifolds * IMPULSE_WORDS * word // 8),
                  window_bytes=window_records * record_bytes(fmt), num_bodies=num_bodies, num_manifolds=num_manifolds)


@dataclass(frozen=True)
class Floors:
    """Lower bounds, in cycles of one step, of a kernel that fetches each manifold's records once per
    ``fetch_every`` iterations (0: once per pass, the streaming kernel of ``rtl/``) and issues ``lanes``
    manifold-passes per cycle."""

    fetch_every: int
    lanes: int
    impulses_resident: bool
    bytes_per_step: int
    ddr_cycles: float  # bytes over the DDR bandwidth of the platform's DMA preset
    compute_cycles: float  # manifold-passes / lanes, plus a cycle per body to load and one to integrate
    manifold_passes: int

    @property
    def bound(self) -> str:
        return "DDR" if self.ddr_cycles >= self.compute_cycles else "compute"

    @property
    def cycles_per_manifold_pass(self) -> float:
        return max(self.ddr_cycles, self.compute_cycles) / self.manifold_passes


def floors(platform: Platform, fmt: NumberFormat, num_bodies: int, num_manifolds: int, iterations: int,
           fetch_every: int, lanes: int = 1, impulses_resident: bool = True) -> Floors:
    """DDR and compute floors of one step (``iterations`` of a contact and a friction pass).

    ``fetch_every`` = 0 is today's kernel: every pass streams its records as the DMA beats carry them (padding
    included, ``StreamLayout``); when the impulses are not resident they travel in the records (the streaming
    kernel built with IMPULSES_IN_RECORDS: the contact record 4, the friction record 6 words longer, in whole
    beats) and each pass writes its own back (the contact pass 4, the friction pass 2 words per manifold).
    ``fetch_every`` = k >= 1 streams a manifold's contact and friction record together once per k iterations, packed
    back to back (:func:`record_bytes`); when the impulses are not resident they are read and written back with each
    fetch. Body records go in and out once per step, in stream beats."""
    if iterations < 1 or fetch_every < 0 or lanes < 1 or min(num_bodies, num_manifolds) < 0:
        raise ValueError("floors need iterations >= 1, fetch_every >= 0, lanes >= 1 and non-negative counts")
    layout = StreamLayout(fmt)
    if fetch_every == 0:
        # impulses travelling with the records (as the thesis's did): in the records' beats, written back per pass
        carried = StreamLayout(fmt, impulses_in_records=not impulses_resident)
        records = num_manifolds * iterations * (carried.contact_bytes + carried.friction_bytes)
        impulses = num_manifolds * iterations * (carried.impulse_write_bytes(CONTACT_PASS)
                                                 + carried.impulse_write_bytes(FRICTION_PASS))
    else:
        fetches = num_manifolds * -(-iterations // fetch_every)
        records = fetches * record_bytes(fmt)
        impulses = 0 if impulses_resident else 2 * fetches * -(-IMPULSE_WORDS * fmt.width // 8)
    bodies = num_bodies * (layout.body_in_bytes + layout.body_out_bytes)
    total = records + impulses + bodies
    passes = 2 * iterations * num_manifolds
    return Floors(fetch_every, lanes, impulses_resident, total, total / platform.preset.ddr_bytes_per_cycle,
                  passes / lanes + 2 * num_bodies, passes)
