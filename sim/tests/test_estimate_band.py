"""The resource estimate's band against a vendor flow (sim/fit/estimate_band.py): the ends computed from the parts
(logic LUTs scaled by the like-for-like operator ratio, distributed RAM not), the verdict's three outcomes and margin,
and the published operator figures written beside Yosys's."""

from __future__ import annotations

import copy
import dataclasses
import math

import pytest

from models.formats.number_format import FP16, FP32
from models.timing.platforms import USABLE_SHARE, get_platform
from sim.fit import estimate_band as eb
from sim.fit import resource_model as rm
from sim.fit import timing_estimate as te

ZCU102 = get_platform("zcu102")
THESIS = (38881, 147485)


def window(fmt=FP32, lanes=1, banks=8) -> rm.KernelConfig:
    return rm.KernelConfig(fmt, *THESIS, lanes=lanes, window=8192, impulses_resident=False, body_ports="banked",
                           body_banks=banks, delay_block_min_depth=129, body_bits=256)


def test_logic_band_is_the_like_for_like_adder_ratio() -> None:
    data = rm.figures()
    band = eb.logic_lut_band(data)
    assert band.low == round(338 / data["operators"]["fp32"]["fp_add"]["LUT"], 3) and band.high == 1.10
    doubled = copy.deepcopy(data)
    doubled["operators"]["fp32"]["fp_add"]["LUT"] *= 2  # a Yosys adder twice as big: the optimistic end halves
    assert eb.logic_lut_band(doubled).low == pytest.approx(band.low / 2, abs=1e-3)


def test_band_ends_from_the_parts() -> None:
    cfg = window()
    est = rm.estimate(cfg, ZCU102)
    lutram = sum(p.lutram for p in est.parts)
    assert 0 < lutram < est.total.lut  # delay lines in LUT RAM, ring heads; the rest is logic
    v = eb.band_verdict(cfg, ZCU102)
    lut, low = v.shares["LUT"], eb.logic_lut_band().low
    gap = eb.whole_pipe_gap(cfg, rm.figures())
    assert v.whole_pipe_gap == gap
    assert lut.yosys == pytest.approx(est.total.lut / ZCU102.lut)
    assert lut.low == pytest.approx(((est.total.lut - lutram + min(gap.lut, 0)) * low + lutram) / ZCU102.lut)
    assert lut.high == pytest.approx((est.total.lut + max(gap.lut, 0)) * 1.10 / ZCU102.lut)
    bram, dsp = v.shares["BRAM36"], v.shares["DSP"]
    assert bram.low == bram.high == bram.yosys and dsp.low == dsp.high == dsp.yosys  # no band on mapping rules
    assert v.shares["FF"].low <= v.shares["FF"].yosys < v.shares["FF"].high
    # the vendor-anchored estimate: DSP adders and multipliers of the published cores
    vendor = rm.estimate(rm.KernelConfig(**{**cfg.__dict__, "operator_source": "vendor"}), ZCU102).total
    assert dsp.vendor == pytest.approx(vendor.dsp / ZCU102.dsp) and dsp.vendor > dsp.yosys
    assert lut.margin_points == pytest.approx(100 * (USABLE_SHARE["LUT"] - lut.high))


def test_whole_pipe_runs_widen_the_band() -> None:
    """A whole pipe synthesized bigger than its per-operator sum raises the pessimistic end by the difference per pipe
    of the configuration (two lanes of two pipes: two contact and two friction pipes; two lanes of one shared
    datapath: two shared datapaths); smaller, it lowers the optimistic end."""
    data = copy.deepcopy(rm.figures())
    shared = window(FP16, lanes=2, banks=16)
    two_pipes = dataclasses.replace(shared, shared_datapath=False)
    plain = rm.KernelConfig(FP16, 0, 0)
    sums = {u: rm.pipe_resources(m, plain, data)[0] for m, u in te.PIPE_UNITS.items()}
    extra = {"contact": 1000, "friction": 500, "integrate": -300, "shared": 700}
    data["units"]["fp16"].update({u: {**sums[u].as_dict(), "LUT": sums[u].lut + d} for u, d in extra.items()})
    gap = eb.whole_pipe_gap(two_pipes, data)
    assert gap.lut == pytest.approx(2 * 1000 + 2 * 500 - 300) and gap.ff == pytest.approx(0)
    assert eb.whole_pipe_gap(shared, data).lut == pytest.approx(2 * 700 - 300)
    wide = eb.band_verdict(two_pipes, ZCU102, data).shares["LUT"]
    for u in extra:
        del data["units"]["fp16"][u]
    assert eb.whole_pipe_gap(two_pipes, data) == rm.Resources() == eb.whole_pipe_gap(shared, data)
    plain_band = eb.band_verdict(two_pipes, ZCU102, data).shares["LUT"]
    assert wide.high - plain_band.high == pytest.approx(2700 * 1.10 / ZCU102.lut)
    assert wide.low == pytest.approx(plain_band.low)  # the gap points up: the optimistic end stays


def share(resource: str, low: float, high: float, limit: float = 0.85) -> eb.BandedShare:
    return eb.BandedShare(resource, (low + high) / 2, low, low, high, limit)


def verdict(*shares: eb.BandedShare) -> eb.BandVerdict:
    return eb.BandVerdict(ZCU102, {s.resource: s for s in shares}, "test")


def test_verdict_outcomes_and_margin() -> None:
    fits = verdict(share("LUT", 0.60, 0.80), share("BRAM36", 0.5, 0.5, 0.95))
    assert fits.status == "FITS" and fits.binding.resource == "LUT"
    assert fits.headline().startswith("FITS the zcu102: 5.0 points to spare") and "LUT 80.0%" in fits.headline()
    edge = verdict(share("LUT", 0.66, 0.92), share("BRAM36", 0.9, 0.9, 0.95))
    assert edge.status == "FITS at the optimistic end only" and not edge.fits and edge.fits_optimistic
    assert "7.0 points over usable 85.0%" in edge.headline()
    over = verdict(share("LUT", 0.90, 1.2), share("BRAM36", 0.5, 0.5, 0.95))
    assert over.status == "DOES NOT FIT" and "5.0 points over usable" in over.headline()
    assert eb.short_band(edge) == "FITS at the optimistic end only (LUT 66.0%-92.0%, margin -7.0 pt)"
    # a block RAM share exactly at its usable share fits with no margin; a hair over does not
    at = verdict(share("LUT", 0.5, 0.6), share("BRAM36", 0.95, 0.95, 0.95))
    assert at.fits and at.binding.margin_points == pytest.approx(0.0, abs=1e-9)
    assert not verdict(share("BRAM36", 0.951, 0.951, 0.95)).fits_optimistic


def test_headline_designs_with_the_band() -> None:
    """The two headline window designs (thesis frame, ring 8,192): the Yosys figure inside its band, the verdict the
    one the pessimistic and optimistic ends give."""
    for cfg in (window(), window(FP16, lanes=2, banks=16)):
        v = eb.band_verdict(cfg, ZCU102)
        lut = v.shares["LUT"]
        assert lut.low < lut.yosys < lut.high and not math.isclose(lut.vendor, lut.yosys)
        worst = max(s.high - s.limit for s in v.shares.values())
        assert v.fits == (worst <= 0) and v.binding.margin_points == pytest.approx(-100 * worst)
        assert v.status == ("FITS" if worst <= 0 else "FITS at the optimistic end only" if all(
            s.low <= s.limit for s in v.shares.values()) else "DOES NOT FIT")


def test_vendor_figures_written_beside_yosys_are_current() -> None:
    """Every operator with a published figure carries it in resource_figures.json, as VENDOR_OPERATORS has it."""
    ops = rm.figures()["operators"]
    for (module, fmt_name), figs in rm.VENDOR_OPERATORS.items():
        assert ops[fmt_name][module]["vendor"] == rm.vendor_rows(module, fmt_name), (module, fmt_name)
        assert all(row["source"] and row["label"] for row in ops[fmt_name][module]["vendor"])
    assert {("fp_add", "fp32"), ("fp_mul", "fp32"), ("fp_add", "fp16"), ("fp_mul", "fp16")} <= set(rm.VENDOR_OPERATORS)
    for fmt_name, mods in ops.items():
        for module, row in mods.items():
            assert ("vendor" in row) == ((module, fmt_name) in rm.VENDOR_OPERATORS), (module, fmt_name)


def test_no_estimate_without_figures() -> None:
    v = eb.band_or_reason(rm.KernelConfig(rm.NumberFormat("e6m9", 6, 9), 10, 10), ZCU102)
    assert isinstance(v, rm.NoEstimate) and eb.short_band(v) == "no estimate"
