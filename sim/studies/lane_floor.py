"""What stops a cycle target on a platform: the headline design with the lanes the target needs, and the block RAM
levers the resource model knows applied one after another (``python -m sim.studies.lane_floor``).

Below about one cycle per manifold-pass a step needs more than one datapath: fp32 at 0.8 cycles per manifold-pass
takes two lanes (the cycle model: 0.7832 with a ring of 8,192 records, 0.7854 with 4,096), fp16 at 0.45 four with
a ring of 4,096 (0.4492; 0.4723 with 8,192). This study takes the headline build (the window kernel, impulses in the
records, banked body velocities, 256-bit body streams, DSP48E2 adders, the scene's 1-word inverse inertia: the
``fitting-fp32`` and ``fitting-fp16`` commands of ``docs/claims.toml``) with those lanes and applies, in turn:

1. **a shallower ring** (``RECORD_WINDOW``; built: the cycle model measures what it costs, ``make sim MODE=model``);
2. **the poses off chip**: only 1/m and the inverse inertia stay on chip through the solve, the positions and
   orientations are streamed in again for the integration (``body_words="solve"``; modelled, not built: no cycle
   is counted for the second stream);
3. **the delay lines in block RAM from shallower depths** (``DELAY_BLOCK_MIN_DEPTH``; built), down to the shallowest
   of :data:`DELAY_DEPTHS` that keeps block RAM within the design target.

Each step prints the estimate with its band (``sim/fit/estimate_band.py``: the Yosys figure, the band's two ends,
the vendor-anchored figure with Vitis HLS's published operators), the verdict at the band's pessimistic end, and
whether the design target holds: LUT, FF and DSP at most :data:`DESIGN_TARGET` of the device by the Yosys figure,
block RAM at most 90%, and FITS. A last line gives the datapaths' operators alone at the vendor's published figures:
the LUTs no lever of the memories or the control reaches.

    python -m sim.studies.lane_floor [--platform zcu102] [--format fp32 --lanes 2 --ring 4096]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
from dataclasses import dataclass
from typing import Any, Optional, Sequence

from models.formats.number_format import FP16, FP32, NumberFormat
from models.kernel.body_banks import default_body_banks
from models.kernel.delay_lines import default_delay_block_min_depth
from models.scenes.specs import THESIS_FRAME_BODIES as THESIS_BODIES
from models.scenes.specs import THESIS_FRAME_MANIFOLDS as THESIS_MANIFOLDS
from models.timing import platforms
from sim.fit import estimate_band as eb
from sim.fit import resource_model as rm

# the design target of the headline designs: each resource's share of the device by the project's own (Yosys)
# figure, beside the verdict at the band's pessimistic end
DESIGN_TARGET = {"LUT": 0.75, "FF": 0.75, "DSP": 0.75, "BRAM36": 0.90}
HEADLINE_RING = 8192  # RECORD_WINDOW of the headline commands
HEADLINE_BODY_BITS = 256  # BODY_BITS of the headline commands
DELAY_DEPTHS = (129, 65, 33, 17, 9, 5)  # DELAY_BLOCK_MIN_DEPTH candidates, deepest first (pgs_delay: at least 4)
# the lanes each format's cycle target needs (the cycle model on the thesis frame: docs/results/fit.md)
TARGET_LANES = {"fp32": 2, "fp16": 4}


def headline_config(fmt: NumberFormat, lanes: int, bodies: int = THESIS_BODIES,
                    manifolds: int = THESIS_MANIFOLDS, ring: int = HEADLINE_RING) -> rm.KernelConfig:
    """The headline commands' build (``SCHEDULE=sweep RECORD_WINDOW=8192 IMPULSE_STORE=records BODY_BITS=256
    ADD_DSP=1 INERTIA=scene``) in ``fmt`` with ``lanes``: its body banks and delay-line threshold as ``make sim``
    chooses them."""
    return rm.KernelConfig(fmt, bodies, manifolds, lanes=lanes, window=ring, impulses_resident=False,
                           body_ports="banked", body_banks=default_body_banks(fmt, True, True, lanes),
                           delay_block_min_depth=default_delay_block_min_depth(fmt, True, True, lanes),
                           body_bits=HEADLINE_BODY_BITS, adders="dsp", inertia_words=1)


@dataclass(frozen=True)
class Step:
    lever: str
    config: rm.KernelConfig
    band: eb.BandVerdict

    def misses(self) -> list[str]:
        """The parts of the design target this step misses (empty: it meets it)."""
        out = [f"{k} {100 * self.band.shares[k].yosys:.1f}% > {100 * t:.0f}%" for k, t in DESIGN_TARGET.items()
               if self.band.shares[k].yosys > t]
        if not self.band.fits:
            out.append(f"{self.band.status} at the pessimistic end")
        return out


def _within_bram_target(cfg: rm.KernelConfig, platform: platforms.Platform, data: dict[str, Any]) -> bool:
    return eb.band_verdict(cfg, platform, data).shares["BRAM36"].yosys <= DESIGN_TARGET["BRAM36"]


def shallowest_delay_within_target(cfg: rm.KernelConfig, platform: platforms.Platform, data: dict[str, Any]) -> int:
    """The shallowest of :data:`DELAY_DEPTHS` (and no deeper than ``cfg``'s own threshold, where it has one) from
    which the delay lines can go to block RAM with block RAM still within the design target; ``cfg``'s own threshold
    where none can."""
    best = cfg.delay_block_min_depth
    for depth in DELAY_DEPTHS:
        if best and depth > best:
            continue
        if not _within_bram_target(dataclasses.replace(cfg, delay_block_min_depth=depth), platform, data):
            break
        best = depth
    return best


def steps(base: rm.KernelConfig, platform: platforms.Platform, ring: int,
          data: Optional[dict[str, Any]] = None) -> list[Step]:
    """The levers applied one after another to ``base``: as built, the ring of ``ring`` records, the poses off chip,
    the delay lines from the shallowest depth block RAM allows (where none is, the next shallower depth, over the
    target)."""
    data = data or rm.figures()
    out: list[Step] = []

    def add(lever: str, cfg: rm.KernelConfig) -> rm.KernelConfig:
        out.append(Step(lever, cfg, eb.band_verdict(cfg, platform, data)))
        return cfg

    cfg = add(f"as built ({base.lanes} lane(s), ring {base.window:,}, delay lines "
              f"{_delay_text(base.delay_block_min_depth)})", base)
    if ring != cfg.window:
        cfg = add(f"ring of {ring:,} records (RECORD_WINDOW={ring})", dataclasses.replace(cfg, window=ring))
    cfg = add("the poses off chip: 1/m and the inverse inertia on chip (modelled, not built)",
              dataclasses.replace(cfg, body_words="solve"))
    depth = shallowest_delay_within_target(cfg, platform, data)
    if depth != cfg.delay_block_min_depth:
        add(f"delay lines {_delay_text(depth)} (the shallowest block RAM allows)",
            dataclasses.replace(cfg, delay_block_min_depth=depth))
    else:  # none shallower keeps block RAM within the target: the next one, to show what it would cost
        shallower = [d for d in DELAY_DEPTHS if not depth or d < depth]
        if shallower:
            add(f"delay lines {_delay_text(shallower[0])} (block RAM over the design target)",
                dataclasses.replace(cfg, delay_block_min_depth=shallower[0]))
    return out


def _delay_text(depth: int) -> str:
    return f"from {depth} deep in block RAM" if depth else "in LUT RAM"


def operators_alone(cfg: rm.KernelConfig, platform: platforms.Platform,
                    data: Optional[dict[str, Any]] = None) -> tuple[float, str]:
    """The LUT share of the lanes' datapath operators alone at the vendor's published figures (Yosys's where none is
    published), and what they are: no delay line, multiplexer, control, integration or memory counted."""
    data = data or rm.figures()
    vendor = dataclasses.replace(cfg, operator_source="vendor")
    luts, names = 0.0, []
    for name, per in rm.lane_pipes(vendor):
        shape = rm.pipe_shape(name, vendor.fmt.man_bits)
        for mod, n in sorted(shape.operators.items()):
            fig_name = rm.operator_figure_name(mod, vendor)
            fig = rm.operator_figure(fig_name, vendor.fmt, "vendor", data)
            luts += per * n * fig.resources.lut
            names.append(f"{per} x {n} {fig_name} ({fig.resources.lut:.0f} LUT, {fig.source.split(' (')[0]})")
    return luts / platform.capacity("LUT"), "; ".join(names)


def table(found: Sequence[Step]) -> list[str]:
    head = ("| lever (cumulative) | LUT (band), vendor-anchored | FF | DSP | BRAM36 | verdict (pessimistic end) | "
            "design target |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    for s in found:
        sh = s.band.shares
        lut = sh["LUT"]
        misses = s.misses()
        lines.append(f"| {s.lever} | {100 * lut.yosys:.1f}% ({100 * lut.low:.1f}-{100 * lut.high:.1f}%), "
                     f"{100 * lut.vendor:.1f}% | {100 * sh['FF'].yosys:.1f}% | {100 * sh['DSP'].yosys:.1f}% | "
                     f"{100 * sh['BRAM36'].yosys:.1f}% | {eb.short_band(s.band)} | "
                     f"{'missed: ' + ', '.join(misses) if misses else 'met'} |")
    return lines


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.studies.lane_floor", description=__doc__.splitlines()[0])
    ap.add_argument("--platform", default="zcu102", choices=list(platforms.PLATFORMS))
    ap.add_argument("--format", default="fp32,fp16", help="formats, comma-separated (fp32, fp16)")
    ap.add_argument("--lanes", type=int, default=0, help="lanes (0: the lanes each format's cycle target needs)")
    ap.add_argument("--ring", type=int, default=HEADLINE_RING // 2,
                    help="the shallower ring's records (the lanes share each entry)")
    args = ap.parse_args(argv)
    by_name = {f.name: f for f in (FP32, FP16)}
    try:
        fmts = [by_name[f] for f in args.format.split(",")]
        platform = platforms.get_platform(args.platform)
        if args.ring < 2 or args.ring & (args.ring - 1):
            raise ValueError(f"--ring must be a power of two of at least 2, not {args.ring}")
        data = rm.figures()
        runs = [(f, args.lanes or TARGET_LANES[f.name]) for f in fmts]
        found = [(f, lanes, steps(headline_config(f, lanes), platform, args.ring, data)) for f, lanes in runs]
    except (KeyError, ValueError, FileNotFoundError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(f"{platform.name} ({platform.describe()}); {THESIS_BODIES:,} bodies, {THESIS_MANIFOLDS:,} manifolds; "
          f"usable: {platforms.describe_usable()}; design target: "
          + ", ".join(f"{k} {100 * t:.0f}%" for k, t in DESIGN_TARGET.items()))
    for fmt, lanes, found_steps in found:
        print(f"\n{fmt.name}, {lanes} lane(s), the headline build:\n")
        print("\n".join(table(found_steps)))
        share, what = operators_alone(found_steps[-1].config, platform, data)
        print(f"\nthe datapaths' operators alone at the vendor's figures: LUT {100 * share:.1f}% ({what})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
