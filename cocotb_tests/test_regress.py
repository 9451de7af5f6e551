"""The points of ``make regress`` (``sim/regress.py``) as pytest tests, one per (seed, case), so that a failing
point reruns alone with the command the regression prints::

    REGRESS_SEED=3 .venv/bin/python -m pytest "cocotb_tests/test_regress.py::test_regress[s3-pile-fp32-hazard-zcu102]"

They are skipped unless ``REGRESS_SEEDS`` (a count: seeds 1..N) or ``REGRESS_SEED`` (one seed) is set, so ``make
test`` only collects them (and runs ``test_failure_report``, the summary's parser of a junit report).
"""

from __future__ import annotations

import fcntl
import os
from pathlib import Path

import pytest

from models.formats.number_format import FP32
from models.scenes.kernel_scenes import SEEDED
from models.timing.platforms import get_preset
from sim.compile.kernel_build import KernelBuild, build_kernel
from sim.regress import CASES, OUT, Case, check, failures, reproduce


def seeds() -> list[int]:
    if os.environ.get("REGRESS_SEED"):
        return [int(os.environ["REGRESS_SEED"])]
    return list(range(1, int(os.environ.get("REGRESS_SEEDS", "0")) + 1))


def _build(kb: KernelBuild) -> None:
    """Build (or find up to date) under a lock: xdist workers share the build directories."""
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / f"{kb.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        build_kernel(kb)


PARAMS = [pytest.param(s, c, id=f"s{s}-{c.name}") for s in seeds() for c in CASES]


@pytest.mark.skipif(not PARAMS, reason="make regress SEEDS=N (REGRESS_SEEDS / REGRESS_SEED) runs these")
@pytest.mark.parametrize("seed,case", PARAMS or [pytest.param(0, CASES[0], id="unset")])
def test_regress(seed: int, case: Case, tmp_path: Path) -> None:
    _build(KernelBuild(case.fmt, cons_bits=get_preset(case.dma).stream_bits))
    print(check(seed, case, tmp_path, case.scene in SEEDED or seed == seeds()[0]))


def test_failure_report(tmp_path: Path) -> None:
    """make regress's summary: the failed tests of a junit report, each with the command that reruns it alone."""
    junit = tmp_path / "junit.xml"
    junit.write_text('<testsuites><testsuite name="pytest">'
                     '<testcase classname="cocotb_tests.test_regress" name="test_regress[s3-pile-fp32-hazard-zcu102]">'
                     '<failure message="seed 3, pile-fp32-hazard-zcu102: 10,431 cycles beat the bound&#10;more">x'
                     '</failure></testcase>'
                     '<testcase classname="cocotb_tests.test_regress" '
                     'name="test_regress[s1-stack-fp16-pybullet-zcu102]"/>'
                     '</testsuite></testsuites>')
    assert failures(junit) == [("s3-pile-fp32-hazard-zcu102", "seed 3, pile-fp32-hazard-zcu102: 10,431 cycles beat "
                                                              "the bound")]
    assert reproduce(Case("pile", FP32, "hazard", "zcu102"), 3) == (
        'REGRESS_SEED=3 .venv/bin/python -m pytest "cocotb_tests/test_regress.py::test_regress[s3-pile-fp32-hazard-'
        'zcu102]"')
