"""``python -m sim.remedies.soft_rtl_loop``: a hard case's soft closed loop with the warm-up on the golden model and the
measured steps on the RTL's soft contact build (the build of ``cocotb_tests/test_kernel_soft_contact.py``)."""

from __future__ import annotations

from pathlib import Path

import pytest

from sim.remedies.soft_rtl_loop import main, run_remedy


def test_measured_steps_run_on_the_rtl(tmp_path: Path) -> None:
    row = run_remedy("incline20", "warm1+soft15z1+sub2+relax", "fp32", 4, 1, tmp_path)
    assert row["kernel calls on the RTL"] == 4 and row["soft calls"] == 2  # 2 substeps x (solve, relax), 1 step
    assert row["differing bits"] == 0 and row["final state equal to the golden loop's"] is True
    assert row["calls where RTL and model cycles differ"] == 0
    assert row["RTL cycles per measured step"] == row["model cycles per measured step"] > 0


def test_bad_arguments_are_refused(tmp_path: Path) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--remedies", "hot", "--out", str(tmp_path)])
    assert exc.value.code == 2
    with pytest.raises(SystemExit):
        main(["--steps", "0", "--out", str(tmp_path)])
    assert not any(tmp_path.iterdir())
