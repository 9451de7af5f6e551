"""cocotb test of rtl/pgs_control_s_axi.sv (the kernel's AXI4-Lite register file), Verilator.

pytest entry point :func:`test_pgs_control_s_axi` builds the register file with cocotb_tools.runner
(one build directory) and runs the cocotb test below, which drives the AXI4-Lite slave with
cocotbext-axi's AxiLiteMaster and plays the kernel side (ap_done/ap_idle/ap_ready pulses, error
flags, counters) itself. Checked: reset values of every register, R/W of the argument registers (with
byte strobes), ap_start set / clear-on-handshake / auto_restart, ap_done and ap_ready clear-on-read,
ap_idle, ISR toggle-on-write, interrupt = GIE && |ISR, status W1C with the first error code (codes 1..8 in
bits 7:0, 9.. in bits 31:24), read-only counters (cycles, stalls, bubbles, issued, rejected, floating-point
events), fp_status W1C, reserved argument words reading 0 with OKAY, unmapped addresses reading 0 with
SLVERR and raising error code 9, ap_start written while busy raising error code 8.
"""

from __future__ import annotations

import os
from pathlib import Path

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ClockCycles, RisingEdge

from models.kernel import register_map as rm

REPO = Path(__file__).resolve().parents[1]

ARGS = {name: rm.OFFSET[name] for name in rm.ARG_NAMES}
AP_CTRL, GIE, IER, ISR = (rm.OFFSET[n] for n in ("ap_ctrl", "gie", "ier", "isr"))
STATUS, CYC_LO, CYC_HI, STALL, BUBBLE, ISSUED = (rm.OFFSET[n] for n in ("status", "cycles_lo", "cycles_hi", "stalls",
                                                                        "bubbles", "issued"))
REJECTED, FP_OVF, FP_UNF, FP_INV, FP_STATUS = (rm.OFFSET[n] for n in ("rejected", "fp_overflow", "fp_underflow",
                                                                      "fp_invalid", "fp_status"))
RESERVED = [addr + 4 for addr in ARGS.values()]  # the upper words of the 8-byte argument slots
UNMAPPED, UNMAPPED_WRITE = (0x5C, 0x6C, 0x74, 0xB0, 0xB4, 0xFC), 0xF0  # addresses of no register
OKAY, SLVERR = 0, 2
ERR = rm.ErrorCode


def status_word(first: int, *codes: int) -> int:
    """The status register with the flags of ``codes`` set and ``first`` as the first error's code."""
    return sum(rm.status_flag(c) for c in codes) | first << 8


# The kernel-side inputs of the register file before a test drives them: idle, no errors, distinct counter values.
_INPUTS_AT_SETUP: dict[str, int] = {
    "ap_done": 0, "ap_ready": 0, "ap_idle": 1, "err_set": 0, "err_code": 0, "fp_set": 0,
    "stat_cycles": 0x1122334455667788, "stat_stalls": 0xA5A5, "stat_bubbles": 0x5A5A, "stat_issued": 1234,
    "stat_rejected": 77, "stat_fp_overflow": 0x10001, "stat_fp_underflow": 0x20002, "stat_fp_invalid": 0x30003,
}


async def _setup(dut):
    from cocotbext.axi import AxiLiteBus, AxiLiteMaster

    cocotb.start_soon(Clock(dut.ap_clk, 10, unit="ns").start())
    for name, value in _INPUTS_AT_SETUP.items():
        getattr(dut, name).value = value
    master = AxiLiteMaster(AxiLiteBus.from_prefix(dut, "s_axi_control"), dut.ap_clk, dut.ap_rst_n,
                           reset_active_level=False)
    dut.ap_rst_n.value = 0
    await ClockCycles(dut.ap_clk, 5)
    dut.ap_rst_n.value = 1
    await ClockCycles(dut.ap_clk, 2)
    return master


async def rd(master, addr: int, resp_code: int = OKAY) -> int:
    resp = await master.read(addr, 4)
    assert int(resp.resp) == resp_code, f"read 0x{addr:02x}: resp {resp.resp}, expected {resp_code}"
    return int.from_bytes(resp.data, "little")


async def wr(master, addr: int, value: int, strb: int | None = None, resp_code: int = OKAY) -> None:
    data = value.to_bytes(4, "little")
    if strb is None:
        resp = await master.write(addr, data)
    else:
        # byte-lane write: only the strobed bytes
        lanes = [i for i in range(4) if strb >> i & 1]
        lo, hi = min(lanes), max(lanes)
        resp = await master.write(addr + lo, data[lo:hi + 1])
    assert int(resp.resp) == resp_code, f"write 0x{addr:02x}: resp {resp.resp}, expected {resp_code}"


async def pulse(dut, *names: str) -> None:
    await RisingEdge(dut.ap_clk)
    for n in names:
        getattr(dut, n).value = 1
    await RisingEdge(dut.ap_clk)
    for n in names:
        getattr(dut, n).value = 0


@cocotb.test()
async def register_file(dut) -> None:
    m = await _setup(dut)
    # reset values
    assert not {*UNMAPPED, UNMAPPED_WRITE} & (set(rm.OFFSET.values()) | set(RESERVED))
    assert await rd(m, AP_CTRL) == rm.AP_IDLE  # ap_idle only
    for addr in (GIE, IER, ISR, STATUS, FP_STATUS):
        assert await rd(m, addr) == 0, f"0x{addr:02x} not 0 after reset"
    for name, addr in ARGS.items():
        assert await rd(m, addr) == 0, f"{name} not 0 after reset"
    assert dut.interrupt.value == 0 and dut.ap_start.value == 0
    # read-only counters
    assert await rd(m, CYC_LO) == 0x55667788 and await rd(m, CYC_HI) == 0x11223344
    assert await rd(m, STALL) == 0xA5A5 and await rd(m, BUBBLE) == 0x5A5A and await rd(m, ISSUED) == 1234
    assert await rd(m, REJECTED) == 77
    assert [await rd(m, a) for a in (FP_OVF, FP_UNF, FP_INV)] == [0x10001, 0x20002, 0x30003]
    await wr(m, CYC_LO, 0xFFFFFFFF)
    assert await rd(m, CYC_LO) == 0x55667788
    await wr(m, FP_INV, 0)
    assert await rd(m, FP_INV) == 0x30003
    # every bit of every counter read path and argument register both ways: all ones, then all zeros
    counters = {"stat_cycles": ((CYC_LO, CYC_HI), 64), "stat_stalls": ((STALL,), 32), "stat_bubbles": ((BUBBLE,), 32),
                "stat_issued": ((ISSUED,), 32), "stat_rejected": ((REJECTED,), 32),
                "stat_fp_overflow": ((FP_OVF,), 32), "stat_fp_underflow": ((FP_UNF,), 32),
                "stat_fp_invalid": ((FP_INV,), 32)}
    for fill in (0xFFFFFFFF, 0):
        for name, (addrs, bits) in counters.items():
            saved = int(getattr(dut, name).value)
            getattr(dut, name).value = (1 << bits) - 1 if fill else 0
            await RisingEdge(dut.ap_clk)
            assert [await rd(m, a) for a in addrs] == [fill] * len(addrs), name
            getattr(dut, name).value = saved
        for name, addr in ARGS.items():
            await wr(m, addr, fill)
            assert await rd(m, addr) == fill and int(getattr(dut, name).value) == fill, name
    # argument registers: R/W, byte strobes, output ports
    for i, (name, addr) in enumerate(ARGS.items()):
        await wr(m, addr, 0x01020304 * (i + 1) & 0xFFFFFFFF)
    for i, (name, addr) in enumerate(ARGS.items()):
        v = 0x01020304 * (i + 1) & 0xFFFFFFFF
        assert await rd(m, addr) == v, name
        assert int(getattr(dut, name).value) == v, name
    await wr(m, ARGS["dt"], 0xAABBCCDD, strb=0b0100)
    assert await rd(m, ARGS["dt"]) == (0x01020304 * 4 & 0xFF00FFFF) | 0x00BB0000
    # reserved upper words of the argument slots read 0, ignore writes, answer OKAY, raise nothing
    assert RESERVED == [*range(0x14, 0x58, 8), 0x94, 0x9C, 0xA4, 0xAC]
    for addr in RESERVED:
        assert await rd(m, addr) == 0, f"0x{addr:02x}"
    await wr(m, RESERVED[0], 0xFFFFFFFF)
    assert await rd(m, RESERVED[0]) == 0
    assert await rd(m, STATUS) == 0
    # unmapped addresses read 0 with SLVERR, ignore writes (SLVERR) and raise error code 9 (status bit 24)
    assert status_word(ERR.UNMAPPED, ERR.UNMAPPED) == 0x0100_0900
    for addr in UNMAPPED:
        assert await rd(m, addr, resp_code=SLVERR) == 0, f"0x{addr:02x}"
    assert await rd(m, STATUS) == status_word(ERR.UNMAPPED, ERR.UNMAPPED)
    await wr(m, STATUS, rm.status_flag(ERR.UNMAPPED))
    assert await rd(m, STATUS) == 0
    await wr(m, UNMAPPED_WRITE, 0x1234, resp_code=SLVERR)
    assert await rd(m, UNMAPPED_WRITE, resp_code=SLVERR) == 0
    assert await rd(m, STATUS) == status_word(ERR.UNMAPPED, ERR.UNMAPPED)
    await wr(m, STATUS, 0x0000_00FF)  # clears flags 7:0 only: bit 24 stays
    assert await rd(m, STATUS) == status_word(ERR.UNMAPPED, ERR.UNMAPPED)
    await wr(m, STATUS, 0xFF00_0000)
    assert await rd(m, STATUS) == 0

    # ap_start: set by writing 1, stays until ap_ready, cleared then (no auto_restart)
    handshake = rm.AP_START | rm.AP_DONE | rm.AP_IDLE | rm.AP_READY
    assert (rm.AP_START, rm.AP_DONE, rm.AP_IDLE, rm.AP_READY, rm.AUTO_RESTART, rm.AP_INTERRUPT) == \
        (0x1, 0x2, 0x4, 0x8, 0x80, 0x200)  # the Vitis HLS ap_ctrl_hs layout
    await wr(m, AP_CTRL, 0x0)
    assert dut.ap_start.value == 0
    await wr(m, AP_CTRL, rm.AP_START)
    assert dut.ap_start.value == 1 and (await rd(m, AP_CTRL)) & rm.AP_START
    dut.ap_idle.value = 0
    await ClockCycles(dut.ap_clk, 3)
    assert (await rd(m, AP_CTRL)) & (rm.AP_START | rm.AP_IDLE) == rm.AP_START  # started, not idle
    # writing ap_start again while busy changes nothing but raises error code 8 (status bit 7)
    await wr(m, AP_CTRL, rm.AP_START)
    assert status_word(ERR.START_WHILE_BUSY, ERR.START_WHILE_BUSY) == 0x0880
    assert (await rd(m, AP_CTRL)) & (rm.AP_START | rm.AP_IDLE) == rm.AP_START
    assert await rd(m, STATUS) == status_word(ERR.START_WHILE_BUSY, ERR.START_WHILE_BUSY)
    await wr(m, STATUS, rm.status_flag(ERR.START_WHILE_BUSY))
    assert await rd(m, STATUS) == 0
    await pulse(dut, "ap_done", "ap_ready")
    dut.ap_idle.value = 1
    await RisingEdge(dut.ap_clk)
    assert dut.ap_start.value == 0
    v = await rd(m, AP_CTRL)
    assert v & handshake == rm.AP_DONE | rm.AP_IDLE | rm.AP_READY, hex(v)  # start cleared
    v = await rd(m, AP_CTRL)
    assert v & handshake == rm.AP_IDLE, hex(v)  # done and ready cleared on read
    # auto_restart keeps ap_start
    await wr(m, AP_CTRL, rm.AUTO_RESTART | rm.AP_START)
    assert (await rd(m, AP_CTRL)) & (rm.AUTO_RESTART | rm.AP_START) == rm.AUTO_RESTART | rm.AP_START
    await pulse(dut, "ap_done", "ap_ready")
    await RisingEdge(dut.ap_clk)
    assert dut.ap_start.value == 1
    await wr(m, AP_CTRL, 0x00)  # clear auto_restart (ap_start stays until the next handshake)
    await pulse(dut, "ap_ready")
    await RisingEdge(dut.ap_clk)
    assert dut.ap_start.value == 0
    await rd(m, AP_CTRL)

    # interrupts: IER gates ISR; GIE gates the output; ISR toggles on write
    await pulse(dut, "ap_done")
    assert await rd(m, ISR) == 0 and dut.interrupt.value == 0
    await wr(m, IER, 0x3)
    assert await rd(m, IER) == 0x3
    await pulse(dut, "ap_done")
    await RisingEdge(dut.ap_clk)
    assert await rd(m, ISR) == 0x1
    assert dut.interrupt.value == 0  # GIE off
    await wr(m, GIE, 0x1)
    assert await rd(m, GIE) == 1
    await RisingEdge(dut.ap_clk)
    assert dut.interrupt.value == 1
    assert (await rd(m, AP_CTRL)) & rm.AP_INTERRUPT  # interrupt mirrored in AP_CTRL bit 9
    await pulse(dut, "ap_ready")
    await RisingEdge(dut.ap_clk)
    assert await rd(m, ISR) == 0x3
    await wr(m, ISR, 0x1)  # toggle bit 0 off
    assert await rd(m, ISR) == 0x2 and dut.interrupt.value == 1
    await wr(m, ISR, 0x2)
    await RisingEdge(dut.ap_clk)
    assert await rd(m, ISR) == 0x0 and dut.interrupt.value == 0
    await wr(m, ISR, 0x1)  # toggle on write also sets
    assert await rd(m, ISR) == 0x1
    await wr(m, ISR, 0x1)
    await wr(m, GIE, 0x0)

    # status: sticky flags, first error code, write 1 to clear
    dut.err_code.value = 7
    await pulse(dut, "err_set")  # sets flag bit 0 (err_set = 1)
    dut.err_code.value = 9
    dut.err_set.value = 0x4
    await RisingEdge(dut.ap_clk)
    dut.err_set.value = 0
    assert status_word(7, 1, 3) == 0x0705
    assert await rd(m, STATUS) == status_word(7, 1, 3)  # flags 0b101, code of the first error
    await wr(m, STATUS, rm.status_flag(1))
    assert await rd(m, STATUS) == status_word(7, 3)
    await wr(m, STATUS, rm.status_flag(3))
    assert await rd(m, STATUS) == 0
    dut.err_code.value = 3
    dut.err_set.value = 0x2
    await RisingEdge(dut.ap_clk)
    dut.err_set.value = 0
    assert await rd(m, STATUS) == status_word(3, 2)
    await wr(m, STATUS, 0xFF)
    assert await rd(m, STATUS) == 0

    # fp_status: sticky event flags (fp_set pulses), write 1 to clear; not errors (status stays 0)
    dut.fp_set.value = 0b101
    await RisingEdge(dut.ap_clk)
    dut.fp_set.value = 0b010
    await RisingEdge(dut.ap_clk)
    dut.fp_set.value = 0
    fp_flags = rm.FP_OVERFLOW_FLAG | rm.FP_UNDERFLOW_FLAG | rm.FP_INVALID_FLAG
    assert await rd(m, FP_STATUS) == fp_flags == 0b111 and await rd(m, STATUS) == 0
    await wr(m, FP_STATUS, rm.FP_OVERFLOW_FLAG)
    assert await rd(m, FP_STATUS) == rm.FP_UNDERFLOW_FLAG | rm.FP_INVALID_FLAG
    await wr(m, FP_STATUS, rm.FP_UNDERFLOW_FLAG | rm.FP_INVALID_FLAG)
    assert await rd(m, FP_STATUS) == 0


def test_pgs_control_s_axi() -> None:
    from cocotb_tools.runner import get_runner

    from sim.compile.verilator_build import ensure_verilator_env
    from sim.drive.cocotb_run import cocotb_results

    ensure_verilator_env()
    runner = get_runner("verilator")
    build_dir = REPO / "build" / "cocotb" / "pgs_control_s_axi"
    runner.build(sources=[REPO / "rtl" / "generated" / "pgs_regs_pkg.sv", REPO / "rtl" / "pgs_control_s_axi.sv"],
                 hdl_toplevel="pgs_control_s_axi",
                 build_dir=build_dir, always=False,
                 build_args=["-MAKEFLAGS", "CFG_CXXFLAGS_PCH_I=-include CFG_LDLIBS_THREADS=-pthread",
                             "-Wno-fatal"])
    results = runner.test(hdl_toplevel="pgs_control_s_axi", test_module="test_pgs_control_s_axi",
                hdl_toplevel_lang="verilog", build_dir=build_dir, test_dir=Path(__file__).parent,
                extra_env={"PYTHONPATH": os.pathsep.join([str(REPO), str(Path(__file__).parent)])})
    assert cocotb_results(Path(results)) == (1, 0)  # register_file ran and passed
