"""C simulation of the HLS kernel's soft contact build (PGS_SOFT_CONTACT=1, the RTL's SOFT_CONTACT: Box2D's soft
row of models/golden/soft_contact.py, each point's accumulated impulse times a per-call keep factor before the add)
with the impulses in the records, against the golden model (``solve`` with ``SolverParams.soft_keep``) bit for bit in
the trace, the body-out stream and the impulse-out records: binary16 and binary32 on the pile, warm-started (non-zero
impulses from the first pass on), once with the soft row (two keep factors, neither 1) and once rigid on the same
build (the options bit clear); a soft job is refused by a build without the soft row."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from hls_export.csim import RECORDS_FORMATS, SOFT_KEEP, build_csim, records_build, run_csim_step, scene_job, soft_jobs
from hls_export.tests.csim_checks import assert_bit_exact
from sim.drive.harness_run import write_inputs
from sim.compile.kernel_build import default_window
from sim.drive.kernel_step import golden_step


@pytest.mark.parametrize("row", ["soft", "rigid"])
@pytest.mark.parametrize("fmt_name", list(RECORDS_FORMATS))
def test_csim_soft_build_bit_exact(fmt_name: str, row: str, tmp_path: Path) -> None:
    fmt = RECORDS_FORMATS[fmt_name]
    cold = scene_job("pile", "hazard", 4, records_build(fmt))
    job = soft_jobs(cold)[row]
    kb = records_build(fmt, cold, soft_contact=True)
    res = run_csim_step(job, tmp_path, build_csim(kb), kb, default_window(fmt, kb.cons_bits))
    assert_bit_exact(res, job, f"soft build {fmt_name} pile {row}")
    if row == "soft":  # the test can fail: the soft row's step is not the rigid one
        assert job.params.soft_keep == SOFT_KEEP
        rigid = golden_step(soft_jobs(cold)["rigid"]).final
        assert not np.array_equal(golden_step(job).final.linear_velocity, rigid.linear_velocity)


def test_csim_soft_job_needs_the_soft_build(tmp_path: Path) -> None:
    cold = scene_job("pile", "hazard", 4, records_build(RECORDS_FORMATS["fp32"]))
    kb = records_build(cold.fmt, cold)
    with pytest.raises(ValueError, match="soft contact pipe"):  # before any input file is written or run
        write_inputs(tmp_path, soft_jobs(cold)["soft"], kb)
    assert not any(tmp_path.iterdir())
