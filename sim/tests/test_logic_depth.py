"""The timing estimate's walk over a synthesized netlist (sim/fit/logic_depth.py) on small hand-written Yosys JSON
netlists: LUT levels and their delay between flip-flops, carry chains counted as CARRY8s, a submodule inlined, black
boxes and ports as boundaries, a combinational DSP48E2, the kernel's argument registers kept apart, delay-line taps in
block RAM; and the delay figures' budget (sim/fit/delays.py)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from sim.fit import delays
from sim.fit import logic_depth as ld

F = delays.FIGURES


class Net:
    """Builds one module's cells and nets for Yosys's JSON format."""

    def __init__(self, ports: dict[str, tuple[str, int]]) -> None:
        self.bit = 2
        self.ports = {n: {"direction": d, "bits": self.bits(w)} for n, (d, w) in ports.items()}
        self.cells: dict[str, Any] = {}
        self.names: dict[str, Any] = {}

    def bits(self, n: int = 1) -> list[int]:
        out = list(range(self.bit, self.bit + n))
        self.bit += n
        return out

    def cell(self, name: str, ctype: str, ins: dict[str, list[Any]], outs: dict[str, list[Any]],
             params: dict[str, str] | None = None) -> None:
        self.cells[name] = {"type": ctype, "parameters": params or {},
                            "port_directions": {**{p: "input" for p in ins}, **{p: "output" for p in outs}},
                            "connections": {**ins, **outs}}

    def ff(self, name: str, d: int) -> int:
        q = self.bits()[0]
        self.cell(f"{name}_reg", "FDRE", {"C": [self.ports["clk"]["bits"][0]], "CE": ["1"], "R": ["0"], "D": [d]},
                  {"Q": [q]})
        self.names[name] = {"hide_name": 0, "bits": [q]}
        return q

    def lut(self, name: str, *ins: int) -> int:
        o = self.bits()[0]
        self.cell(name, f"LUT{len(ins)}", {f"I{i}": [b] for i, b in enumerate(ins)}, {"O": [o]})
        return o

    def module(self, top: bool = True) -> dict[str, Any]:
        return {"attributes": {"top": "00000000000000000000000000000001"} if top else {}, "ports": self.ports,
                "cells": self.cells, "netnames": self.names}


def write(tmp_path: Path, modules: dict[str, Any]) -> Path:
    path = tmp_path / "netlist.json"
    path.write_text(json.dumps({"modules": modules}))
    return path


def chain(n: int) -> Net:
    """clk, d -> a (FF) -> n LUTs -> b (FF) -> q"""
    m = Net({"clk": ("input", 1), "d": ("input", 1), "q": ("output", 1)})
    x = m.ff("a", m.ports["d"]["bits"][0])
    for i in range(n):
        x = m.lut(f"l{i}", x)
    b = m.ff("b", x)
    m.cell("buf", "LUT1", {"I0": [b]}, {"O": m.ports["q"]["bits"]})
    return m


def test_lut_levels_and_delay(tmp_path: Path) -> None:
    a = ld.analyze(ld.load(write(tmp_path, {"top": chain(3).module()})))
    worst = a.worst[0]
    assert (worst.start, worst.end, worst.luts, worst.levels) == ("a", "b", 3, 3)
    # each net here has one load
    expect = F.ff_clock_to_q + 3 * (F.net(1) + F.lut) + F.net(1) + F.ff_setup
    assert worst.delay_ns == pytest.approx(expect) and worst.cells == ["LUT1"] * 3
    assert a.histogram == {3: 1}  # b (3 LUTs from a); a is reached from the input port only
    assert a.inputs["d"].end == "a" and a.inputs["d"].levels == 0
    assert a.outputs["q"].start == "b" and a.outputs["q"].luts == 1


def test_fanout_slows_a_net_up_to_the_cap() -> None:
    assert F.net(10) - F.net(1) == pytest.approx(9 * F.net_per_load)
    assert F.net(10_000) == F.net(delays.FANOUT_CAP)


def test_carry_chain_counts_carry8(tmp_path: Path) -> None:
    m = Net({"clk": ("input", 1), "d": ("input", 1)})
    x = m.lut("l0", m.ff("a", m.ports["d"]["bits"][0]))
    co = []
    ci: list[Any] = ["0"]
    for k in range(3):  # three CARRY4 in a chain: entered at S, then two CI hops (half a CARRY8 each)
        o, c = m.bits(4), m.bits(4)
        s_in = [x] + ["0"] * 3 if k == 0 else ["1"] * 4
        m.cell(f"c{k}", "CARRY4", {"CI": ci, "CYINIT": ["0"], "DI": ["0"] * 4, "S": s_in}, {"O": o, "CO": c})
        ci, co = [c[3]], c
    m.ff("b", co[3])
    worst = ld.analyze(ld.load(write(tmp_path, {"top": m.module()}))).worst[0]
    assert (worst.luts, math.ceil(worst.carry8), worst.levels) == (1, 2, 3)
    assert worst.cells == ["LUT1", "CARRY4", "CARRY4", "CARRY4"]
    expect = (F.ff_clock_to_q + F.net(1) + F.lut + F.net_to_carry + F.carry_entry + 2 * F.carry_next8 / 2 +
              F.net(1) + F.ff_setup)
    assert worst.delay_ns == pytest.approx(expect)


def test_submodule_inlined_and_module_types(tmp_path: Path) -> None:
    sub = Net({"i": ("input", 1), "o": ("output", 1)})
    x = sub.lut("s0", sub.ports["i"]["bits"][0])
    sub.cell("s1", "LUT1", {"I0": [x]}, {"O": sub.ports["o"]["bits"]})
    top = Net({"clk": ("input", 1), "d": ("input", 1)})
    a = top.ff("a", top.ports["d"]["bits"][0])
    mid = top.bits()[0]
    top.cell("u_sub", "sub", {"i": [a]}, {"o": [mid]})
    top.ff("b", top.lut("t0", mid))
    nl = ld.load(write(tmp_path, {"top": top.module(), "sub": sub.module(top=False)}))
    assert {c.name for c in nl.cells} >= {"u_sub.s0", "u_sub.s1"} and not nl.boxes
    worst = ld.analyze(nl).worst[0]
    assert (worst.start, worst.end, worst.luts) == ("a", "b", 3)  # through the submodule: 2 + 1 LUTs


def test_black_box_boundaries(tmp_path: Path) -> None:
    m = Net({"clk": ("input", 1), "d": ("input", 1)})
    a = m.ff("a", m.ports["d"]["bits"][0])
    into, out = m.lut("l0", m.lut("l1", a)), m.bits()[0]
    m.cell("u_pipe", "pgs_contact_pipe", {"in_data": [into]}, {"out_data": [out]})
    m.ff("b", m.lut("l2", out))
    a_ = ld.analyze(ld.load(write(tmp_path, {"top": m.module()})))
    assert a_.boxes == {"u_pipe": "pgs_contact_pipe"}
    assert a_.box_in["u_pipe:in_data"].luts == 2 and a_.box_in["u_pipe:in_data"].start == "a"
    assert a_.box_out["u_pipe:out_data"].luts == 1 and a_.box_out["u_pipe:out_data"].end == "b"
    assert all(p.end != "b" or p.start != "a" for p in a_.worst)  # no path through the box


def test_combinational_dsp(tmp_path: Path) -> None:
    m = Net({"clk": ("input", 1), "d": ("input", 1)})
    a = m.ff("a", m.ports["d"]["bits"][0])
    p = m.bits(48)
    regs = {k: "00000000000000000000000000000000" for k in ("AREG", "BREG", "MREG", "PREG", "CREG")}
    m.cell("mul", "DSP48E2", {"A": [a] * 30, "B": [a] * 18, "C": ["0"] * 48}, {"P": p},
           {**regs, "USE_MULT": "MULTIPLY"})
    m.ff("b", p[0])
    worst = ld.analyze(ld.load(write(tmp_path, {"top": m.module()}))).worst[0]
    assert (worst.dsp, worst.luts, worst.levels) == (1, 0, 1)
    fanout = 48  # a drives A and B: 48 pins
    assert worst.delay_ns == pytest.approx(F.ff_clock_to_q + F.net(fanout) + F.dsp_mult_alu + F.net(1) + F.ff_setup)
    # with PREG the product ends a path and P starts one
    m2 = Net({"clk": ("input", 1), "d": ("input", 1)})
    a2 = m2.ff("a", m2.ports["d"]["bits"][0])
    p2 = m2.bits(48)
    m2.cell("mul", "DSP48E2", {"A": [a2] * 30, "B": [a2] * 18}, {"P": p2},
            {**regs, "PREG": "00000000000000000000000000000001", "USE_MULT": "MULTIPLY"})
    m2.ff("b", m2.lut("l", p2[0]))
    r = ld.analyze(ld.load(write(tmp_path, {"top": m2.module()})))
    assert max(p.dsp for p in r.worst) == 0 and {p.end for p in r.worst} >= {"mul/A", "b"}


def test_argument_registers_kept_apart(tmp_path: Path) -> None:
    m = chain(5)
    m.names["u_control.fetch_passes"] = m.names["a"]  # a is the register file's argument (an alias)
    a = ld.analyze(ld.load(write(tmp_path, {"top": m.module()})), arguments=("fetch_passes",))
    assert [p.start for p in a.from_arguments] == ["a"] and a.from_arguments[0].luts == 5
    assert all(p.start != "a" for p in a.worst)
    plain = ld.analyze(ld.load(write(tmp_path, {"top": m.module()})))
    assert plain.worst[0].start == "a" and not plain.from_arguments


def test_block_ram_delay_line_taps(tmp_path: Path) -> None:
    m = Net({"clk": ("input", 1), "d": ("input", 1)})
    tap = m.ff("u_dl_x.g_ram.g_tap[0].g_read.r", m.ports["d"]["bits"][0])
    m.ff("b", m.lut("l0", tap))
    nl = ld.load(write(tmp_path, {"top": m.module()}))
    lut_ram = ld.analyze(nl).worst[0]
    bram = ld.analyze(nl, bram_taps=ld.block_ram_taps({"u_dl_x": 137, "u_dl_y": 40}, 129)).worst[0]
    assert bram.delay_ns - lut_ram.delay_ns == pytest.approx(F.bram_clock_to_out - F.ff_clock_to_q)
    assert ld.block_ram_taps({"u_dl_x": 137, "u_dl_y": 40}, 0) == ()
    assert ld.block_ram_taps({"u_dl_x": 137, "u_dl_y": 40}, 40) == ("u_dl_x.g_ram.g_tap[", "u_dl_y.g_ram.g_tap[")


def test_delay_line_depths_of_a_generated_pipe() -> None:
    source = (Path(__file__).parents[2] / "rtl" / "generated" / "pgs_contact_pipe.sv").read_text()
    depths = ld.delay_line_depths(source)
    latency = int(next(line for line in source.splitlines() if "localparam int LATENCY" in line)
                  .split("=")[1].split(",")[0])
    assert depths["u_tag"] == latency and len(depths) == source.count("pgs_delay #")  # multi-tap lines too
    assert all(0 <= d <= latency for d in depths.values())


def test_instance_types_follow_the_sources() -> None:
    types = ld.instance_types({"a.sv": "module top; sub #(.W(2), .T({32'(1)})) u_a (.x(y)); other u_b (.x(y));"
                                       " endmodule\nmodule sub; other u_c(); endmodule\nmodule other; endmodule"})
    assert types["top"] == {"u_a": "sub", "u_b": "other"} and types["sub"] == {"u_c": "other"}
    assert ld.module_of("u_a.g_x[2].u_c.r[3]", "top", types) == "other"
    assert ld.module_of("u_a.r", "top", types) == "sub" and ld.module_of("r", "top", types) == "top"


def test_budget_of_the_zcu102_clock() -> None:
    b = delays.budget(275e6)
    assert b.period_ns == pytest.approx(1e3 / 275)
    assert b.path_ns == pytest.approx(b.period_ns - F.clock_uncertainty - F.ff_clock_to_q - F.ff_setup)
    assert b.lut_levels == int(b.path_ns // F.lut_level) and 8 <= b.lut_levels <= 16
    assert delays.fmax_hz(b.period_ns - F.clock_uncertainty) == pytest.approx(275e6)
    assert delays.budget(550e6).lut_levels < b.lut_levels
    with pytest.raises(ValueError):
        delays.budget(0)
    # the -2 figures are the -1 report's scaled by DS925's BUFG ratio
    assert F.lut == pytest.approx(0.112 * 667 / 775, abs=1e-4) and F.dsp_mult_alu == pytest.approx(1e3 / 544, 1e-3)
