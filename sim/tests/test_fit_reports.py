"""The two report commands of the fp32 records design on a small scene: the body banks per count
(sim.studies.body_banks_report) and the tangent basis derived on chip (sim.studies.tangent_basis_report)."""

from __future__ import annotations

import pytest

from sim.studies import body_banks_report
from sim.studies import tangent_basis_report


def _rows(out: str) -> list[list[str]]:
    return [[c.strip() for c in line.strip("|").split("|")] for line in out.splitlines()
            if line.startswith("| ") and not line.startswith("| body banks") and not line.startswith("| tangent")]


def test_body_banks_report(capsys: pytest.CaptureFixture[str]) -> None:
    assert body_banks_report.main(["--scene", "stack", "--banks", "0,1,2"]) == 0
    rows = _rows(capsys.readouterr().out)
    assert [r[0] for r in rows] == ["0", "1", "2"] and rows[0][3] == "0"
    assert int(rows[1][1].replace(",", "")) >= int(rows[0][1].replace(",", ""))  # one bank never beats the LVT
    assert body_banks_report.main(["--scene", "stack", "--banks", "3"]) == 2


def test_tangent_basis_report(capsys: pytest.CaptureFixture[str]) -> None:
    assert tangent_basis_report.main(["--scene", "stack", "--shared-datapath", "0"]) == 0
    rows = _rows(capsys.readouterr().out)
    assert rows[0][0] == "in the record" and rows[0][2] == "704 (2)" and rows[1][2] == rows[2][2] == "512 (1)"
    assert int(rows[2][1]) > int(rows[1][1]) == int(rows[0][1])  # the deeper friction pipe: a wider window
    assert rows[3][0].startswith("the tangents' rounding alone")
    # one datapath per lane binds the deeper friction pass within the contact latency: every row the same window
    assert tangent_basis_report.main(["--scene", "stack"]) == 0
    shared = _rows(capsys.readouterr().out)
    assert int(shared[2][1]) == int(shared[1][1]) == int(shared[0][1]) == 179 + 2  # 179 cycles, one-beat records
