"""The resource estimate's band against a vendor flow, and the verdict with margin that ``make sim``, ``make sweep``
and ``make band`` print.

The resource model (``sim/fit/resource_model.py``) sums Yosys figures and computed memories. What a Vivado build of
the same RTL would count differs, and no published comparison of Yosys with Vivado on floating-point datapaths was
found (research note fit_audit_turn3.md section 5). The band is built from what is known:

* **Logic LUTs (operators, control, multiplexer rules), the optimistic end: x 0.763.** The only like-for-like pair of
  an operator is the fabric fp32 adder: Vitis HLS's ``fadd no_dsp`` 338 LUT against Yosys's ``fp_add`` 443
  (``VENDOR_OPERATORS``; -23.7%). Yosys reads high for known reasons that apply to every module: it does not pack
  two LUTs into one LUT6_2 as Vivado does, and with the hierarchy kept it optimises nothing across module
  boundaries. The other published pairs are other architectures and are not used for the band: ``fmul max_dsp``
  (78-123 LUT with 3 DSP against 133 with 2), ``hadd full_dsp`` and ``hmul max_dsp`` (DSP forms, -46% and -41%).
* **Distributed-RAM LUTs (delay lines, LUT-RAM arrays): no optimistic reduction.** They are counted as the RAM32M16 /
  RAM64M8 primitives Vivado also uses (``distributed_ram_luts``), which LUT combining does not shrink.
* **Every LUT and FF, the pessimistic end: x 1.10.** Vivado adds logic the estimate does not count: timing-driven
  replication of high-fanout drivers and route-through LUTs at 275 MHz, and the AXI DMA engines and interconnect of a
  board design (fit_audit_turn3.md section 5 takes about +10% as the working figure: no published measure of the
  three together was found, so it stays an assumption, named as one).
* **The sum of parts against Yosys of the whole pipe.** The estimate sums each pipe's operators and delay lines; where
  ``make resources`` has synthesized the whole pipe (``resource_figures.json`` units ``contact``, ``friction``,
  ``integrate``: every delay line in LUT RAM), the difference of its LUT and FF from the sum of the same pipe is added
  to the end it points to, per pipe of the configuration: a whole pipe above its sum raises the pessimistic end, below
  it lowers the optimistic end (Yosys optimises across the operators of a flattened pipe, and maps delay lines its own
  way).
* **FF, the optimistic end: x 1.0.** Registers follow the RTL; the vendor adder's FF figure (243 against Yosys's 192)
  is of a core with one more pipeline stage, not a smaller count of the same design.
* **DSP48E2 and block RAM: no band.** Vivado maps the same multiplies to the same DSP48E2 count (a 24 x 24 product
  takes two 27 x 18 multipliers) and each array to its cheapest RAMB36 / RAMB18 shape, which is the model's rule;
  what a board design adds here (the DMA engines' FIFOs) is not in the estimate and is not in the band either.

A design FITS when the pessimistic end of every resource is within its usable share (``USABLE_SHARE`` of
``models/timing/platforms.py``), with the margin in points of the device; "FITS at the optimistic end only" when the
pessimistic end of some resource is over it but every optimistic end is within it; otherwise DOES NOT FIT.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Optional, Union

from models.kernel.kernel_job import KernelJob
from models.timing import platforms
from sim.fit import resource_model as rm
from sim.fit.timing_estimate import pipe_unit


@dataclass(frozen=True)
class BandFactor:
    low: float
    high: float
    basis: str


PESSIMISTIC = 1.10  # replication, route-throughs, AXI DMA and interconnect: fit_audit_turn3.md section 5 (assumed)
LIKE_FOR_LIKE = ("fp_add", "fp32", "fadd no_dsp")  # the operator pair the optimistic end rests on


def logic_lut_band(data: Optional[dict[str, Any]] = None) -> BandFactor:
    """The logic LUTs' factors: the like-for-like vendor / Yosys LUT ratio (the committed Yosys figure of fp_add fp32
    against the published fadd no_dsp) and :data:`PESSIMISTIC`."""
    module, fmt_name, label = LIKE_FOR_LIKE
    vendor = next(v for v in rm.VENDOR_OPERATORS[(module, fmt_name)] if v.label == label)
    yosys = (data or rm.figures())["operators"][fmt_name][module]["LUT"]
    ratio = round(vendor.resources.lut / yosys, 3)
    return BandFactor(ratio, PESSIMISTIC, f"x{ratio}: {label} {vendor.resources.lut:g} LUT vs Yosys {module} {fmt_name} "
                      f"{yosys:g} (like for like); x{PESSIMISTIC}: replication, route-throughs, AXI DMA (assumed)")




def whole_pipe_gap(cfg: rm.KernelConfig, data: dict[str, Any]) -> rm.Resources:
    """Yosys of each whole pipe less the per-operator sum of the same pipe (delay lines in LUT RAM, as the whole run
    synthesizes them), times the pipes of ``cfg``; pipes without a whole run (their own or a stand-in's,
    ``pipe_unit``) count nothing."""
    gap = rm.Resources()
    units = data.get("units", {}).get(cfg.fmt.name, {})
    plain = rm.KernelConfig(cfg.fmt, 0, 0)
    for module, count in rm.lane_pipes(cfg) + [("pgs_integrate_pipe", 1)]:
        whole = units.get(pipe_unit(module) or "")
        if whole is None:
            continue
        parts, _ = rm.pipe_resources(module, plain, data)
        gap = gap + (rm.Resources.from_dict(whole) + parts.scaled(-1)).scaled(count)
    return gap


LUTRAM_LUT = BandFactor(1.0, PESSIMISTIC, "distributed RAM primitives as Vivado maps them; x1.10 as the logic")
FF = BandFactor(1.0, PESSIMISTIC, "registers follow the RTL; x1.10 replication and AXI DMA (assumed)")
EXACT = BandFactor(1.0, 1.0, "the same multiplies and arrays map the same way")
BANDS = {"FF": FF, "DSP": EXACT, "BRAM36": EXACT, "URAM": EXACT}


@dataclass(frozen=True)
class BandedShare:
    """One resource as shares of the device: the Yosys estimate, the vendor-anchored one, the band's two ends."""

    resource: str
    yosys: float
    vendor: float
    low: float
    high: float
    limit: float

    @property
    def margin_points(self) -> float:
        """Points of the device between the pessimistic end and the usable share (negative: over it)."""
        return 100 * (self.limit - self.high)

    def text(self) -> str:
        band = (f"{_pct(self.yosys)}" if math.isclose(self.low, self.high)
                else f"{_pct(self.yosys)} (band {_pct(self.low)}-{_pct(self.high)})")
        vendor = "" if math.isclose(self.vendor, self.yosys) else f", vendor-anchored {_pct(self.vendor)}"
        return f"{self.resource} {band}{vendor}"


def _pct(x: float) -> str:
    return "inf" if math.isinf(x) else f"{100 * x:.1f}%"


@dataclass(frozen=True)
class BandVerdict:
    platform: platforms.Platform
    shares: dict[str, BandedShare]
    config: str
    whole_pipe_gap: rm.Resources = dataclasses.field(default_factory=rm.Resources)  # whole pipes less their sums

    @property
    def binding(self) -> BandedShare:
        """The resource with the least margin at the pessimistic end."""
        return min(self.shares.values(), key=lambda s: s.margin_points)

    @property
    def fits(self) -> bool:
        return self.binding.margin_points >= 0

    @property
    def fits_optimistic(self) -> bool:
        return all(s.low <= s.limit for s in self.shares.values())

    @property
    def status(self) -> str:
        if self.fits:
            return "FITS"
        return "FITS at the optimistic end only" if self.fits_optimistic else "DOES NOT FIT"

    def headline(self) -> str:
        b = self.binding
        if self.fits:
            return (f"FITS the {self.platform.name}: {b.margin_points:.1f} points to spare at the pessimistic end "
                    f"({b.resource} {_pct(b.high)} of usable {_pct(b.limit)})")
        worst_low = max(self.shares.values(), key=lambda s: s.low - s.limit)
        if self.fits_optimistic:
            return (f"FITS at the optimistic end only on the {self.platform.name}: {b.resource} "
                    f"{_pct(b.low)}-{_pct(b.high)}, {-b.margin_points:.1f} points over usable {_pct(b.limit)} "
                    "at the pessimistic end")
        return (f"DOES NOT FIT the {self.platform.name}: {worst_low.resource} {_pct(worst_low.low)} at the "
                f"optimistic end, {100 * (worst_low.low - worst_low.limit):.1f} points over usable "
                f"{_pct(worst_low.limit)}")

    def shares_text(self) -> str:
        return "; ".join(s.text() for k, s in self.shares.items()
                         if self.platform.capacity(k) or s.high)


def band_verdict(cfg: rm.KernelConfig, platform: platforms.Platform,
                 data: Optional[dict[str, Any]] = None) -> BandVerdict:
    """The configuration's estimate (Yosys operators) and its vendor-anchored estimate on ``platform``, with the band."""
    data = data or rm.figures()
    est = rm.estimate(cfg, platform, data)
    logic_band = logic_lut_band(data)
    vendor = rm.estimate(dataclasses.replace(cfg, operator_source="vendor"), platform, data).total.as_dict()
    total = est.total.as_dict()
    lutram = sum(p.lutram for p in est.parts)
    gap = whole_pipe_gap(cfg, data)
    logic = total["LUT"] - lutram
    ends = {"LUT": ((logic + min(gap.lut, 0)) * logic_band.low + lutram * LUTRAM_LUT.low,
                    (logic + max(gap.lut, 0)) * logic_band.high + lutram * LUTRAM_LUT.high)}
    for k, f in BANDS.items():
        ends[k] = (total[k] * f.low, total[k] * f.high)
    ends["FF"] = ((total["FF"] + min(gap.ff, 0)) * FF.low, (total["FF"] + max(gap.ff, 0)) * FF.high)
    shares = {}
    for k in rm.KEYS:
        cap = platform.capacity(k)
        share = (lambda v: v / cap) if cap else (lambda v: math.inf if v else 0.0)
        shares[k] = BandedShare(k, share(total[k]), share(vendor[k]), share(ends[k][0]), share(ends[k][1]),
                                platforms.USABLE_SHARE[k])
    return BandVerdict(platform, shares, cfg.describe(), gap)


def band_or_reason(cfg: rm.KernelConfig, platform: platforms.Platform,
                   choose_adders: bool = False) -> Union[BandVerdict, rm.NoEstimate]:
    """The band of ``cfg`` (its own adder form, or with ``choose_adders`` the one the fit picks,
    ``rm.with_chosen_adders``: the model-only studies), or why there is none."""
    try:
        return band_verdict(rm.with_chosen_adders(cfg, platform) if choose_adders else cfg, platform)
    except (KeyError, FileNotFoundError) as exc:
        return rm.NoEstimate(str(exc).strip("'\""))


def short_band(v: Union[BandVerdict, rm.NoEstimate, None]) -> str:
    """One table cell: the status with the binding resource's band and margin."""
    if v is None or isinstance(v, rm.NoEstimate):
        return "no estimate"
    b = v.binding
    return f"{v.status} ({b.resource} {_pct(b.low)}-{_pct(b.high)}, margin {b.margin_points:+.1f} pt)"


def band_basis() -> str:
    """How the band is made, one line."""
    logic = logic_lut_band()
    return (f"LUT logic {logic.basis}; LUT RAM x{LUTRAM_LUT.low}-x{LUTRAM_LUT.high}; FF x{FF.low}-x{FF.high}; "
            "DSP and BRAM exact; Yosys of the whole pipes less their per-operator sums added to the end they point "
            "to (sim/fit/estimate_band.py)")


def kernel_band(job: KernelJob, dma: str, body_bits: int = rm.DEFAULT_BODY_BITS) -> Optional[Union[BandVerdict, rm.NoEstimate]]:
    """The band verdict of a run's configuration on its DMA preset's platform (None: no platform)."""
    if dma not in platforms.PLATFORMS:
        return None
    return band_or_reason(rm.config_for_job(job, body_bits), platforms.get_platform(dma))
