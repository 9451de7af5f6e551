"""A model of the Xilinx AXI DMA (PG021) in simple (direct register) mode, with modeled bandwidth.

Each :class:`AxiDmaEngine` is one AXI DMA IP with the PG021 register map (addressable as a cocotbext-axi
``Region``, so a host driver reads and writes it by offset like PYNQ's ``_DMAChannel``):

======  ==============  ==========================================================================
offset  register        modeled bits
======  ==============  ==========================================================================
0x00    MM2S_DMACR      RS (0), Reset (2), IOC_IrqEn (12), Err_IrqEn (14)
0x04    MM2S_DMASR      Halted (0, reset 1), Idle (1), DMAIntErr (4), DMASlvErr (5), DMADecErr (6),
                        IOC_Irq (12, W1C), Err_Irq (14, W1C)
0x18    MM2S_SA         source address (low), 0x1C: high word
0x28    MM2S_LENGTH     bytes; writing it starts the transfer (when running)
0x30    S2MM_DMACR      as MM2S_DMACR
0x34    S2MM_DMASR      as MM2S_DMASR
0x48    S2MM_DA         destination address (low), 0x4C: high word
0x58    S2MM_LENGTH     buffer bytes; writing it arms the channel; on completion it holds the bytes
                        actually written. A packet longer than the buffer sets DMAIntErr and halts.
======  ==============  ==========================================================================

A soft reset (DMACR.Reset) of an engine also ends the transfers of its ports that are in progress (the stream
stops where it is; nothing is written or completed), as the IP's reset does.

A :class:`DmaStreamPort` joins ``channels`` engines to one kernel AXI4-Stream port of
``channels * channel_bits``: lane e of every beat comes from (or goes to) engine e's buffer, so the host
splits a record stream into per-engine lane buffers (``split_lanes``/``join_lanes``). A transfer starts once
every engine of the port is armed with the same length, after the preset's start-up latency; beats then flow
at most at the DDR rate, a token bucket shared by all ports (:class:`DdrBandwidth`), and optionally through a
seeded random gate (idle cycles on MM2S, backpressure on S2MM).

:class:`BurstDmaStreamPort` is the same port on the transaction-level bench (``pgs_kernel_burst_tb.sv``): same
engines, registers and transfers, but the beats move a burst at a time through the bench's buffers and DDR
token bucket, without Python per beat (no random gates there: the cycle-level handshake is not what it checks).
"""

from __future__ import annotations

import random
from dataclasses import dataclass, field
from typing import Any, Optional

import cocotb
import numpy as np
from cocotb.triggers import ClockCycles, Event, RisingEdge
from cocotbext.axi import Region

from models.timing.platforms import DmaPreset

from cocotb_tests.tb.axis_words import AxisWordSink, AxisWordSource, Gate
from cocotb_tests.tb.burst_streams import BurstSink, BurstSource

MM2S, S2MM = 0x00, 0x30
DMACR, DMASR, ADDR, ADDR_MSB, LENGTH = 0x00, 0x04, 0x18, 0x1C, 0x28
CR_RS, CR_RESET = 1 << 0, 1 << 2
SR_HALTED, SR_IDLE = 1 << 0, 1 << 1
SR_INT_ERR, SR_SLV_ERR, SR_DEC_ERR = 1 << 4, 1 << 5, 1 << 6
SR_IOC_IRQ, SR_ERR_IRQ = 1 << 12, 1 << 14
IRQ_MASK = SR_IOC_IRQ | (1 << 13) | SR_ERR_IRQ


@dataclass
class _Channel:
    dmacr: int = 0
    dmasr: int = SR_HALTED
    addr: int = 0
    length: int = 0
    pending: bool = False  # a transfer was started by a LENGTH write and has not completed
    wake: Event = field(default_factory=Event)  # set on every arm and reset
    resets: int = 0  # soft resets so far (a transfer in progress ends when this changes)
    done: Event = field(default_factory=Event)  # set on every completion (the IOC / error interrupt)

    def reset(self) -> None:
        self.dmacr, self.dmasr, self.addr, self.length = 0, SR_HALTED, 0, 0
        self.pending = False
        self.resets += 1
        self.wake.set()

    def arm(self) -> None:
        self.dmasr &= ~SR_IDLE
        self.pending = True
        self.wake.set()

    @property
    def running(self) -> bool:
        return bool(self.dmacr & CR_RS) and not (self.dmasr & SR_HALTED)

    def complete(self, error: int = 0) -> None:
        if error:
            self.dmasr |= error | SR_ERR_IRQ | SR_HALTED
            self.dmacr &= ~CR_RS
        else:
            self.dmasr |= SR_IOC_IRQ
        self.dmasr |= SR_IDLE
        self.pending = False
        self.done.set()


class AxiDmaEngine(Region):
    """One AXI DMA (PG021, direct register mode): registers plus the pending transfer of each channel."""

    def __init__(self, name: str, memory_size: int, length_bits: int = 26):
        super().__init__(0x10000)
        self.name = name
        self.memory_size = memory_size
        self.length_mask = (1 << length_bits) - 1
        self.mm2s = _Channel()
        self.s2mm = _Channel()

    def _chan(self, offset: int) -> tuple[_Channel, int]:
        return (self.s2mm, offset - S2MM) if offset >= S2MM else (self.mm2s, offset)

    def read_reg(self, offset: int) -> int:
        ch, reg = self._chan(offset)
        if reg == DMACR:
            return ch.dmacr | 0x2  # bit 1 reserved, reads 1
        if reg == DMASR:
            return ch.dmasr
        if reg == ADDR:
            return ch.addr & 0xFFFFFFFF
        if reg == ADDR_MSB:
            return ch.addr >> 32
        if reg == LENGTH:
            return ch.length
        return 0

    def write_reg(self, offset: int, value: int) -> None:
        ch, reg = self._chan(offset)
        if reg == DMACR:
            if value & CR_RESET:
                self.mm2s.reset()
                self.s2mm.reset()
                return
            ch.dmacr = value & ~CR_RESET
            if value & CR_RS:
                ch.dmasr &= ~SR_HALTED
        elif reg == DMASR:
            ch.dmasr &= ~(value & IRQ_MASK)  # write 1 to clear the interrupt bits
        elif reg == ADDR:
            ch.addr = (ch.addr & ~0xFFFFFFFF) | value
        elif reg == ADDR_MSB:
            ch.addr = (ch.addr & 0xFFFFFFFF) | (value << 32)
        elif reg == LENGTH:
            ch.length = value & self.length_mask
            if not ch.running or ch.length == 0:
                return
            if ch.addr + ch.length > self.memory_size:
                ch.complete(SR_DEC_ERR)
                return
            ch.arm()

    async def _read(self, address: int, length: int, **kwargs: Any) -> bytes:
        out = bytearray()
        for base in range(address & ~3, address + length, 4):
            out += self.read_reg(base).to_bytes(4, "little")
        start = address & 3
        return bytes(out[start:start + length])

    async def _write(self, address: int, data: bytes, **kwargs: Any) -> None:
        if address & 3 or len(data) != 4:
            raise ValueError(f"{self.name}: registers take aligned 32-bit writes")
        self.write_reg(address, int.from_bytes(bytes(data), "little"))


class DdrBandwidth:
    """A token bucket of DDR bytes per kernel cycle, shared by every stream port."""

    def __init__(self, clock: Any, preset: DmaPreset):
        self.rate = preset.ddr_bytes_per_cycle
        self.credit = 0.0
        self.cap = 2.0 * preset.stream_bits / 8.0
        self.bytes_moved = 0
        cocotb.start_soon(self._refill(clock))

    async def _refill(self, clock: Any) -> None:
        while True:
            await RisingEdge(clock)
            self.credit = min(self.cap, self.credit + self.rate)

    def available(self, nbytes: int) -> bool:
        return self.rate == float("inf") or self.credit >= nbytes

    def take(self, nbytes: int) -> bool:
        """Spend ``nbytes`` of credit if there is enough (a beat that will move)."""
        if not self.available(nbytes):
            return False
        self.spend(nbytes)
        return True

    def spend(self, nbytes: int) -> None:
        if self.rate != float("inf"):
            self.credit -= nbytes
        self.bytes_moved += nbytes


def split_lanes(data: bytes, channels: int, lane_bytes: int) -> list[bytes]:
    """Split a stream of beats into the per-engine lane buffers (lane e = bytes [e*L, (e+1)*L) of each beat)."""
    beat = channels * lane_bytes
    if len(data) % beat:
        raise ValueError(f"stream of {len(data)} bytes is not a whole number of {beat}-byte beats")
    beats = np.frombuffer(data, np.uint8).reshape(-1, channels, lane_bytes)
    return [beats[:, e].tobytes() for e in range(channels)]


def join_lanes(lanes: list[bytes], lane_bytes: int) -> bytes:
    per_lane = [np.frombuffer(lane, np.uint8).reshape(-1, lane_bytes) for lane in lanes]
    return np.stack(per_lane, axis=1).tobytes()


class DmaStreamPort:
    """``channels`` engines feeding (MM2S) or draining (S2MM) one kernel AXI4-Stream port."""

    def __init__(self, dut: Any, prefix: str, clock: Any, engines: list[AxiDmaEngine], memory: Region,
                 preset: DmaPreset, ddr: Optional[DdrBandwidth], direction: str, rng: Optional[random.Random] = None,
                 idle_prob: float = 0.0):
        self.engines, self.memory, self.preset, self.ddr = engines, memory, preset, ddr
        self.lane_bytes = preset.channel_bits // 8
        self.beat_bytes = self.lane_bytes * len(engines)
        self.rng, self.idle_prob = rng, idle_prob
        self.clock = clock
        self.transfers = 0
        self.busy_cycles = 0
        if direction not in ("mm2s", "s2mm"):
            raise ValueError(f"direction must be mm2s or s2mm, got {direction!r}")
        self._attach(dut, prefix, direction)
        cocotb.start_soon(self._run_mm2s() if direction == "mm2s" else self._run_s2mm())

    def _attach(self, dut: Any, prefix: str, direction: str) -> None:
        """The stream models of the port: one beat per cycle, paced by the gates."""
        if direction == "mm2s":
            self.source = AxisWordSource(dut, prefix, self.clock)
        else:
            self.sink = AxisWordSink(dut, prefix, self.clock)

    async def _send(self, data: bytes, aborted: Gate) -> bool:
        """Move ``data`` onto the stream (TLAST on its last beat); False when ``aborted`` ended it first."""
        beats = [int.from_bytes(b, "little") for b in _beats(data, self.beat_bytes)]
        start = self.source.cycle
        sent = await self.source.send(beats, gate=self._source_gate, abort=aborted)
        self.busy_cycles += self.source.cycle - start
        return sent

    async def _receive(self, max_beats: int, aborted: Gate) -> tuple[bytes, int, bool]:
        """Take a packet of at most ``max_beats`` beats; returns (bytes, beats, ended_with_tlast)."""
        beats, ended = await self.sink.recv_packet(max_beats, gate=self._sink_gate,
                                                   on_beat=lambda _b, _l: self.ddr.spend(self.beat_bytes),
                                                   abort=aborted)
        return b"".join(b.to_bytes(self.beat_bytes, "little") for b in beats), len(beats), ended

    def _stalled(self) -> bool:
        return self.rng is not None and bool(self.idle_prob) and self.rng.random() < self.idle_prob

    def _source_gate(self) -> bool:
        """MM2S: present a beat when not idling and the DDR has delivered its bytes."""
        return not self._stalled() and self.ddr.take(self.beat_bytes)

    def _sink_gate(self) -> bool:
        """S2MM: assert TREADY when not backpressuring and the DDR can take a beat (spent on the beat)."""
        return not self._stalled() and self.ddr.available(self.beat_bytes)

    @staticmethod
    def _aborted_by_reset(chans: list[_Channel]) -> Gate:
        """A check that is True once any of the channels was reset after this call."""
        counts = [ch.resets for ch in chans]
        return lambda: any(ch.resets != n for ch, n in zip(chans, counts))

    async def _wait_armed(self, which: str) -> list[_Channel]:
        """Wait until every engine of the port has a pending transfer on this channel."""
        while True:
            chans = [getattr(e, which) for e in self.engines]
            waiting = [ch for ch in chans if not ch.pending]
            if not waiting:
                return chans
            waiting[0].wake.clear()
            await waiting[0].wake.wait()

    async def _run_mm2s(self) -> None:
        while True:
            chans = await self._wait_armed("mm2s")
            aborted = self._aborted_by_reset(chans)
            length = chans[0].length
            if any(ch.length != length for ch in chans) or length % self.lane_bytes:
                for ch in chans:
                    ch.complete(SR_INT_ERR)
                continue
            if self.preset.startup_cycles:
                await ClockCycles(self.clock, self.preset.startup_cycles)
            if aborted():
                continue
            lanes = [await self.memory.read(ch.addr, length) for ch in chans]
            if not await self._send(join_lanes(lanes, self.lane_bytes), aborted):
                continue
            self.transfers += 1
            for ch in chans:
                ch.complete()

    async def _run_s2mm(self) -> None:
        while True:
            chans = await self._wait_armed("s2mm")
            aborted = self._aborted_by_reset(chans)
            length = min(ch.length for ch in chans)
            max_beats = length // self.lane_bytes
            data, beats, ended = await self._receive(max_beats + 1, aborted)
            if aborted():
                continue
            lanes = split_lanes(data, len(chans), self.lane_bytes)
            overflow = beats > max_beats or not ended
            for ch, lane in zip(chans, lanes):
                lane = lane[:ch.length]
                await self.memory.write(ch.addr, lane)
                ch.length = len(lane)
                ch.complete(SR_INT_ERR if overflow else 0)
            self.transfers += 1


def _beats(data: bytes, beat_bytes: int) -> list[bytes]:
    return [data[i:i + beat_bytes] for i in range(0, len(data), beat_bytes)]


class BurstDmaStreamPort(DmaStreamPort):
    """A :class:`DmaStreamPort` on the transaction-level bench (``pgs_kernel_burst_tb.sv``): the same engines,
    registers and transfers, but the beats move a burst at a time through the bench's burst buffers
    (``tb.burst_streams``), paced by the bench's own DDR token bucket; no Python runs per beat or per cycle.
    A soft reset lets the bursts already handed to the bench finish, then ends the transfer."""

    def __init__(self, dut: Any, prefix: str, engines: list[AxiDmaEngine], memory: Region, preset: DmaPreset,
                 direction: str, burst: int):
        self.burst = burst
        super().__init__(dut, prefix, dut.ap_clk, engines, memory, preset, None, direction)

    def _attach(self, dut: Any, prefix: str, direction: str) -> None:
        if direction == "mm2s":
            self.burst_source = BurstSource(dut, prefix, self.beat_bytes, self.burst)
        else:
            self.burst_sink = BurstSink(dut, prefix, self.beat_bytes, self.burst)

    async def _send(self, data: bytes, aborted: Gate) -> bool:
        return await self.burst_source.send(data, aborted)

    async def _receive(self, max_beats: int, aborted: Gate) -> tuple[bytes, int, bool]:
        return await self.burst_sink.recv_packet(max_beats, aborted)
