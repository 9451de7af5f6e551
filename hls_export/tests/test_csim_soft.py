"""C simulation of the HLS kernel's soft contact build (PGS_SOFT_CONTACT=1, the RTL's SOFT_CONTACT: Box2D's soft
row of models/golden/soft_contact.py, each point's accumulated impulse times a per-call keep factor before the add)
with the impulses in the records, against the golden model (``solve`` with ``SolverParams.soft_keep``) bit for bit in
the trace, the body-out stream and the impulse-out records: binary16 and binary32 on the pile, warm-started (non-zero
impulses from the first pass on), once with the soft row (two keep factors, neither 1) and once rigid on the same
build (the options bit clear); a soft job is refused by a build without the soft row."""

from __future__ import annotations

import re
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from hls_export.csim import RECORDS_FORMATS, SOFT_KEEP, build_csim, records_build, run_csim_step, scene_job, soft_jobs
from hls_export.tests.csim_checks import assert_bit_exact
from sim.drive.harness_run import write_inputs
from sim.compile.kernel_build import default_window
from sim.drive.kernel_step import golden_step
from rtl.gen.shared_hls_emit import BOOL_PARAMS, HEADER_FILE, bool_params

HLS_DIR = Path(__file__).resolve().parents[1]


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


def test_the_shared_functions_take_their_bools_in_the_order_lane_pass_passes_them() -> None:
    """The RTL connects the shared pipe's bool ports by name, the C++ by position: every generated function takes
    them in BOOL_PARAMS order (the soft ones: spin damping, then the soft row), the order of lane_pass's call, whatever
    order the binding met them in (a swap ran the contact pass rigid and spin-damped by the soft bit)."""
    header = (HLS_DIR / "generated" / HEADER_FILE).read_text()
    sigs = dict(re.findall(r"inline void (\w+)\(bool friction, const float in\[\d+\], (.*?), float out\[", header))
    assert len(sigs) == 10
    for name, params in sigs.items():
        bools = [p.removeprefix("bool ") for p in params.split(", ")]
        assert bools == [b for b in BOOL_PARAMS if b in bools], name
        assert bools == (["in_spin_damp", "in_soft"] if "_soft" in name else ["in_spin_damp"]), name
    kernel = (HLS_DIR / "pgs_kernel.cpp").read_text()
    assert "PGS_LANE_DATAPATH(friction, in, spin_damp, soft.on, out);" in kernel
    met_soft_first = SimpleNamespace(name="dp", bool_ports={"in_soft": None, "in_spin_damp": None})
    assert bool_params(met_soft_first) == ["in_spin_damp", "in_soft"]  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="in_other"):
        bool_params(SimpleNamespace(name="dp", bool_ports={"in_other": None}))  # type: ignore[arg-type]
