"""Platform and DMA presets: how fast bytes reach the kernel.

A preset describes the data path between DDR and the kernel's streams: ``channels`` AXI DMA engines of
``channel_bits`` each (their streams are concatenated into one kernel stream beat of
``channels * channel_bits``), a start-up latency per transfer (memory-mapped requests take 30 to 50
cycles on the ZCU102, thesis section 5.2), and a DDR bandwidth cap shared by all channels (with the impulses in the records also by the impulse writes
back: ``models.kernel.stream_format.StreamLayout.ddr_read_share``; :attr:`DmaPreset.impulse_turnaround_cycles` from a
write to the read that depends on it). The kernel clock
turns bytes per second into bytes per cycle. The same numbers drive the cocotb DMA model
(``cocotb_tests/tb/axi_dma.py``) and the figures ``make sim`` reports (bandwidth floor, utilisation).

=========  ========  ============  ===========  ===========  ================================================
preset     channels  channel bits  DDR GB/s     clock MHz    source
=========  ========  ============  ===========  ===========  ================================================
zcu102     4         128           16.0         275          the thesis: 4 DMAs through HP ports, 16 GB/s PS DDR
zcu102_1   1         128           16.0         275          one DMA channel (the thesis's first 128-bit step)
u280       8         512           460.0        300          Alveo U280 HBM2 class (32 x 14.375 GB/s)
ideal      4         128           (none)       275          no DDR cap, no start-up latency
=========  ========  ============  ===========  ===========  ================================================
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


PRESETS: dict[str, DmaPreset] = {
    "zcu102": DmaPreset("zcu102", 4, 128, 16e9, 275e6, 40),
    "zcu102_1": DmaPreset("zcu102_1", 1, 128, 16e9, 275e6, 40),
    "u280": DmaPreset("u280", 8, 512, 460e9, 300e6, 40),
    "ideal": DmaPreset("ideal", 4, 128, None, 275e6, 0),
}


def get_preset(name: str) -> DmaPreset:
    try:
        return PRESETS[name]
    except KeyError:
        raise ValueError(f"unknown DMA preset {name!r} (expected one of {', '.join(PRESETS)})") from None
