"""Delays of UltraScale+ cells and nets for the timing estimate (``sim/fit/logic_depth.py``), and the budget a clock
leaves a register-to-register path.

AMD's data sheet for the ZCU102's device (DS925, Zynq UltraScale+ MPSoC DC and AC switching characteristics)
publishes maximum frequencies, not per-cell delays: those live in Vivado's speed files. So the figures here come from
published Vivado timing reports of UltraScale+ parts, each named, scaled to the ZCU102's speed grade (-2, 0.85 V) by
DS925's own ratio between the speed grades:

* **-1 to -2**: DS925 gives the global clock tree (BUFG) 667 MHz at -1 and 775 MHz at -2, the DSP48E2 with all
  registers 645 and 775 MHz. The smaller speed-up (667 / 775 = 0.861) scales every -1 delay below (the larger one
  would make the estimate more optimistic).
* **FF, LUT, routed net, CARRY8, setup, clock uncertainty**: a routed Vivado 2021.2 report of an XCZU3EG -1 (Zynq
  UltraScale+, speed file PRODUCTION 1.29), a 15-level path (public repository gussmith23/lakeroad-evaluation, file
  ``runs/2022-07-06-1704-full/vivado-eval/xilinx-ultrascale-plus-vivado-eval/vivado-synth-opt-place-route/
  lpm.futil-ultrascale-timing-route.v``): FDRE clock-to-Q 0.093 ns; its ten LUTs 0.039-0.179 ns, mean 0.112 ns; the
  ten LUT-to-LUT routed nets 0.157-0.462 ns, which a least-squares line through their fanouts (1 to 78) puts at
  0.201 + 0.00255 ns per load; a CARRY8 entered at S 0.206 ns (to CO7) and 0.250 ns (to O4), mean 0.228 ns, plus
  0.018 ns of net from its LUT; each further CARRY8 of a chain 0.023-0.030 ns (mean 0.025) plus 0.028 ns of net;
  the FDRE's setup -0.027 ns (taken as 0); clock uncertainty 0.035 ns (jitter; not scaled).
* **DSP48E2 without registers** (what Yosys leaves when it packs none): DS925's -2 maximum frequencies of the
  registered paths stand for the pin-to-pin delays of the same logic: the multiply and post-adder (A/B to P, no
  MREG: FMAX_MULT_NOMREG 544 MHz, 1.838 ns), the post-adder alone (C, PCIN to P: all registers, 775 MHz,
  1.290 ns). Each period also holds an internal clock-to-out and setup, which a combinational use replaces by its
  pins' delays, so these are upper estimates.
* **Block RAM clock-to-out** without the output register: 0.830 ns in a routed Vivado report of an Alveo U250 (Virtex
  UltraScale+, -2L at 0.85 V: the -2 speed) quoted in UCLA-VAST/AutoBridge's source (``Prop_RAMB36E2_RAMB36_
  CLKARDCLK_DOUTBDOUT``); not scaled.
* **Shift-register and distributed-RAM clock-to-out**: the Artix-7 database Yosys ships (``share/xilinx/cells_sim.v``,
  from SymbiFlow prjxray-db) gives an SRL's 1.472 ns against an FDRE's 0.303 ns: that ratio (4.86) times the FDRE
  above. A distributed RAM's read (address to output) is a LUT's (prjxray-db gives a RAM64M8's and a LUT6's address
  pins the same delays).
* **Assumed, no published figure found**: a wide multiplexer (MUXF7/8/9) one LUT delay with no routed net before it
  (its inputs are the slice's own LUT outputs); setup of a block RAM, a registered DSP48E2 input, an SRL or a
  distributed RAM write port 0.40 / 0.40 / 0.10 / 0.10 ns; a registered DSP48E2 output 0.40 ns. The estimate names
  the paths that use them.

Routed nets in the sampled report are short (a small design); a full device routes longer nets, and nets with
hundreds of loads are replicated by a board flow: a net's fanout counts up to :data:`FANOUT_CAP` loads. The budget
is therefore an estimate of what placement and routing would give, not a timing sign-off.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass

SPEED_SCALE = 667.0 / 775.0  # DS925: BUFG FMAX -1 / -2 (0.85 V)
FANOUT_CAP = 100  # loads counted in a net's delay; a board flow replicates drivers of larger nets


@dataclass(frozen=True)
class DelayFigures:
    """Per-cell and per-net delays (ns) of one device speed grade; see the module docstring for each source."""

    name: str
    ff_clock_to_q: float
    ff_setup: float
    clock_uncertainty: float
    lut: float
    net_base: float  # routed net: base + per_load x min(fanout, FANOUT_CAP)
    net_per_load: float
    net_to_carry: float  # LUT output to the carry chain's S / DI (same slice)
    carry_entry: float  # a carry chain entered at S / DI, to CO or O
    carry_next8: float  # each further CARRY8 of the chain (CI to CO and the net between)
    muxf: float  # MUXF7 / MUXF8 / MUXF9 (assumed one LUT delay)
    dsp_mult_alu: float  # DSP48E2 A/B/D to P through the multiplier, no MREG / PREG
    dsp_alu: float  # DSP48E2 C / PCIN / MREG to P through the post-adder, no PREG
    dsp_clock_to_out: float  # assumed
    dsp_setup: float  # assumed
    bram_clock_to_out: float
    bram_setup: float  # assumed
    srl_clock_to_out: float
    srl_setup: float  # assumed (also a distributed RAM's write port)

    def net(self, fanout: int) -> float:
        return self.net_base + self.net_per_load * min(max(fanout, 1), FANOUT_CAP)

    @property
    def lut_level(self) -> float:
        """One LUT and a typical single-load net before it."""
        return self.lut + self.net(1)

    def digest(self) -> str:
        """A short hash of the figures: the committed path delays name the figures they were computed with."""
        return hashlib.sha256(json.dumps(asdict(self), sort_keys=True).encode()).hexdigest()[:12]


def _scaled(x: float) -> float:
    return round(x * SPEED_SCALE, 4)


_NET_BASE_1, _NET_PER_LOAD_1 = 0.201, 0.00255  # -1, least squares over the report's ten LUT-to-LUT nets
ULTRASCALE_PLUS_2 = DelayFigures(
    name="UltraScale+ -2 (0.85 V)",
    ff_clock_to_q=_scaled(0.093), ff_setup=0.0, clock_uncertainty=0.035,
    lut=_scaled(0.112), net_base=_scaled(_NET_BASE_1), net_per_load=_scaled(_NET_PER_LOAD_1),
    net_to_carry=_scaled(0.018), carry_entry=_scaled(0.228), carry_next8=_scaled(0.025 + 0.028),
    muxf=_scaled(0.112),
    dsp_mult_alu=round(1e3 / 544, 4), dsp_alu=round(1e3 / 775, 4), dsp_clock_to_out=0.40, dsp_setup=0.40,
    bram_clock_to_out=0.830, bram_setup=0.40,
    srl_clock_to_out=round(_scaled(0.093) * 1472 / 303, 4), srl_setup=0.10,
)
FIGURES = ULTRASCALE_PLUS_2  # the figures of every platform in models/timing/platforms.py (ZCU102 -2, U280 -2L)


@dataclass(frozen=True)
class Budget:
    """What a clock leaves a register-to-register path: the period less the clock uncertainty and the launching
    register's clock-to-out and the capturing one's setup, and how many LUT levels (a LUT and a single-load net
    each, no carry chain) fit in it."""

    clock_hz: float
    period_ns: float
    path_ns: float  # for the logic and nets between the launching register's output and the capturing input
    lut_levels: int

    def describe(self) -> str:
        return (f"{self.clock_hz / 1e6:g} MHz: {self.period_ns:.3f} ns, {self.path_ns:.3f} ns between registers "
                f"(about {self.lut_levels} LUT levels at {FIGURES.lut_level:.3f} ns; {FIGURES.name})")


def budget(clock_hz: float, figures: DelayFigures = FIGURES) -> Budget:
    if clock_hz <= 0:
        raise ValueError(f"clock must be positive, got {clock_hz} Hz")
    period = 1e9 / clock_hz
    path = period - figures.clock_uncertainty - figures.ff_clock_to_q - figures.ff_setup
    return Budget(clock_hz, period, path, max(0, int(path // figures.lut_level)))


def fmax_hz(path_delay_ns: float, figures: DelayFigures = FIGURES) -> float:
    """The highest clock at which a path of ``path_delay_ns`` (launch clock-to-out and capture setup included) meets
    the budget."""
    return 1e9 / (path_delay_ns + figures.clock_uncertainty)
