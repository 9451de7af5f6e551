"""The AXI DMA model (PG021 register map, modeled bandwidth) around an AXI4-Stream loopback.

cocotb coroutines are ``run_*``; the pytest entry point is ``test_axi_dma`` (one Verilator build per stream
width). Reproduce a failure with ``SEED=<n> .venv/bin/python -m pytest cocotb_tests/test_axi_dma.py``.
"""

from __future__ import annotations

import os
import random
from pathlib import Path

import cocotb
import pytest
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, RisingEdge
from cocotbext.axi import SparseMemoryRegion

from models.timing.platforms import DmaPreset, get_preset

THIS = Path(__file__).resolve().parent
GUARD = b"\xaa" * 64


class LoopbackTb:
    def __init__(self, dut, preset: DmaPreset, seed: int, idle_prob: float):
        from tb.axi_dma import AxiDmaEngine, DdrBandwidth, DmaStreamPort

        self.dut = dut
        self.preset = preset
        self.memory = SparseMemoryRegion(size=1 << 32)
        self.engines = [AxiDmaEngine(f"dma{e}", memory_size=1 << 32) for e in range(preset.channels)]
        cocotb.start_soon(Clock(dut.ap_clk, 2, unit="ns").start())
        self.ddr = DdrBandwidth(dut.ap_clk, preset)
        rng = random.Random(seed)
        self.mm2s = DmaStreamPort(dut, "s_axis", dut.ap_clk, self.engines, self.memory, preset, self.ddr, "mm2s",
                                  random.Random(rng.random()), idle_prob)
        self.s2mm = DmaStreamPort(dut, "m_axis", dut.ap_clk, self.engines, self.memory, preset, self.ddr, "s2mm",
                                  random.Random(rng.random()), idle_prob)

    async def reset(self) -> None:
        self.dut.ap_rst_n.value = 0
        await ClockCycles(self.dut.ap_clk, 3)
        self.dut.ap_rst_n.value = 1
        await RisingEdge(self.dut.ap_clk)

    async def start_channels(self, after_reset: bool = True) -> None:
        for eng in self.engines:
            for base in (0x00, 0x30):
                if after_reset:
                    assert await eng.read_dword(base + 0x04) & 1, "DMASR.Halted must be set after reset"
                await eng.write_dword(base, 0x1001)  # RS | IOC_IrqEn
                assert not (await eng.read_dword(base + 0x04) & 1), "RS=1 must clear Halted"

    async def transfer(self, data: bytes, src: int, dst: int, room: int) -> tuple[int, list[bytes]]:
        """Loop ``data`` through the DUT: lanes to src, results to dst; returns (cycles, received lanes)."""
        from tb.axi_dma import split_lanes

        lane_bytes = self.preset.channel_bits // 8
        lanes = split_lanes(data, self.preset.channels, lane_bytes)
        stride = len(lanes[0]) + 4096
        for e, lane in enumerate(lanes):
            await self.memory.write(src + e * stride, lane)
            await self.memory.write(dst + e * (room + 4096) - len(GUARD), GUARD + b"\x00" * room + GUARD)
        for e, eng in enumerate(self.engines):  # S2MM first (armed), then MM2S: PYNQ's order
            await eng.write_dword(0x48, dst + e * (room + 4096))
            await eng.write_dword(0x58, room)
        for e, eng in enumerate(self.engines):
            await eng.write_dword(0x18, src + e * stride)
            await eng.write_dword(0x28, len(lanes[e]))
        cycles = 0
        while not all([bool(await eng.read_dword(0x34) & 0x2) for eng in self.engines]):
            await RisingEdge(self.dut.ap_clk)
            cycles += 1
            assert cycles < 200_000, "DMA transfer did not complete (hang)"
        got = [await self.memory.read(dst + e * (room + 4096), room) for e in range(self.preset.channels)]
        return cycles, got


@cocotb.test()
async def run_stream_through(dut) -> None:
    """Random data through MM2S -> loopback -> S2MM, with the preset's bandwidth and random stalls."""
    preset = get_preset(os.environ["DMA_PRESET"])
    seed = int(os.environ["TB_SEED"])
    idle = float(os.environ.get("TB_IDLE", "0"))
    tb = LoopbackTb(dut, preset, seed, idle)
    await tb.reset()
    await tb.start_channels()
    rng = random.Random(seed)
    beat = preset.stream_bits // 8
    nbeats = 400
    data = bytes(rng.getrandbits(8) for _ in range(beat * nbeats))
    lane = preset.channel_bits // 8
    cycles, got = await tb.transfer(data, src=0x1000_0000, dst=0x2000_0000, room=lane * nbeats)
    from tb.axi_dma import join_lanes

    assert join_lanes(got, lane) == data, "data looped through the DMA model differ"
    for e in range(preset.channels):
        base = 0x2000_0000 + e * (lane * nbeats + 4096)
        assert await tb.memory.read(base - len(GUARD), len(GUARD)) == GUARD, "S2MM wrote before its buffer"
        assert await tb.memory.read(base + lane * nbeats, len(GUARD)) == GUARD, "S2MM wrote past its buffer"
        sr = await tb.engines[e].read_dword(0x34)
        assert sr & 0x1000 and not sr & 0x70, f"S2MM status {sr:#x}: expected IOC and no error"
        assert await tb.engines[e].read_dword(0x58) == lane * nbeats, "S2MM_LENGTH must hold the bytes written"
        await tb.engines[e].write_dword(0x34, 0x1000)
        assert not (await tb.engines[e].read_dword(0x34) & 0x1000), "IOC_Irq is write-1-to-clear"
    # reads and writes share the DDR: the floor is (bytes in + bytes out) / DDR bytes per cycle
    floor = 2 * len(data) / min(preset.ddr_bytes_per_cycle, 2 * preset.port_bytes_per_cycle)
    floor = max(floor, nbeats)
    dut._log.info("%s: %d bytes each way in %d cycles; floor %.0f cycles (%.1f%%), DDR bytes %d", preset.name,
                  len(data), cycles, floor, 100 * floor / cycles, tb.ddr.bytes_moved)
    assert cycles >= floor
    if idle == 0:
        assert cycles <= 1.05 * floor + preset.startup_cycles + 20


@cocotb.test()
async def run_register_errors(dut) -> None:
    """PG021 behaviour: LENGTH ignored while halted, decode error, overflow of the S2MM buffer, soft reset."""
    preset = get_preset(os.environ["DMA_PRESET"])
    tb = LoopbackTb(dut, preset, 1, 0.0)
    await tb.reset()
    eng = tb.engines[0]
    await eng.write_dword(0x28, 64)  # halted: LENGTH does not start a transfer
    assert await eng.read_dword(0x04) == 0x1
    await tb.start_channels()
    await eng.write_dword(0x18, (1 << 32) - 16)
    await eng.write_dword(0x28, 64)  # beyond the memory: decode error, halted
    sr = await eng.read_dword(0x04)
    assert sr & 0x40 and sr & 0x4000 and sr & 0x1, f"expected DMADecErr, Err_Irq and Halted, got {sr:#x}"
    await eng.write_dword(0x00, 0x4)  # soft reset
    assert await eng.read_dword(0x04) == 0x1 and await eng.read_dword(0x00) == 0x2
    # S2MM buffer smaller than the packet: DMAIntErr, Halted
    await tb.start_channels(after_reset=False)
    lane = preset.channel_bits // 8
    data = bytes(range(256)) * (preset.stream_bits // 8 * 8 // 256 + 1)
    data = data[:preset.stream_bits // 8 * 8]
    from tb.axi_dma import split_lanes

    lanes = split_lanes(data, preset.channels, lane)
    for e, engine in enumerate(tb.engines):
        await tb.memory.write(0x100_0000 + e * 0x10000, lanes[e])
        await engine.write_dword(0x48, 0x200_0000 + e * 0x10000)
        await engine.write_dword(0x58, lane * 4)  # room for 4 of 8 beats
    for e, engine in enumerate(tb.engines):
        await engine.write_dword(0x18, 0x100_0000 + e * 0x10000)
        await engine.write_dword(0x28, len(lanes[e]))
    for _ in range(2000):
        await RisingEdge(dut.ap_clk)
        if await eng.read_dword(0x34) & 0x10:
            break
    sr = await eng.read_dword(0x34)
    assert sr & 0x10 and sr & 0x1, f"expected DMAIntErr and Halted on S2MM overflow, got {sr:#x}"


@pytest.mark.parametrize("preset_name,idle", [("zcu102", 0.0), ("zcu102", 0.3), ("zcu102_1", 0.0), ("ideal", 0.0)])
def test_axi_dma(preset_name: str, idle: float) -> None:
    from sim.drive.cocotb_run import cocotb_results, run_cocotb, test_seed

    preset = get_preset(preset_name)
    seed = test_seed()
    results = run_cocotb("axis_loopback", [THIS / "dma" / "axis_loopback.sv"], "test_axi_dma",
               parameters={"W": preset.stream_bits}, seed=seed,
               extra_env={"DMA_PRESET": preset_name, "TB_SEED": str(seed), "TB_IDLE": str(idle)})
    assert cocotb_results(results) == (2, 0)  # run_stream_through and run_register_errors, both passed
