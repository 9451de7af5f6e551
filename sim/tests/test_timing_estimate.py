"""A configuration's timing estimate (sim/fit/timing_estimate.py) on synthetic unit analyses: the worst path against
the clock's budget, the joins at the control's black boxes (pipes, block RAM, a distributed RAM's read tree), the clock a
design's latency is quoted at; and the committed timing figures against the code and delay figures that made them."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest

from models.formats.number_format import FP32
from models.timing.platforms import get_platform
from sim.fit import delays
from sim.fit import resource_model as rm
from sim.fit import timing_estimate as te

F = delays.FIGURES
ZCU102 = get_platform("zcu102")
REQUIRED = 1e3 / 275 - F.clock_uncertainty


def path(delay: float, luts: int, start: str = "s", end: str = "e", carry8: int = 0, module: str = "") -> dict[str, Any]:
    return {"delay_ns": delay, "luts": luts, "carry8": carry8, "muxf": 0, "dsp": 0, "start": start, "end": end,
            "module": module, "cells": "LUT6 " * luts, "levels": luts + carry8}


def unit(worst: float, levels: int = 5, **extra: Any) -> dict[str, Any]:
    a = {"endpoints": 10, "histogram": {str(levels): 10}, "worst": [path(worst, levels)], "by_module": {},
         "inputs": {}, "outputs": {}, "box_in": {}, "box_out": {}, "boxes": {}, "from_arguments": [], "notes": []}
    a.update(extra)
    return a


def data(control: dict[str, Any], pipes: float = 2.0) -> dict[str, Any]:
    units = {"contact": {"0": unit(pipes, 8, inputs={"in_data": path(1.0, 3, "in_data", "u_add.s1")},
                                   outputs={"out_data": path(0.08, 0, "u_dl.r", "output out_data")})},
             "friction": {"0": unit(pipes)}, "integrate": {"0": unit(pipes)}, "control": {"0": control}}
    return {"code": te.code_digest(), "figures": F.digest(), "units": {"fp32": units}}


# the streaming kernel with a contact and a friction pipe per lane: its control unit is "control"
CFG = rm.KernelConfig(FP32, 100, 100, shared_datapath=False)


def test_meets_and_fails_the_clock() -> None:
    ok = te.timing(CFG, ZCU102, data(unit(3.0)))
    assert isinstance(ok, te.TimingVerdict) and ok.meets and ok.headline().startswith("meets 275 MHz (estimate)")
    assert ok.slack_ns == pytest.approx(REQUIRED - 3.0) and ok.clock_hz == 275e6
    bad = te.timing(CFG, ZCU102, data(unit(5.0, 20)))
    assert isinstance(bad, te.TimingVerdict) and not bad.meets
    assert bad.headline().startswith("fails 275 MHz (estimate): control: s -> e, 20 levels (20 LUT), 5.00 ns")
    assert bad.fmax_hz == pytest.approx(1e9 / (5.0 + F.clock_uncertainty)) and bad.clock_hz == bad.fmax_hz
    # a path exactly at the budget meets it; a picosecond over does not
    assert te.timing(CFG, ZCU102, data(unit(REQUIRED))).meets
    assert not te.timing(CFG, ZCU102, data(unit(REQUIRED + 1e-3))).meets


def test_pipe_boundary_joined() -> None:
    control = unit(1.0, 2, boxes={"u_seq.u_contact": "pgs_contact_pipe"},
                   box_in={"u_seq.u_contact:in_data": path(2.5, 7, "u_seq.s1_words", "u_seq.u_contact:in_data")},
                   box_out={"u_seq.u_contact:out_data": path(0.9, 2, "u_seq.u_contact:out_data", "u_seq.r")})
    v = te.timing(CFG, ZCU102, data(control))
    assert isinstance(v, te.TimingVerdict)
    into = next(p for p in v.paths if p.where == "control -> contact")
    assert into.delay_ns == pytest.approx(3.5) and into.luts == 10 and (into.start, into.end) == ("u_seq.s1_words",
                                                                                                   "u_add.s1")
    out = next(p for p in v.paths if p.where == "contact -> control")
    assert out.delay_ns == pytest.approx(0.98) and out.end == "u_seq.r"
    assert v.worst is into and v.meets


def test_shared_datapath_takes_the_place_of_both_pipes() -> None:
    """One datapath per lane (the default): its own unit's paths, neither pipe's; without a run of it, named missing."""
    shared = dataclasses.replace(CFG, shared_datapath=True)
    d = data(unit(1.0))
    d["units"]["fp32"]["contact"]["0"] = unit(3.4, 12)  # a two-pipe build's worst: not the shared build's
    d["units"]["fp32"]["shared"] = {"0": unit(2.6, 9)}
    v = te.timing(shared, ZCU102, d)
    assert isinstance(v, te.TimingVerdict) and v.worst.where == "shared" and v.worst.delay_ns == 2.6
    assert not any(p.where in ("contact", "friction") for p in v.paths) and not v.missing
    assert te.timing(CFG, ZCU102, d).worst.where == "contact"  # type: ignore[union-attr]
    del d["units"]["fp32"]["shared"]
    gone = te.timing(shared, ZCU102, d)
    assert isinstance(gone, te.TimingVerdict) and gone.missing == ["shared in fp32 (`make resources FORMATS=fp32` "
                                                                   "adds it)"]


def test_the_scalar_shared_datapath_is_timed_with_the_default_ones_run() -> None:
    """The 1-word inverse inertia's shared datapath (the same operators, multiplexers and stages) has no Yosys run of
    its own: the default datapath's run stands for it, and the verdict says so; another variant stays missing."""
    shared = dataclasses.replace(CFG, shared_datapath=True)
    d = data(unit(1.0))
    d["units"]["fp32"]["shared"] = {"0": unit(2.6, 9)}
    v = te.timing(dataclasses.replace(shared, inertia_words=1), ZCU102, d)
    assert isinstance(v, te.TimingVerdict) and v.worst.where == "shared" and not v.missing
    assert any("pgs_shared_pipe_scalar as pgs_shared_pipe's Yosys run" in n for n in v.notes)
    assert te.pipe_unit("pgs_shared_pipe_scalar") == "shared" and te.pipe_unit("pgs_shared_pipe_full") is None
    full = te.timing(dataclasses.replace(shared, inertia_words=6), ZCU102, d)
    assert isinstance(full, te.TimingVerdict) and full.missing == ["pgs_shared_pipe_full (no Yosys run of it)"]


def test_ring_heads_and_records_are_block_ram() -> None:
    """The window's ring heads and records are block RAMs: a path into one ends at its setup, one out of it starts at
    its clock-to-out; the rejected-slot flags of the on-chip impulses are read through the LUT RAM tree."""
    cfg = rm.KernelConfig(FP32, 100, 100, window=8192, impulses_resident=True, body_ports="banked")
    flags_box = "u_seq.u_issue.g_rej_window.g_lane_rej[0].u_slot_rej"
    control = unit(1.0, 2, boxes={"u_seq.u_window.u_heads": "pgs_ring_ram", "u_seq.u_window.u_records": "pgs_ring_ram",
                                  flags_box: "pgs_ring_ram"},
                   box_in={"u_seq.u_window.u_heads:rd_addr": path(1.0, 3, "take"),
                           "u_seq.u_window.u_records:rd_addr": path(1.0, 3, "jlo"),
                           f"{flags_box}:rd_addr": path(0.8, 2, "sel")},
                   box_out={"u_seq.u_window.u_heads:rd_data": path(0.5, 2, end="issue"),
                            "u_seq.u_window.u_records:rd_data": path(0.5, 2, end="s1"),
                            f"{flags_box}:rd_data": path(0.6, 3, end="take")})
    d = data(control)
    d["units"]["fp32"]["control_window"] = d["units"]["fp32"].pop("control")
    v = te.timing(cfg, ZCU102, d)
    assert isinstance(v, te.TimingVerdict)
    outs = sorted(p.end for p in v.paths if p.where == "block RAM -> control")
    assert outs == ["issue", "s1"]
    assert all(p.delay_ns == pytest.approx(F.bram_clock_to_out + 0.5) for p in v.paths if p.where == "block RAM -> control")
    ins = [p for p in v.paths if p.where == "control -> block RAM"]
    assert len(ins) == 2 and all(p.delay_ns == pytest.approx(1.0 + F.net(1) + F.bram_setup) for p in ins)
    tree = te.read_tree(100)
    rej = next(p for p in v.paths if "LUT RAM read" in p.where)
    assert rej.delay_ns == pytest.approx(1.4 + tree.delay_ns) and rej.luts == 5 + tree.luts and rej.end == "take"


def test_body_flags_read_after_the_ring_heads() -> None:
    """The body RAM's dynamic / bad flags are read at the offered record's bodies: in the window kernel from the ring
    heads' block RAM output (read a cycle ahead), in the streaming kernel from the assembler's register."""
    window = rm.KernelConfig(FP32, 40000, 100, window=8192, impulses_resident=False, body_ports="banked")
    control = unit(1.0, 2, boxes={"u_seq.u_window.u_heads": "pgs_ring_ram", "u_seq.u_body_ram": "pgs_body_ram"},
                   box_in={"u_seq.u_window.u_heads:rd_addr": path(1.0, 3, "take")},
                   box_out={"u_seq.u_window.u_heads:rd_data": path(0.5, 2, end="issue"),
                            "u_seq.u_body_ram:dyn": path(0.7, 4, end="cam")})
    d = data(control)
    d["units"]["fp32"]["control_window"] = d["units"]["fp32"].pop("control")
    v = te.timing(window, ZCU102, d)
    assert isinstance(v, te.TimingVerdict)
    flags = te.read_tree(40000)
    assert flags.luts == 1 + math.ceil(math.log(math.ceil(40000 / 64), 4)) == 6
    read = next(p for p in v.paths if "body flags" in p.where)
    assert read.delay_ns == pytest.approx(F.bram_clock_to_out + F.lut_level + flags.delay_ns + 0.7)  # the bypass mux
    assert read.luts == 1 + flags.luts + 4 and read.end == "cam" and "block RAM" in read.start
    assert v.worst is read  # the deepest path of this kernel
    stream = te.timing(dataclasses.replace(CFG, max_bodies=40000), ZCU102,
                       data(unit(1.0, 2, boxes={"u_seq.u_body_ram": "pgs_body_ram"},
                                 box_out={"u_seq.u_body_ram:bad": path(0.7, 4, end="take")})))
    assert isinstance(stream, te.TimingVerdict)
    reg = next(p for p in stream.paths if "body flags" in p.where)
    assert reg.delay_ns == pytest.approx(F.ff_clock_to_q + flags.delay_ns + 0.7) and reg.end == "take"


def test_delay_line_threshold_picks_the_pipe_analysis() -> None:
    d = data(unit(1.0))
    d["units"]["fp32"]["contact"]["129"] = unit(3.3, 9)
    lutram = te.timing(CFG, ZCU102, d)
    block = te.timing(dataclasses.replace(CFG, delay_block_min_depth=129), ZCU102, d)
    assert isinstance(lutram, te.TimingVerdict) and isinstance(block, te.TimingVerdict)
    assert lutram.worst.delay_ns == 2.0 and block.worst.delay_ns == 3.3


def test_missing_units_and_stale_figures() -> None:
    d = data(unit(1.0))
    del d["units"]["fp32"]["friction"]
    v = te.timing(CFG, ZCU102, d)
    assert isinstance(v, te.TimingVerdict) and any(m.startswith("friction in fp32") for m in v.missing)
    assert "not covered: friction in fp32" in v.headline()
    tb = te.timing(dataclasses.replace(CFG, tangents_on_chip=True), ZCU102, data(unit(1.0)))
    assert isinstance(tb, te.TimingVerdict) and any("pgs_friction_pipe_tb" in m for m in tb.missing)
    stale = data(unit(1.0))
    stale["figures"] = "0" * 12
    assert isinstance(te.timing(CFG, ZCU102, stale), te.NoTiming)
    old_code = data(unit(1.0))
    old_code["code"] = "0" * 12
    v = te.timing(CFG, ZCU102, old_code)
    assert isinstance(v, te.TimingVerdict) and "older sim/fit/logic_depth.py" in v.notes[0]
    assert isinstance(te.timing(rm.KernelConfig(rm.NumberFormat("e6m9", 6, 9), 9, 9), ZCU102, data(unit(1.0))),
                      te.NoTiming)


def test_clock_of_the_latency() -> None:
    ok = te.timing(CFG, ZCU102, data(unit(3.0)))
    bad = te.timing(CFG, ZCU102, data(unit(7.0)))
    assert te.clock_note(ok, 275e6) == (275e6, "275 MHz (the timing estimate meets it)")
    hz, why = te.clock_note(bad, 275e6)
    assert hz == pytest.approx(1e9 / (7.0 + F.clock_uncertainty)) and why.endswith("275 fails)")
    assert te.clock_note(None, 250e6)[0] == 250e6


def test_histogram_bands() -> None:
    text = te.histogram_text({0: 10, 3: 30, 5: 50, 13: 10})
    assert text.startswith("0: 10.0%, 1-4: 30.0%, 5-8: 50.0%, 13-16: 10.0%") and "deepest 13" in text


def test_committed_timing_figures_are_current() -> None:
    """The committed figures were computed by this walk with these delay figures (else `make resources` redoes them
    from its cached netlists), and they hold the units the headline designs build."""
    d = te.timing_figures()
    assert d["code"] == te.code_digest() and d["figures"] == F.digest()
    for fmt in ("fp32", "fp16"):
        assert {"fp_add", "fp_mul", "control_window"} <= set(d["units"][fmt]), fmt
        for name, per_threshold in d["units"][fmt].items():
            for a in per_threshold.values():
                assert a["worst"] or a["endpoints"] == 0 or name == "fp_minmax"
                assert all(p["levels"] == p["luts"] + p["carry8"] + p["muxf"] + p["dsp"] for p in a["worst"])


def test_make_sim_sections_print_the_band_and_the_timing() -> None:
    from sim.fit import estimate_band as eb
    from sim.report.run_result import FIT_SECTION, TIMING_SECTION, ModelRunResult, sections

    cfg = rm.KernelConfig(FP32, 38881, 147485, window=8192, impulses_resident=False, body_ports="banked",
                          delay_block_min_depth=129, body_bits=256)
    result = ModelRunResult("r", "thesis", 38881, 147485, "sweep", "zcu102", {}, fit=rm.fit(cfg, ZCU102),
                            band=eb.band_verdict(cfg, ZCU102), timing=te.timing(CFG, ZCU102, data(unit(5.0, 20))))
    rows = sections(result)
    fit = rows[FIT_SECTION]
    verdict = next(v for k, v in fit.items() if k.startswith("verdict at the band's pessimistic end"))
    band = eb.band_verdict(cfg, ZCU102)
    assert isinstance(band, eb.BandVerdict) and verdict == band.headline() and band.binding.resource in verdict
    assert "band" in fit["LUT, FF, DSP, BRAM36, URAM (share of the device: Yosys estimate, band, vendor-anchored)"]
    assert fit["margin per resource (points of the device at the pessimistic end)"].startswith("LUT ")
    timing = rows[TIMING_SECTION]
    assert timing["timing"].startswith("fails 275 MHz (estimate)") and timing["deepest path 1 (over)"]
    assert timing["clock the estimate supports"] == f"{1e3 / (5.0 + F.clock_uncertainty):.0f} MHz"
    none = sections(ModelRunResult("r", "x", 1, 1, "hazard", "zcu102", {}, timing=te.NoTiming("no figures")))
    assert none[TIMING_SECTION] == {"timing": "no estimate (no figures)"}


def test_model_latency_at_the_clock_the_estimate_supports() -> None:
    """make sim MODE=model adds the latency at the estimate's clock where the platform's fails, and nothing where it
    meets."""
    from sim.run import at_estimated_clock

    section = {"model: kernel cycles": 822_865}
    hz = 1e9 / (7.0 + F.clock_uncertainty)
    slow = at_estimated_clock(section, te.timing(CFG, ZCU102, data(unit(7.0))), 275e6)
    key = next(k for k in slow if k.startswith("model: latency at"))
    assert key.startswith(f"model: latency at {hz / 1e6:.0f} MHz (ms; ") and "275 fails" in key
    assert slow[key] == pytest.approx(822_865 / hz * 1e3)
    assert at_estimated_clock(section, te.timing(CFG, ZCU102, data(unit(3.0))), 275e6) == section


def test_dsp_adders_add_their_own_deepest_path() -> None:
    """A build with the DSP48E2 adders: the pipes were analysed with the fabric form, so fp_add_dsp's own deepest path
    joins the verdict (and decides it where it is the deepest); a unit missing is named; the fabric form ignores it."""
    d = data(unit(2.0))
    d["units"]["fp32"][te.DSP_ADDER_UNIT] = {"0": unit(4.8, 10)}
    dsp_cfg = dataclasses.replace(CFG, adders="dsp")
    v = te.timing(dsp_cfg, ZCU102, d)
    assert isinstance(v, te.TimingVerdict) and not v.meets and v.worst.where == te.DSP_ADDER_UNIT
    assert v.worst.delay_ns == pytest.approx(4.8) and any("fp_add_dsp's own" in n for n in v.notes)
    fabric = te.timing(CFG, ZCU102, d)
    assert isinstance(fabric, te.TimingVerdict) and fabric.meets
    assert all(p.where != te.DSP_ADDER_UNIT for p in fabric.paths)
    del d["units"]["fp32"][te.DSP_ADDER_UNIT]
    gone = te.timing(dsp_cfg, ZCU102, d)
    assert isinstance(gone, te.TimingVerdict) and any("fp_add_dsp in fp32" in m for m in gone.missing)
