"""The points of ``make regress`` (``sim/regress.py``) as pytest tests, one per (seed, case), so that a failing
point reruns alone with the command the regression prints::

    REGRESS_SEED=3 .venv/bin/python -m pytest "cocotb_tests/test_regress.py::test_regress[s3-pile-fp32-hazard-zcu102]"

They are skipped unless ``REGRESS_SEEDS`` (a count: seeds 1..N) or ``REGRESS_SEED`` (one seed) is set, so ``make
test`` only collects them (and runs ``test_failure_report``, the summary's parser of a junit report). CI sets
``REGRESS_SLICE`` (``.ci/run``): that many points with the run seed (``sim.drive.seed.run_seed``, CI's from the commit),
the cases picked by the seed (``sim.regress.ci_slice``), each with its random stalls and deterministic streams.
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
from sim.regress import CASES, OUT, Case, check, ci_slice, failures, reproduce
from sim.drive.seed import run_seed


def seeds() -> list[int]:
    if os.environ.get("REGRESS_SEED"):
        return [int(os.environ["REGRESS_SEED"])]
    return list(range(1, int(os.environ.get("REGRESS_SEEDS", "0")) + 1))


def points() -> list[tuple[int, Case]]:
    """(seed, case) of every point to run: CI's slice, or every case of every seed."""
    if os.environ.get("REGRESS_SLICE") and not seeds():
        return [(run_seed(), c) for c in ci_slice(run_seed(), int(os.environ["REGRESS_SLICE"]))]
    return [(s, c) for s in seeds() for c in CASES]


def _build(kb: KernelBuild) -> None:
    """Build (or find up to date) under a lock: xdist workers share the build directories."""
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / f"{kb.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        build_kernel(kb)


PARAMS = [pytest.param(s, c, id=f"s{s}-{c.name}") for s, c in points()]


@pytest.mark.skipif(not PARAMS, reason="make regress SEEDS=N (REGRESS_SEEDS / REGRESS_SEED) or CI's REGRESS_SLICE")
@pytest.mark.parametrize("seed,case", PARAMS or [pytest.param(0, CASES[0], id="unset")])
def test_regress(seed: int, case: Case, tmp_path: Path) -> None:
    _build(KernelBuild(case.fmt, cons_bits=get_preset(case.dma).stream_bits))
    print(check(seed, case, tmp_path, case.scene in SEEDED or not seeds() or seed == seeds()[0]))


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


def test_ci_slice() -> None:
    """CI's slice: as many distinct cases as asked, one of them fp16 or bf16 in frame order, the same for a seed and
    another for another seed; a slice out of range is refused."""
    for seed in (1, 2, 0xA3F9C21):
        cases = ci_slice(seed, 8)
        assert len(set(cases)) == 8 and set(cases) <= set(CASES)
        assert cases[0].fmt is not FP32 and cases[0].schedule == "pybullet"
        assert ci_slice(seed, 8) == cases
    assert ci_slice(1, 8) != ci_slice(2, 8)
    for bad in (0, len(CASES) + 1):
        with pytest.raises(ValueError, match="a slice of 1 to"):
            ci_slice(1, bad)
