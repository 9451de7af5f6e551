"""The frames the kernel is tested on, named once: scene name -> the builder parameters of its frame
(``models.scenes.load_or_capture(scene, **params)``).

* :data:`KERNEL_TEST_SCENES`: the kernel co-simulation tests' scenes (``cocotb_tests/test_pgs_kernel.py``) and the
  scenes of the coverage regression (``sim/coverage``): a 48-cube pile, the 10-cube stack, the box on a slope;
* :data:`MAKE_SIM_PILE`: ``make sim``'s default frame (the pile of 217 bodies, seed 1: more bodies than the
  64 body-out credits of the integration), a coverage run of its own;
* :data:`REGRESS_SCENES`: ``make regress``, every scene kind (the test scenes first); the frames of the
  :data:`SEEDED` scenes follow the regression seed (their jitter), the others are the same for every seed;
* :data:`PIPE_VECTOR_SCENES`: the frames the datapath tests (``cocotb_tests/test_kernel_pipes.py``) draw their
  scene vectors from: the test scenes, but the 48-cube pile of seed 0 (the builder's default).
"""

from __future__ import annotations

from typing import Any

KERNEL_TEST_SCENES: dict[str, dict[str, Any]] = {
    "pile": {"nx": 4, "ny": 3, "nz": 4, "seed": 2},
    "stack": {},
    "incline": {},
}
MAKE_SIM_PILE: dict[str, Any] = {"seed": 1}
REGRESS_SCENES: dict[str, dict[str, Any]] = {
    **KERNEL_TEST_SCENES,
    **{scene: {} for scene in ("pyramid", "mass_ratio", "impact", "spin", "plank", "degenerate")},
}
SEEDED: frozenset[str] = frozenset({"pile"})
PIPE_VECTOR_SCENES: dict[str, dict[str, Any]] = {
    **KERNEL_TEST_SCENES,
    "pile": {"nx": 4, "ny": 3, "nz": 4},
}


def regress_params(scene: str, seed: int) -> dict[str, Any]:
    """The builder parameters of ``scene``'s regression frame for regression seed ``seed``."""
    params = REGRESS_SCENES[scene]
    return {**params, "seed": seed} if scene in SEEDED else dict(params)
