"""C simulation of the HLS kernel's records design (PGS_IMPULSES_IN_RECORDS=1) on shock propagation steps
(models/golden/shock_propagation.py, ``KernelJob.shocked``): in a shock pass each manifold row may have one body frozen,
marked in its record's header (bit 60 frozen A, bit 61 frozen B, bit 62 linear; body_b in bits 59:32), and the kernel
takes the frozen body as a static one for that row (inverse mass and inertia +0, its velocities not written back) and
a linear row's bodies without inverse inertia and without spin damping (pgs_kernel.cpp shock_row, pgs_solver.h
solve_friction). No build option: the same build as the records design.

Against the golden model (``solve`` with ``SolverParams.shock_contact`` / ``shock_friction``, the frozen rows'
impulses returned) bit for bit in the trace, the body-out stream and the impulse-out records: binary16 and binary32
on the pile and the stack, warm-started (csim.WARM_SEED), each shock of ``csim.SHOCKS`` (contact passes with an
angular or a linear shock, contact and friction passes with a linear or an angular one), with one iteration
(``shock_passes=1``: every pass a shock pass) and with four (only the last contact pass, and with friction the last
friction pass, a shock pass). The on-chip design (PGS_IMPULSES_IN_RECORDS=0) reads the same bits: binary32 on the
pile, four iterations, the two shocks with friction.

The tests can fail: each shock step's golden final velocities differ from those of the same job without its shock
passes (the same records, schedule and start, ``shock_contact`` / ``shock_friction`` clear), so the bit-exact runs
tell the kernel's shock rows from ordinary ones; and every shock step has frozen rows (linear ones where asked). The
angular+friction step is the one where the frozen body's velocities not being written back shows (its spin damping
is computed and dropped); elsewhere its chain v + 0 d equals what the table holds.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hls_export.csim import (RECORDS_FORMATS, RECORDS_SCENES, SHOCKS, build_csim, records_build, run_csim_step,
                             scene_job, shock_job)
from hls_export.tests.csim_checks import assert_bit_exact
from models.formats.number_format import FP32
from models.golden.shock_propagation import FREEZE_NONE
from sim.compile.kernel_build import KernelBuild, default_window
from sim.drive.kernel_step import golden_step


@pytest.mark.parametrize("iterations", [1, 4])
@pytest.mark.parametrize("shock", list(SHOCKS))
@pytest.mark.parametrize("scene", RECORDS_SCENES)
@pytest.mark.parametrize("fmt_name", list(RECORDS_FORMATS))
def test_csim_shock_bit_exact(fmt_name: str, scene: str, shock: str, iterations: int, tmp_path: Path) -> None:
    fmt = RECORDS_FORMATS[fmt_name]
    cold = scene_job(scene, "hazard", iterations, records_build(fmt))
    job = shock_job(cold, shock)
    linear, friction = SHOCKS[shock]
    p = job.params
    assert p.shock_contact and p.shock_friction == friction and p.shock_passes == 1 and p.shock_impulses == "return"
    frozen = job.cons.frozen != FREEZE_NONE
    assert frozen.any() and job.cons.linear == linear
    kb = records_build(fmt, job)
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(fmt, kb.cons_bits))
    assert_bit_exact(res, job, f"shock {shock} {fmt_name} {scene} {iterations} it, warm",
                     f"{int(frozen.sum())} of {frozen.size} rows frozen; "
                     f"{int(res.registers['impulse_out_records'])} impulse-out records compared")
    assert int(res.registers["impulse_out_records"]) == job.manifold_passes
    # the test can fail: the shock passes change the step
    plain = golden_step(job.unshocked()).final.linear_velocity
    assert not np.array_equal(golden_step(job).final.linear_velocity, plain)


@pytest.mark.parametrize("shock", ["linear+friction", "angular+friction"])
def test_csim_shock_on_chip_design(shock: str, tmp_path: Path) -> None:
    """The on-chip design (impulses in on-chip arrays, every step from zeros) reads the same header bits: binary32
    on the pile, four iterations, bit for bit."""
    kb = KernelBuild(FP32)
    linear, friction = SHOCKS[shock]
    job = scene_job("pile", "hazard", 4, kb).shocked(linear=linear, friction=friction, impulses="return")
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(FP32, kb.cons_bits))
    assert_bit_exact(res, job, f"shock {shock} on chip fp32 pile 4 it")
