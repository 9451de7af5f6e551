"""Published per-step times of engines a user could pick instead, on their own scenes (not measured here): the
anchors ``make peers`` prints beside the peers it measures, scaled linearly to the frame and marked as such.
Each anchor names its source: the Box3D and Box2D v3 benchmark files, and the thesis."""

from __future__ import annotations

from dataclasses import dataclass

from models.published.thesis import THESIS_CPU_MS, THESIS_GPU_MS, THESIS_MANIFOLDS


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
