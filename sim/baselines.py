"""Published figures we compare against (the 2018 thesis in ``shared/seeds/``), as measured there.

The thesis's scene: 38,880 cubes falling on a plane, one step with 127,000 contact manifolds, 4 iterations of
Bullet's GPU contact and friction passes plus integration, on a Xilinx ZCU102. Its GPU and CPU figures are
Bullet3's OpenCL pipeline on a GTX 980 and an i7-3770, for the same solver work.
"""

from __future__ import annotations

from dataclasses import dataclass

THESIS_MANIFOLDS = 127_000
THESIS_ITERATIONS = 4
THESIS_PASSES = 2 * THESIS_ITERATIONS  # contact and friction


@dataclass(frozen=True)
class FpgaFigure:
    label: str
    cycles: int
    clock_hz: float
    ms: float  # as reported
    fit: str = ""  # the published utilisation of the XCZU9EG

    @property
    def cycles_per_manifold_pass(self) -> float:
        return self.cycles / (THESIS_MANIFOLDS * THESIS_PASSES)


THESIS_FPGA = {
    "fp32": FpgaFigure("thesis ZCU102 fp32", 2_062_697, 275e6, 7.49, "fits (published: LUT 47%, FF 32%, DSP 42%, BRAM 70%)"),
    "fp16": FpgaFigure("thesis ZCU102 fp16", 1_557_317, 250e6, 6.23, "fits (published: LUT 49%, FF 29%, DSP 42%, BRAM 48%)"),
}
THESIS_GPU_MS = 13.64  # GTX 980, Bullet3 OpenCL
THESIS_CPU_MS = 53.01  # i7-3770
REPORT_CLOCKS_HZ = (250e6, 275e6)


@dataclass(frozen=True)
class PublishedPeer:
    """A published per-step time of an engine on its own scene (not measured here): an anchor, not a peer row."""

    label: str
    scene: str
    size: int  # the scene's size in ``unit``
    unit: str  # "bodies" (boxes) or "manifolds" (the thesis's solver work: 4 iterations of both passes)
    ms: float  # time per step as published
    hardware: str
    source: str
    whole_step: bool  # True: the whole step (collision included); False: the contact solve and integration only

    def scaled(self, bodies: int, manifolds: int) -> float:
        """The time scaled linearly to a frame of ``bodies`` and ``manifolds``: an extrapolation, not a measurement."""
        return self.ms * (bodies if self.unit == "bodies" else manifolds) / self.size


PEER_ANCHORS = (
    PublishedPeer("Box3D soft step, 1 thread (SSE2)", "many_pyramids", 10_780, "bodies", 23.3, "AMD Ryzen 9 7950X",
                  "erincatto/box3d benchmark/amd7950x_sse2/many_pyramids.csv", True),
    PublishedPeer("Box3D soft step, 8 threads (SSE2)", "many_pyramids", 10_780, "bodies", 3.16, "AMD Ryzen 9 7950X",
                  "erincatto/box3d benchmark/amd7950x_sse2/many_pyramids.csv", True),
    PublishedPeer("Box2D v3 (2D) soft step, 8 threads (AVX2)", "many_pyramids", 22_000, "bodies", 2.31, "AMD Ryzen 9 7950X",
                  "erincatto/box2d benchmark/amd7950x_avx2/", True),
    PublishedPeer("thesis: Bullet3 OpenCL, GTX 980", "its frame, 127,000 manifolds", THESIS_MANIFOLDS, "manifolds",
                  THESIS_GPU_MS, "NVIDIA GTX 980", "the thesis, Tables 6.4-6.11", False),
    PublishedPeer("thesis: Bullet3 CPU port, i7-3770", "its frame, 127,000 manifolds", THESIS_MANIFOLDS, "manifolds",
                  THESIS_CPU_MS, "Intel i7-3770", "the thesis, Tables 6.4-6.11", False),
)
