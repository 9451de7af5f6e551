"""sim.studies.platform_fit: a row per built design with the cycle model's cycles (the streaming and the window
kernel's) and the resource model's verdict on the preset's platform; bad options end with status 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from models import scenes
from models.formats.frame import save
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from sim.studies import platform_fit


def test_table_rows(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    frame = save(scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"]), tmp_path / "pile.npz")
    assert platform_fit.main(["--frame", str(frame), "--dma", "u280", "--formats", "fp16", "--ring", "64"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| fp16 ")]
    rows = list(dict.fromkeys(rows))  # each row is printed as it comes and again in the table
    assert len(rows) == 2 + 2 * len(platform_fit.LANES)  # streaming x2, window lanes, the same with the records
    assert all("FITS the u280" in r for r in rows)
    assert all(int(r.split("|")[2].strip().replace(",", "")) > 0 for r in rows)  # streaming and window kernels
    assert sum("window" in r for r in rows) == 2 * len(platform_fit.LANES)
    assert sum("window 64 x1, impulses in the records" in r for r in rows) == 1


@pytest.mark.parametrize("bad", [["--ring", "3"], ["--iters", "0"], ["--formats", "float64"]])
def test_bad_options(bad: list[str]) -> None:
    assert platform_fit.main(["--scene", "stack", *bad]) == 2
