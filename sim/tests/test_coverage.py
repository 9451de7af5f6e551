"""The coverage.dat parser and summary of `make coverage` (sim/coverage/) on a small canned file (Verilator's
SystemC::Coverage-3 format: two instances of one module, a second file, a point outside rtl/), the bit editing
of the harness's input files and the bad-input edits against the catalogue; the coverage run itself is
`make coverage` (not in `make test`: an instrumented kernel build per configuration)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from models.bad_input import CATALOGUE
from models.dma_model import get_preset
from models.number_format import FP32
from sim.coverage import cases, configurations, data, input_edits, report, runs, waivers
from sim.kernel_build import KernelBuild

CANNED = Path(__file__).resolve().parent / "data" / "coverage_canned.dat"


def test_parse_fields() -> None:
    points = data.parse(CANNED.read_text())
    assert len(points) == 12
    p = points[0]
    assert (p.file, p.line, p.column, p.kind, p.comment, p.module, p.hier, p.count) == \
        ("/repo/rtl/a.sv", 5, 3, "line", "block", "a", "TOP.k.u0", 40)
    assert points[2].is_branch and not points[0].is_branch
    assert points[10].kind == "toggle"  # no t field: the type comes from the page (v_toggle/b)


def test_summary_merges_instances_and_lists_uncovered() -> None:
    """A point is covered when any instance hit it (the `if` at a.sv:6); only rtl/ files are counted."""
    summary = report.summarize(data.merge(data.parse(CANNED.read_text())), root=Path("/repo"))
    rows = {r.file: r for r in summary.rows}
    assert list(rows) == ["rtl/a.sv", "rtl/sub/b.sv"]
    a, b = rows["rtl/a.sv"], rows["rtl/sub/b.sv"]
    assert (a.line, a.branch, a.toggle) == ([2, 3], [1, 2], [1, 2])
    assert (b.line, b.branch, b.toggle) == ([1, 2], [1, 1], [1, 1])
    assert (summary.total.line, summary.total.branch, summary.total.toggle) == ([3, 5], [2, 3], [2, 3])
    assert summary.uncovered == [("rtl/a.sv", 7, "else"), ("rtl/sub/b.sv", 4, "block")]
    assert summary.toggles == {("rtl/a.sv", "q"): 1}
    js = summary.to_json()
    assert js["total"]["line"] == {"covered": 3, "total": 5, "percent": 60.0}
    assert js["uncovered_lines"] == ["rtl/a.sv:7: else", "rtl/sub/b.sv:4: block"]
    md = "\n".join(report.configuration_markdown("canned", summary, root=Path("/repo")))
    assert "| rtl/a.sv | 66.7% (2/3) | 50.0% (1/2) | 50.0% (1/2) |" in md and "`rtl/sub/b.sv:4` (block)" in md
    assert "NOT covered, not waived" in md and not summary.waived


def test_waiver_follows_the_source_line(tmp_path: Path) -> None:
    """A waiver names its line by text: it waives the uncovered point on that line wherever the line is, and the
    figure with waivers counts it; the measured line figure does not change."""
    (tmp_path / "rtl" / "sub").mkdir(parents=True)
    (tmp_path / "rtl" / "a.sv").write_text("\n" * 6 + "    else x <= 0;  // seven\n")
    (tmp_path / "rtl" / "sub" / "b.sv").write_text("\n\n\nfoo;\n")
    text = CANNED.read_text().replace("/repo/", f"{tmp_path}/")
    w = waivers.Waiver("rtl/a.sv", "else x <= 0;", "unreachable")
    summary = report.summarize(data.merge(data.parse(text)), root=tmp_path, waivers=[w])
    assert summary.waived == {("rtl/a.sv", 7, "else"): w}
    assert summary.total.line == [3, 5] and summary.line_with_waivers == [4, 5]
    (tmp_path / "rtl" / "a.sv").write_text("\n\n    else x <= 0;\n" + "\n" * 3 + "    x <= 1;\n")
    moved = report.summarize(data.merge(data.parse(text)), root=tmp_path, waivers=[w])
    assert not moved.waived and moved.line_with_waivers == [3, 5]  # line 7 is another statement now


def test_each_configuration_has_a_build_and_runs() -> None:
    """Every configuration builds apart (its own Verilator parameter set), has runs of its own, and each run's DMA
    model streams the configuration's beat; shared runs count for the configurations of their format."""
    builds = [c.build() for c in configurations.CONFIGURATIONS]
    assert len(set(builds)) == len(builds) == len({b.name for b in builds})
    by_config = {c.name: [k for k in cases.CASES if k.config == c.name] for c in configurations.CONFIGURATIONS}
    assert all(len(runs) >= 5 for runs in by_config.values()), {k: len(v) for k, v in by_config.items()}
    assert len({k.label for k in cases.CASES}) == len(cases.CASES)
    for case in cases.CASES:
        assert get_preset(case.dma).stream_bits == case.configuration.build().cons_bits, case.label
    window = configurations.BY_NAME["window-fp16-l4"]
    assert (window.build().window, window.build().lanes, window.build().body_in_bits) == (16384, 4, 512)
    fp16_shared = [s.label for s in [cases.REGISTER_CASE, *cases.FP_OPERATOR_CASES] if s.counts_for(window)]
    assert fp16_shared == ["pgs_control_s_axi-register-test", "fp-operators-fp16"]


def test_counts_merge_across_runs() -> None:
    once = data.parse(CANNED.read_text())
    merged = data.merge(once + once)
    assert merged[("/repo/rtl/a.sv", 5, 3, "line", "block")] == 84


def test_bit_editing_of_harness_records(tmp_path: Path) -> None:
    """The bad-input edits write fields at their bit offsets of a record spread over beats."""
    rows = np.zeros((2, 4), np.uint8)  # one record of two 32-bit beats
    input_edits.set_bits(rows, 28, 8, 0xAB)  # straddles the beats
    assert int.from_bytes(rows.tobytes(), "little") == 0xAB << 28
    kb = KernelBuild(FP32)
    assert input_edits.nonfinite_bits(kb) == 0x7F800001
    assert input_edits.nonfinite_bits(kb, sign=1, payload=0) == 0xFF800000


def test_bad_input_edits_make_the_catalogue() -> None:
    """Every catalogue case the harness can make is made by exactly one edit, each a run of the regression."""
    made = [name for e in input_edits.BAD_INPUT_EDITS for name in e.cases]
    assert sorted(made) == sorted(c.name for c in CATALOGUE if c.harness)
    labels = {c.label for c in cases.CASES}
    assert all(f"stream-fp32-stack-bad-{e.name}" in labels for e in input_edits.BAD_INPUT_EDITS)
    assert all(f"window-fp32-l2-pile-bad-{e.name}" in labels for e in input_edits.WINDOW_BAD_INPUT_EDITS)


def _own_runs(config: configurations.Configuration) -> list[runs.CaseResult]:
    return [runs.CaseResult(c, Path("coverage.dat"), 1.0) for c in cases.CASES_OF[config.name]]


def test_configuration_without_its_own_runs_is_incomplete() -> None:
    """Figures from the shared runs alone (or with a failed run of its own) never read as a met goal."""
    config = configurations.BY_NAME["window-fp32-l2"]
    full = report.Summary([], report.Row("total", [10, 10], [1, 1], [10, 10]), [])
    low = report.Summary([], report.Row("total", [10, 10], [1, 1], [8, 10]), [])
    shared = runs.CaseResult(cases.REGISTER_CASE, Path("coverage.dat"), 1.0)
    own = _own_runs(config)
    assert report.verdict(full, config, [shared]).startswith("INCOMPLETE")
    assert report.verdict(full, config, [shared, *own]) == "met"
    assert report.verdict(low, config, [shared, *own]) == "MISSED"
    own[0] = runs.CaseResult(own[0].case, None, 1.0, error="harness exit 1")
    assert report.verdict(full, config, [shared, *own]) == f"INCOMPLETE ({len(own)} of {len(own) + 1} runs)"
