"""Host side of a co-simulated step: DDR, AXI DMAs and the kernel's AXI4-Lite control, as a PYNQ driver does it.

:class:`KernelHost` owns the DDR model (cocotbext-axi ``SparseMemoryRegion``), the DMA engines
(``tb.axi_dma``) that feed ``s_axis_cons`` (the preset's channels), ``s_axis_body`` and drain ``m_axis_body``
(one 128-bit engine), and an ``AxiLiteMaster`` on ``s_axi_control``. :meth:`run_step` writes exactly the
packed streams of ``models/kernel/stream_format.py`` into DDR, arms S2MM, programs the kernel's arguments, starts it,
issues one MM2S transfer per pass on the constraint engines (each pass ends with TLAST), waits for ap_done
with a cycle timeout, and returns the body-out bytes read back from DDR with the kernel's status and counter
registers. :meth:`begin_step` / :meth:`finish_step` are its two halves (something can happen in between, e.g.
a reset: :meth:`reset` with ``dma=True`` also soft-resets the DMA engines, ending their transfers).

With ``transaction_level=True`` the host drives the transaction-level bench (``pgs_kernel_burst_tb.sv``) instead:
the same DDR, engines, registers and driver steps, with the DMA ports moving bursts (``BurstDmaStreamPort``), the
DDR bandwidth modeled by the bench, and the host waiting on interrupts (the DMA engines' completion, the kernel's
ap_done interrupt, enabled through GIE/IER) instead of polling registers every few cycles.
"""

from __future__ import annotations

import dataclasses
import random
from dataclasses import dataclass
from typing import Any

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, First, RisingEdge, Timer
from cocotbext.axi import AxiLiteBus, AxiLiteMaster, SparseMemoryRegion

from models.kernel import register_map as rm
from models.timing.platforms import DmaPreset
from models.formats.number_format import NumberFormat

from cocotb_tests.tb.axi_dma import AxiDmaEngine, BurstDmaStreamPort, DdrBandwidth, DmaStreamPort, split_lanes

# the kernel's registers (models/kernel/register_map.py)
AP_CTRL, GIE, IER, ISR = (rm.OFFSET[n] for n in ("ap_ctrl", "gie", "ier", "isr"))
ARGS = {name: rm.OFFSET[name] for name in rm.ARG_NAMES}
STATUS, CYCLES_LO, CYCLES_HI, STALLS, BUBBLES, ISSUED = (rm.OFFSET[n] for n in ("status", "cycles_lo", "cycles_hi",
                                                                                "stalls", "bubbles", "issued"))
REJECTED, FP_OVERFLOW, FP_UNDERFLOW, FP_INVALID, FP_STATUS = (
    rm.OFFSET[n] for n in ("rejected", "fp_overflow", "fp_underflow", "fp_invalid", "fp_status"))
DMACR_RUN, DMACR_RESET = 0x1001, 0x4  # RS | IOC_IrqEn; soft reset

BODY_IN_ADDR = 0x1000_0000
BODY_OUT_ADDR = 0x2000_0000
CONS_ADDR = 0x4000_0000
LANE_STRIDE = 0x0400_0000  # per constraint engine
POLL_CYCLES = 16
AP_DONE_IRQ = 1  # IER / ISR bit of ap_done
CLOCK_PERIOD_NS = 2


def _timeout(cycles: int) -> Timer:
    """A timeout of ``cycles`` clock periods as one timer (``ClockCycles`` would wake Python every cycle)."""
    return Timer(cycles * CLOCK_PERIOD_NS, unit="ns")


@dataclass
class StepResult:
    cycles: int  # the kernel's own cycle counter (ap_start to ap_done)
    wall_cycles: int  # testbench cycles from the ap_start write to seeing ap_done
    stalls: int
    bubbles: int
    issued: int
    status: int
    body_out: bytes
    bytes_in: int
    bytes_out: int
    rejected: int = 0
    fp_events: tuple[int, int, int] = (0, 0, 0)  # overflow, underflow, invalid
    fp_status: int = 0


class KernelHost:
    def __init__(self, dut: Any, preset: DmaPreset, seed: int, idle_prob: float = 0.0,
                 backpressure_prob: float = 0.0, body_bits: int = 128, transaction_level: bool = False,
                 burst: int = 16):
        self.dut = dut
        self.clock = dut.ap_clk
        self.transaction_level = transaction_level
        cocotb.start_soon(Clock(dut.ap_clk, CLOCK_PERIOD_NS, unit="ns").start())
        self.axil = AxiLiteMaster(AxiLiteBus.from_prefix(dut, "s_axi_control"), dut.ap_clk, dut.ap_rst_n,
                                  reset_active_level=False)
        self.memory = SparseMemoryRegion(size=1 << 32)
        self.preset = preset
        self.cons_engines = [AxiDmaEngine(f"dma_cons{e}", 1 << 32) for e in range(preset.channels)]
        self.body_engine = AxiDmaEngine("dma_body", 1 << 32)
        body_preset = dataclasses.replace(preset, channels=1, channel_bits=body_bits)
        if transaction_level:
            if idle_prob or backpressure_prob:
                raise ValueError("the transaction-level bench has no random idles or backpressure (the cycle-level "
                                 "benches test those)")
            rate = preset.ddr_bytes_per_cycle
            dut.ddr_unlimited.value = int(rate == float("inf"))
            dut.ddr_rate_q16.value = 0 if rate == float("inf") else int(rate * 65536)  # rounded down: never faster
            self.cons_port: DmaStreamPort = BurstDmaStreamPort(dut, "cons", self.cons_engines, self.memory, preset,
                                                               "mm2s", burst)
            self.body_in_port: DmaStreamPort = BurstDmaStreamPort(dut, "body_in", [self.body_engine], self.memory,
                                                                  body_preset, "mm2s", burst)
            self.body_out_port: DmaStreamPort = BurstDmaStreamPort(dut, "body_out", [self.body_engine], self.memory,
                                                                   body_preset, "s2mm", burst)
            return
        self.ddr = DdrBandwidth(dut.ap_clk, preset)
        rng = random.Random(seed)
        self.cons_port = DmaStreamPort(dut, "s_axis_cons", dut.ap_clk, self.cons_engines, self.memory, preset,
                                       self.ddr, "mm2s", random.Random(rng.random()), idle_prob)
        self.body_in_port = DmaStreamPort(dut, "s_axis_body", dut.ap_clk, [self.body_engine], self.memory,
                                          body_preset, self.ddr, "mm2s", random.Random(rng.random()), idle_prob)
        self.body_out_port = DmaStreamPort(dut, "m_axis_body", dut.ap_clk, [self.body_engine], self.memory,
                                           body_preset, self.ddr, "s2mm", random.Random(rng.random()),
                                           backpressure_prob)

    async def reset(self, dma: bool = False) -> None:
        """Reset the kernel (ap_rst_n low for 4 cycles) and start the DMA engines; with ``dma`` soft-reset the
        engines first (ending any transfer in progress)."""
        self.dut.ap_rst_n.value = 0
        await ClockCycles(self.clock, 4)
        self.dut.ap_rst_n.value = 1
        await ClockCycles(self.clock, 2)
        for eng in self.cons_engines + [self.body_engine]:
            if dma:
                await eng.write_dword(0x00, DMACR_RESET)
            await eng.write_dword(0x00, DMACR_RUN)
            await eng.write_dword(0x30, DMACR_RUN)

    async def read_reg(self, offset: int) -> int:
        return await self.axil.read_dword(offset)

    async def write_reg(self, offset: int, value: int) -> None:
        await self.axil.write_dword(offset, value & 0xFFFFFFFF)

    async def program(self, fmt: NumberFormat, num_bodies: int, num_manifolds: int, iterations: int, dt: float,
                      gravity: tuple[float, float, float], damping: float, options: int = 0) -> None:
        bits = lambda x: int(fmt.encode(float(x)))  # noqa: E731
        values = {"num_bodies": num_bodies, "num_manifolds": num_manifolds, "iterations": iterations,
                  "dt": bits(dt), "gravity_x": bits(gravity[0]), "gravity_y": bits(gravity[1]),
                  "gravity_z": bits(gravity[2]), "damping": bits(damping), "options": options}
        for name, value in values.items():
            await self.write_reg(ARGS[name], value)

    async def _mm2s(self, engines: list[AxiDmaEngine], lanes: list[bytes], addr: int) -> None:
        for e, (eng, lane) in enumerate(zip(engines, lanes)):
            await self.memory.write(addr + e * LANE_STRIDE, lane)
        for e, (eng, lane) in enumerate(zip(engines, lanes)):
            await eng.write_dword(0x18, addr + e * LANE_STRIDE)
            await eng.write_dword(0x28, len(lane))

    async def _wait_mm2s_idle(self, engines: list[AxiDmaEngine], timeout: int) -> None:
        if self.transaction_level:  # the engines' completion interrupt
            for eng in engines:
                while not eng.mm2s.dmasr & 0x2:
                    eng.mm2s.done.clear()
                    if isinstance(await First(eng.mm2s.done.wait(), _timeout(timeout)), Timer):
                        raise TimeoutError(f"MM2S transfer not finished after {timeout} cycles (kernel not "
                                           "consuming?)")
            return
        waited = 0
        while not all([bool(await eng.read_dword(0x04) & 0x2) for eng in engines]):
            await ClockCycles(self.clock, POLL_CYCLES)
            waited += POLL_CYCLES
            if waited > timeout:
                raise TimeoutError(f"MM2S transfer not finished after {timeout} cycles (kernel not consuming?)")

    async def _feed_constraints(self, passes: list[bytes], timeout: int) -> None:
        lane_bytes = self.preset.channel_bits // 8
        for data in passes:
            await self._mm2s(self.cons_engines, split_lanes(data, self.preset.channels, lane_bytes), CONS_ADDR)
            await self._wait_mm2s_idle(self.cons_engines, timeout)

    async def run_step(self, body_in: bytes, passes: list[bytes], body_out_bytes: int,
                       timeout_cycles: int) -> StepResult:
        """One kernel run; raises TimeoutError (a hang is a failure, never a stuck test) past the timeout.
        ``body_out_bytes`` = 0: no body-out transfer is armed or awaited."""
        feeder = await self.begin_step(body_in, passes, body_out_bytes, timeout_cycles)
        return await self.finish_step(feeder, body_in, passes, body_out_bytes, timeout_cycles)

    async def begin_step(self, body_in: bytes, passes: list[bytes], body_out_bytes: int, timeout_cycles: int) -> Any:
        """Arm body-out, start body-in, start the kernel and the constraint feeder (returned)."""
        if body_out_bytes:
            await self.body_engine.write_dword(0x48, BODY_OUT_ADDR)
            await self.body_engine.write_dword(0x58, body_out_bytes)
        await self._mm2s([self.body_engine], [body_in], BODY_IN_ADDR)
        feeder = cocotb.start_soon(self._feed_constraints(passes, timeout_cycles))
        if self.transaction_level:  # wait on the ap_done interrupt instead of polling AP_CTRL
            await self.write_reg(GIE, 1)
            await self.write_reg(IER, AP_DONE_IRQ)
        await self.write_reg(AP_CTRL, rm.AP_START)
        return feeder

    async def finish_step(self, feeder: Any, body_in: bytes, passes: list[bytes], body_out_bytes: int,
                          timeout_cycles: int) -> StepResult:
        """Wait for ap_done (and the body-out transfer), then read the registers."""
        waited = 0
        if self.transaction_level and not int(self.dut.interrupt.value):
            t0 = self.dut.tb_cycle.value.to_unsigned()
            await First(RisingEdge(self.dut.interrupt), _timeout(timeout_cycles))
            waited = self.dut.tb_cycle.value.to_unsigned() - t0
        if self.transaction_level and int(self.dut.interrupt.value):
            await self.write_reg(ISR, AP_DONE_IRQ)  # toggle-on-write: clears the ap_done interrupt
        while True:
            ctrl = await self.read_reg(AP_CTRL)
            if ctrl & rm.AP_DONE:  # clear on read: seen once
                break
            await ClockCycles(self.clock, POLL_CYCLES)
            waited += POLL_CYCLES
            if waited > timeout_cycles:
                feeder.cancel()
                status = await self.read_reg(STATUS)
                raise TimeoutError(f"kernel did not assert ap_done within {timeout_cycles} cycles "
                                   f"(AP_CTRL={ctrl:#x}, status={status:#x}, issued={await self.read_reg(ISSUED)})")
        s2mm_wait = 0
        while body_out_bytes and not (await self.body_engine.read_dword(0x34) & 0x2):
            await RisingEdge(self.clock)
            s2mm_wait += 1
            if s2mm_wait > timeout_cycles:
                raise TimeoutError("body-out S2MM transfer did not complete after ap_done")
        if not feeder.done():
            feeder.cancel()
        cycles = await self.read_reg(CYCLES_LO) | (await self.read_reg(CYCLES_HI) << 32)
        out_len = await self.body_engine.read_dword(0x58) if body_out_bytes else 0
        body_out = await self.memory.read(BODY_OUT_ADDR, out_len) if out_len else b""
        events = (await self.read_reg(FP_OVERFLOW), await self.read_reg(FP_UNDERFLOW), await self.read_reg(FP_INVALID))
        return StepResult(cycles=cycles, wall_cycles=waited, stalls=await self.read_reg(STALLS),
                          bubbles=await self.read_reg(BUBBLES), issued=await self.read_reg(ISSUED),
                          status=await self.read_reg(STATUS), body_out=bytes(body_out),
                          bytes_in=len(body_in) + sum(len(p) for p in passes), bytes_out=out_len,
                          rejected=await self.read_reg(REJECTED), fp_events=events,
                          fp_status=await self.read_reg(FP_STATUS))
