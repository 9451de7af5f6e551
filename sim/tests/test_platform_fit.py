"""sim.studies.platform_fit: a row per built design with the cycle model's cycles (the streaming and the window
kernel's) and the resource model's verdict on the preset's platform; bad options end with status 2."""

from __future__ import annotations

from pathlib import Path

import pytest

from models import scenes
from models.formats.frame import save
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from sim.studies import platform_fit


def _rows(capsys: pytest.CaptureFixture[str], fmt: str) -> dict[str, str]:
    """The table's rows of ``fmt``: design -> the verdict cell (each row is printed as it comes and again)."""
    rows = [line.split("|") for line in capsys.readouterr().out.splitlines() if line.startswith(f"| {fmt} ")]
    assert all(int(r[2].strip().replace(",", "")) > 0 for r in rows)  # streaming and window kernels' cycles
    return {r[1].strip(): r[-2].strip() for r in rows}


def test_table_rows(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Each design's verdict (the Yosys estimate's): on the U280 a ring of 64 records fits in every form; on the ZCU102
    a ring of 16,384 fp32 records fits one lane (the impulses on chip or in the records) and no more (LUT the binding
    resource), the streaming kernel both ways."""
    frame = save(scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"]), tmp_path / "pile.npz")
    assert platform_fit.main(["--frame", str(frame), "--dma", "u280", "--formats", "fp16", "--ring", "64"]) == 0
    rows = _rows(capsys, "fp16")
    designs = ["streaming, impulses on chip", "streaming, impulses in the records",
               *(f"window 64 x{n}{records}" for records in ("", ", impulses in the records") for n in platform_fit.LANES)]
    assert rows == {f"fp16 {d}": "FITS the u280" for d in designs}
    assert platform_fit.main(["--frame", str(frame), "--dma", "zcu102", "--formats", "fp32", "--ring", "16384"]) == 0
    verdicts = {name.removeprefix("fp32 "): v.split(":")[0] + (": " + v.split(": ")[1].split()[0] if ":" in v else "")
                for name, v in _rows(capsys, "fp32").items()}
    assert verdicts == {
        "streaming, impulses on chip": "FITS the zcu102", "streaming, impulses in the records": "FITS the zcu102",
        "window 16,384 x1": "FITS the zcu102", "window 16,384 x2": "DOES NOT FIT the zcu102: LUT",
        # (four lanes' ring heads, 16,384 deep, in block RAM: block RAM is the furthest over at the optimistic end)
        "window 16,384 x4": "DOES NOT FIT the zcu102: BRAM36",
        "window 16,384 x1, impulses in the records": "FITS the zcu102",
        "window 16,384 x2, impulses in the records": "DOES NOT FIT the zcu102: LUT",
        "window 16,384 x4, impulses in the records": "DOES NOT FIT the zcu102: LUT"}


@pytest.mark.parametrize("bad", [["--ring", "3"], ["--iters", "0"], ["--formats", "float64"]])
def test_bad_options(bad: list[str]) -> None:
    assert platform_fit.main(["--scene", "stack", *bad]) == 2
