"""The runs of ``make coverage``: the kernel harness on the kernel test scenes (``models/scenes/kernel_scenes.py``)
in several formats, orders, DMA models and stream timings, with the edits of ``sim.coverage.input_edits``; the
fp-operator vectors; the register file's cocotb test."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from models.number_format import FP16, FP32, NumberFormat
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES, MAKE_SIM_PILE
from sim.coverage.input_edits import BAD_INPUT_EDITS, Edit, edit_gravity, edit_spin, edit_wide_index

# run scene -> (catalogue scene, builder parameters): the kernel tests' scenes, plus make sim's default pile (217
# bodies: more than the 64 body-out credits of the integration)
SCENES: dict[str, tuple[str, dict[str, Any]]] = {
    **{name: (name, params) for name, params in KERNEL_TEST_SCENES.items()}, "pile217": ("pile", MAKE_SIM_PILE)}


@dataclass(frozen=True)
class Case:
    """One harness run of the regression."""

    label: str
    fmt: NumberFormat
    scene: str  # a key of SCENES
    schedule: str = "hazard"
    dma: str = "zcu102"
    stalls: int = 0  # random stream gaps and backpressure, per mille
    interleaved: bool = False
    edit: Edit | None = None


CASES: list[Case] = [
    Case("pile-fp32-hazard-zcu102-stalls", FP32, "pile", stalls=150),
    Case("pile-fp32-pybullet-zcu102", FP32, "pile", "pybullet"),
    Case("stack-fp32-hazard-ideal-stalls", FP32, "stack", dma="ideal", stalls=300),
    Case("stack-fp32-pybullet-zcu102-interleaved", FP32, "stack", "pybullet", interleaved=True),
    Case("incline-fp32-hazard-zcu102", FP32, "incline"),
    Case("pile217-fp32-hazard-zcu102", FP32, "pile217"),
    Case("pile-fp16-hazard-zcu102-stalls", FP16, "pile", stalls=150),
    Case("stack-fp16-pybullet-ideal", FP16, "stack", "pybullet", dma="ideal"),
    Case("stack-fp16-spin-overflow", FP16, "stack", "pybullet", edit=edit_spin),
    Case("stack-fp32-gravity-dt-damping", FP32, "stack", edit=edit_gravity),
    Case("stack-fp32-wide-index", FP32, "stack", edit=edit_wide_index),
] + [Case(f"stack-fp32-bad-{e.name}", FP32, "stack", edit=e.edit) for e in BAD_INPUT_EDITS]

REGISTER_CASE = Case("pgs_control_s_axi-register-test", FP32, "-")
# the operator vectors (random pairs, every special pair, directed ties / flush / overflow cases, every 16-bit
# sqrt input) through every rtl/fp operator, in the formats the kernel runs are built for
FP_OPERATOR_CASES = [Case(f"fp-operators-{fmt.name}", fmt, "-") for fmt in (FP32, FP16)]
