"""The check every C simulation test ends with: the step's comparison with the golden model printed, the first
difference failing the test, every manifold-pass's trace record and every body compared."""

from __future__ import annotations

import pytest

from hls_export.csim import CsimResult
from models.kernel.kernel_job import KernelJob


def assert_bit_exact(res: CsimResult, job: KernelJob, label: str, detail: str = "") -> None:
    """Print ``[label]``, the records, bodies and differing bits compared (then ``detail``); fail on the first
    difference; every manifold-pass and every body must have been compared, 0 differing bits."""
    c = res.comparison
    print(f"\n[{label}] {c.records} trace records, {c.bodies} bodies, {c.differing_bits} differing bits"
          + (f"; {detail}" if detail else ""))
    if c.first_mismatch is not None:
        pytest.fail(c.first_mismatch)
    assert res.bit_exact and c.differing_bits == 0
    assert c.records == job.manifold_passes and c.bodies == job.bodies.num_bodies
