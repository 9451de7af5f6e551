"""The platforms, one table (:data:`_TABLE`): each row a DMA data path (how fast bytes reach the kernel) and, for a
board, its device (what fits on it). :data:`PRESETS` and :data:`PLATFORMS` are read off it.

A DMA preset (:class:`DmaPreset`) is the data path between DDR and the kernel's streams: ``channels`` AXI DMA engines
of ``channel_bits`` each (their streams side by side form one kernel stream beat), a start-up latency per transfer
(memory-mapped requests take 30 to 50 cycles on the ZCU102, thesis section 5.2) and a DDR bandwidth cap shared by
all channels (with the impulses in the records also by the impulse writes back:
``models.kernel.stream_format.StreamLayout.ddr_read_share``; :attr:`DmaPreset.impulse_turnaround_cycles` from a write
to the read that depends on it). The kernel clock turns bytes per second into bytes per cycle. The same numbers drive
the harness's and cocotb's DMA models (``cocotb_tests/tb/axi_dma.py``) and the figures ``make sim`` reports.
Sources: ``zcu102``, the thesis (4 DMAs through HP ports, 16 GB/s PS DDR); ``u280``, Alveo U280 HBM2 (32 x 14.375
GB/s); ``zcu102_1`` and ``ideal`` are variants for studies (one channel; no DDR cap and no start-up latency).

A board's device (:class:`Platform`): LUT, FF, DSP48E2, block RAM (BRAM36; a BRAM18 pair counts as one) and UltraRAM;
XCZU9EG from AMD DS891, the U280 from a public Vitis HLS report ("Available"). Capacity counts the data bits of a
block at the word widths the kernel uses (16 and 32 bits): 32 Kib per BRAM36 (the 4 Kib of parity per block hold no
data at these widths; raw 36 Kib) and 256 Kib per UltraRAM (4K x 72 bits, of which a 64-bit pair of words uses 64;
raw 288 Kib). A design *fits* when every resource stays within its usable share of the device
(:data:`USABLE_SHARE`: 85% of the LUT, FF and DSP, 95% of the block RAM and UltraRAM, the headroom placement and
routing need).
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class DmaPreset:
    name: str
    channels: int
    channel_bits: int
    ddr_bytes_per_s: float | None  # None: no cap beyond the streams themselves
    clock_hz: float
    startup_cycles: int  # cycles from a LENGTH write to the first beat of a transfer

    def __post_init__(self) -> None:
        if not (1 <= self.channels <= 16):
            raise ValueError(f"DMA channels must be 1..16, got {self.channels}")
        if self.channel_bits % 8 or not (32 <= self.channel_bits <= 1024):
            raise ValueError(f"DMA channel width must be a byte multiple in 32..1024 bits, got {self.channel_bits}")
        if self.clock_hz <= 0:
            raise ValueError("kernel clock must be positive")

    @property
    def stream_bits(self) -> int:
        """Width of one kernel stream beat (all channels side by side)."""
        return self.channels * self.channel_bits

    @property
    def port_bytes_per_cycle(self) -> float:
        return self.stream_bits / 8.0

    @property
    def ddr_bytes_per_cycle(self) -> float:
        return math.inf if self.ddr_bytes_per_s is None else self.ddr_bytes_per_s / self.clock_hz

    @property
    def bytes_per_cycle(self) -> float:
        """Sustained bytes per kernel cycle: the lower of the stream ports and the DDR cap."""
        return min(self.port_bytes_per_cycle, self.ddr_bytes_per_cycle)

    @property
    def beats_per_cycle(self) -> float:
        """Sustained kernel-stream beats per cycle (<= 1)."""
        return min(1.0, self.bytes_per_cycle / self.port_bytes_per_cycle)

    @property
    def impulse_turnaround_cycles(self) -> int:
        """Impulses in the records: cycles from an impulse-out record leaving the kernel to the first beat of a
        record that reads it: the S2MM write's latency to DDR and the MM2S read's, each the memory-mapped request
        latency (``startup_cycles``); at least one cycle."""
        return max(1, 2 * self.startup_cycles)

    def transfer_cycles(self, nbytes: int) -> float:
        """Cycles to move ``nbytes`` in one transfer, start-up latency included (a floor: no stalls)."""
        if nbytes <= 0:
            return 0.0
        beats = math.ceil(nbytes * 8 / self.stream_bits)
        return self.startup_cycles + beats / self.beats_per_cycle

    def describe(self) -> str:
        ddr = "uncapped" if self.ddr_bytes_per_s is None else f"{self.ddr_bytes_per_s / 1e9:g} GB/s DDR"
        return (f"{self.name}: {self.channels} x {self.channel_bits}-bit DMA, {ddr}, {self.clock_hz / 1e6:g} MHz, "
                f"{self.bytes_per_cycle:.2f} B/cycle, start-up {self.startup_cycles} cycles")


def get_preset(name: str) -> DmaPreset:
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown DMA preset {name!r} (expected one of {', '.join(PRESETS)})") from None


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
    dma: str  # DMA preset name (PRESETS)
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


@dataclass(frozen=True)
class Device:
    """A board's FPGA: its logic and its on-chip RAM (a BRAM18 pair counting as one BRAM36)."""

    lut: int
    ff: int
    dsp: int
    bram36: int
    uram: int


XCZU9EG = Device(lut=274_080, ff=548_160, dsp=2_520, bram36=912, uram=0)  # the ZCU102's; AMD DS891
ALVEO_U280 = Device(lut=1_303_680, ff=2_607_360, dsp=9_024, bram36=4032 // 2, uram=960)  # a Vitis HLS report

# The one table. name: DMA engines, channel bits, DDR bytes/s (None: uncapped), kernel clock, start-up cycles per
# transfer, the device (None: a data path without a board of its own, which has no fit verdict).
_TABLE: tuple[tuple[str, int, int, float | None, float, int, Device | None], ...] = (
    ("zcu102", 4, 128, 16e9, 275e6, 40, XCZU9EG),
    ("zcu102_1", 1, 128, 16e9, 275e6, 40, None),  # one DMA channel of the ZCU102 (the thesis's first 128-bit step)
    ("u280", 8, 512, 460e9, 300e6, 40, ALVEO_U280),
    ("ideal", 4, 128, None, 275e6, 0, None),  # no DDR cap, no start-up latency
)
PRESETS: dict[str, DmaPreset] = {row[0]: DmaPreset(*row[:6]) for row in _TABLE}
PLATFORMS: dict[str, Platform] = {name: Platform(name, name, bram36=dev.bram36, uram=dev.uram, lut=dev.lut,
                                                 ff=dev.ff, dsp=dev.dsp)
                                  for name, *_, dev in _TABLE if dev is not None}


def get_platform(name: str) -> Platform:
    try:
        return PLATFORMS[name]
    except KeyError:
        raise ValueError(f"unknown platform {name!r} (expected one of {', '.join(PLATFORMS)})") from None



