"""Published figures we compare against (the 2018 thesis in ``shared/seeds/``), as measured there.

The thesis's scene: 38,880 cubes falling on a plane, one step with 127,000 contact manifolds, 4 iterations of
Bullet's GPU contact and friction passes plus integration, on a Xilinx ZCU102. Its GPU and CPU figures are
Bullet3's OpenCL pipeline on a GTX 980 and an i7-3770, for the same solver work.
"""

from __future__ import annotations

from dataclasses import dataclass

THESIS_BODIES = 38_880  # cubes (the ground plane not counted)
THESIS_MANIFOLDS = 127_000
THESIS_ITERATIONS = 4
THESIS_PASSES = 2 * THESIS_ITERATIONS  # contact and friction


@dataclass(frozen=True)
class FpgaFigure:
    label: str
    cycles: int
    clock_hz: float
    ms: float  # as reported
    utilisation: dict[str, int]  # percent of the XCZU9EG, Vivado HLS (LUT, FF, DSP, BRAM36)
    table: str  # the thesis's table of the utilisation

    @property
    def fit(self) -> str:
        """The published fit, e.g. ``fits (published: LUT 47%, FF 32%, DSP 42%, BRAM 70%)``."""
        shares = ", ".join(f"{'BRAM' if k == 'BRAM36' else k} {v}%" for k, v in self.utilisation.items())
        return f"fits (published: {shares})"

    @property
    def cycles_per_manifold_pass(self) -> float:
        return self.cycles / (THESIS_MANIFOLDS * THESIS_PASSES)


THESIS_FPGA = {
    "fp32": FpgaFigure("thesis ZCU102 fp32", 2_062_697, 275e6, 7.49, {"LUT": 47, "FF": 32, "DSP": 42, "BRAM36": 70},
                       "6.4"),
    "fp16": FpgaFigure("thesis ZCU102 fp16", 1_557_317, 250e6, 6.23, {"LUT": 49, "FF": 29, "DSP": 42, "BRAM36": 48},
                       "6.8"),
}
THESIS_GPU_MS = 13.64  # GTX 980, Bullet3 OpenCL
THESIS_CPU_MS = 53.01  # i7-3770
REPORT_CLOCKS_HZ = (250e6, 275e6)
