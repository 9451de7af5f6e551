"""The platforms' resources (one table), and the on-chip memory budget of a banded kernel against them.

A banded kernel (``models/order/manifold_schedule.py``, band width D) reads each manifold record from DDR once and runs the
passes that trail it over an on-chip window of the last D records per trailing pass. What it keeps on chip:

* body state: the body-in record of every body (``BODY_IN_WORDS`` words: pos, q, v, w, 1/m, I^-1), what
  ``rtl/pgs_body_ram.sv`` holds, counted once (a board build replicates it per read/write port; not counted);
* accumulated impulses: 4 normal + 2 friction words per manifold (``rtl/pgs_impulse_ram.sv``), either
  resident for every manifold of the frame, or travelling with the records (then only the window holds them);
* the record window: ``trailing`` x D records, each a contact record plus a friction record (the two kinds of
  ``models/kernel/stream_format.py``, headers included) in their unpadded bits: on chip a record takes its bits,
  not the stream beats it was padded to.

Capacity counts the data bits of a block at the word widths the kernel uses (16 and 32 bits): 32 Kib per
BRAM36 (the 4 Kib of parity per block hold no data at these widths; raw 36 Kib) and 256 Kib per UltraRAM
(4K x 72 bits, of which a 64-bit pair of words uses 64; raw 288 Kib).

=========  =========  =========  =====  ===========  ==============  =====================  ==========================
platform   LUT        FF         DSP    block RAM    UltraRAM        data (raw)             source
=========  =========  =========  =====  ===========  ==============  =====================  ==========================
zcu102     274,080    548,160    2,520  912 BRAM36   none            3.5625 MiB (4.01 MiB)  XCZU9EG, AMD DS891
u280       1,303,680  2,607,360  9,024  4,032 BRAM18 960 x 288 Kib   37.9 MiB (42.6 MiB)    Alveo U280, a public Vitis
                                                                                            HLS report ("Available")
=========  =========  =========  =====  ===========  ==============  =====================  ==========================

A design *fits* when every resource stays within its usable share of the device (:data:`USABLE_SHARE`: 85% of
the LUT, FF and DSP, 95% of the block RAM and UltraRAM, the headroom placement and routing need).

Each platform names its DMA preset (``models/timing/platforms.py``) for the off-chip side.
"""

from __future__ import annotations

from dataclasses import dataclass

from models.golden.contact_solver import CONTACT_PASS, FRICTION_PASS
from models.timing.platforms import DmaPreset, get_preset
from models.formats.number_format import NumberFormat
from models.kernel.stream_format import BODY_IN_WORDS, StreamLayout

IMPULSE_WORDS = 6  # lam[0..3] and lamT[0..1] per manifold (rtl/pgs_impulse_ram.sv)
KIB = 1024 // 8  # bytes per Kib
BRAM36_DATA_KIB = 32
BRAM36_RAW_KIB = 36
URAM_DATA_KIB = 256
URAM_RAW_KIB = 288


USABLE_SHARE = {"LUT": 0.85, "FF": 0.85, "DSP": 0.85, "BRAM36": 0.95, "URAM": 0.95}


def describe_usable() -> str:
    return ", ".join(f"{k} {100 * v:g}%" for k, v in USABLE_SHARE.items())


@dataclass(frozen=True)
class Platform:
    """A board's device: its logic (LUT, FF, DSP48E2), its on-chip RAM (BRAM36 blocks, a BRAM18 pair counting as
    one, and UltraRAM blocks) and the DMA preset of its off-chip side."""

    name: str
    dma: str  # DMA preset name (models.timing.platforms.PRESETS)
    bram36: int
    uram: int
    lut: int = 0
    ff: int = 0
    dsp: int = 0

    @property
    def data_bytes(self) -> int:
        """Bytes of data the blocks hold at 16/32-bit word widths (the figure budgets are checked against)."""
        return (self.bram36 * BRAM36_DATA_KIB + self.uram * URAM_DATA_KIB) * KIB

    @property
    def raw_bytes(self) -> int:
        """Bytes including the parity / 72-bit-word bits that such words leave unused."""
        return (self.bram36 * BRAM36_RAW_KIB + self.uram * URAM_RAW_KIB) * KIB

    @property
    def preset(self) -> DmaPreset:
        return get_preset(self.dma)

    def capacity(self, resource: str) -> int:
        """The device's count of ``resource`` (a key of USABLE_SHARE)."""
        return {"LUT": self.lut, "FF": self.ff, "DSP": self.dsp, "BRAM36": self.bram36, "URAM": self.uram}[resource]

    def describe(self) -> str:
        uram = f", {self.uram:,} URAM" if self.uram else ", no URAM"
        return f"{self.lut:,} LUT, {self.ff:,} FF, {self.dsp:,} DSP, {self.bram36:,} BRAM36{uram}"


PLATFORMS: dict[str, Platform] = {
    "zcu102": Platform("zcu102", "zcu102", bram36=912, uram=0, lut=274_080, ff=548_160, dsp=2_520),
    "u280": Platform("u280", "u280", bram36=4032 // 2, uram=960, lut=1_303_680, ff=2_607_360, dsp=9_024),
}


def get_platform(name: str) -> Platform:
    try:
        return PLATFORMS[name]
    except KeyError:
        raise ValueError(f"unknown platform {name!r} (expected one of {', '.join(PLATFORMS)})") from None


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
    beats) and each pass writes its own back (the contact pass 4, the friction pass 2 words per manifold). ``fetch_every`` = k >= 1 streams a manifold's contact and friction record together
    once per k iterations, packed back to back (:func:`record_bytes`); when the impulses are not resident they
    are read and written back with each fetch. Body records go in and out once per step, in stream beats."""
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
