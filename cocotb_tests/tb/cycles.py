"""A cycle-by-cycle driver for the benches of small modules (the sequencer's modules): each cycle the bench sets the
inputs of that cycle right after the rising edge, then reads the settled outputs (what the module decides in that
cycle, from its state and those inputs) before the next edge."""

from __future__ import annotations

from typing import Any

import cocotb
from cocotb.clock import Clock
from cocotb.triggers import ReadOnly, RisingEdge, Timer


async def start(dut: Any, inputs: dict[str, int], reset_cycles: int = 3) -> None:
    """Start the clock on ``dut.clk``, hold ``dut.rst`` (where the module has one) for ``reset_cycles`` cycles with
    ``inputs`` applied, release it."""
    cocotb.start_soon(Clock(dut.clk, 10, unit="ns").start())
    has_rst = hasattr(dut, "rst")
    if has_rst:
        dut.rst.value = 1
    for name, value in inputs.items():
        getattr(dut, name).value = value
    for _ in range(reset_cycles):
        await RisingEdge(dut.clk)
    if has_rst:
        dut.rst.value = 0


async def cycle(dut: Any, **inputs: int) -> None:
    """Wait for the next rising edge, apply ``inputs`` for the cycle that starts there, and return once the
    combinational outputs of that cycle have settled (read them now; drive nothing until the next call)."""
    await RisingEdge(dut.clk)
    for name, value in inputs.items():
        getattr(dut, name).value = value
    await ReadOnly()


async def respond(dut: Any, **inputs: int) -> None:
    """Within the same cycle, after reading its outputs: apply ``inputs`` that answer them (what a parent module
    derives combinationally from those outputs, e.g. an issue from a may-issue), and let the outputs settle again."""
    await Timer(1, unit="ns")
    for name, value in inputs.items():
        getattr(dut, name).value = value
    await ReadOnly()


def val(signal: Any) -> int:
    """A signal's value as an int."""
    return int(signal.value)
