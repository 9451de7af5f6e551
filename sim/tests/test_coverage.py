"""The coverage.dat parser and summary of `make coverage` (sim/coverage/) on a small canned file (Verilator's
SystemC::Coverage-3 format: two instances of one module, a second file, a point outside rtl/), the bit editing
of the harness's input files and the bad-input edits against the catalogue; the coverage run itself is
`make coverage` (not in `make test`: an instrumented kernel build per configuration)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from models import scenes
from models.kernel.bad_input import CATALOGUE
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.formats.number_format import FP32
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from sim.coverage import build, cases, configurations, data, input_edits, report, runs, waivers
from sim.compile.kernel_build import KernelBuild
from sim.compile.verilator_build import REPO_ROOT

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
    banks = {c.name: c.build().body_banks for c in configurations.CONFIGURATIONS if c.impulses_in_records}
    assert banks == {"stream-fp16-records": 0, "stream-fp16-records-b256": 0, "stream-fp32-records": 2, "stream-fp32-records-tangents": 2,
                     "stream-fp32-records-tangents-b256": 2, "stream-fp32-soft": 2, "window-fp32-records": 8,
                     "window-fp16-records-l2": 16}  # the builds make sim runs
    delay = {c.name: c.build().delay_block_min_depth for c in configurations.CONFIGURATIONS}
    # (the one-lane window kernel's lines in LUT RAM: its shared datapath leaves the LUTs to hold them; with lanes
    # and the impulses in the records the LUTs bind, and the lines from 129 deep are in block RAM)
    lanes = {c.name: 129 for c in configurations.CONFIGURATIONS if c.lanes > 1 and c.impulses_in_records}
    assert {n: d for n, d in delay.items() if d} == {n: 65 for n in banks if banks[n] == 2} | lanes
    assert set(lanes) == {"window-fp16-records-l2"}
    assert all(c.build().shared_datapath for c in configurations.CONFIGURATIONS)
    window = configurations.BY_NAME["window-fp16-l4"]
    assert (window.build().window, window.build().lanes, window.build().body_in_bits) == (16384, 4, 512)
    fp16_shared = [s.label for s in [cases.REGISTER_CASE, *cases.FP_OPERATOR_CASES] if s.counts_for(window)]
    assert fp16_shared == ["pgs_control_s_axi-register-test", "fp-operators-fp16"]


def test_each_configuration_builds_what_its_runs_need() -> None:
    """The instrumented build of a configuration is the build ``make sim`` makes for its runs' steps
    (``KernelBuild.for_job``): the tangent basis derived on chip, the soft contact pipe and every other parameter,
    so that its coverage is of the kernel its README row runs (the inverse-inertia words are the one parameter a
    configuration sets for itself: the inertia modes run the test scenes on a build of 1 or 6 words); the soft
    build's rigid call keeps the build."""
    stack = scenes.load_or_capture("stack", **KERNEL_TEST_SCENES["stack"])
    rotated = scenes.load_or_capture(*cases.SCENES["rotated"][:1], **cases.SCENES["rotated"][1])
    for c in configurations.CONFIGURATIONS:
        job = c.job(rotated if c.friction_words else stack, SolverParams(4), "sweep" if c.record_window else "hazard")
        made = KernelBuild.for_job(job, get_preset(c.beat_preset), body_bits=c.body_bits)
        assert dataclasses.replace(made, inertia_words=c.inertia_words) == c.build(), c.name
    params = {n: configurations.BY_NAME[n].build().parameters
              for n in ("stream-fp32-records-tangents", "stream-fp32-soft")}
    assert params["stream-fp32-records-tangents"]["TANGENTS_ON_CHIP"] == 1
    assert params["stream-fp32-soft"]["SOFT_CONTACT"] == 1 and "SOFT_CONTACT" not in params[
        "stream-fp32-records-tangents"]
    soft = configurations.BY_NAME["stream-fp32-soft"].job(stack, SolverParams(4), "hazard")
    assert soft.params.soft_keep == configurations.SOFT_KEEP and cases.rigid_call(soft).params.soft_keep is None


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


def test_mass_spread_edit_keeps_good_input(tmp_path: Path) -> None:
    """The mass-spread edit of the records regression: every dynamic body's inverse mass and inertia words scaled
    by a factor in [1/4, 4), distinct per body, positive and finite; the static bodies (inverse mass 0) untouched."""
    from models.kernel.stream_format import BODY_INV_INERTIA, BODY_INV_MASS

    case = next(c for c in cases.CASES if c.label == "stream-fp32-records-pile-mass-spread")
    kb = case.configuration.build()
    plain = dataclasses.replace(case, edit=None, label="plain")
    runs.prepare_case(plain, tmp_path / "plain")
    runs.prepare_case(case, tmp_path / "edited")
    before, after = input_edits.HarnessFiles(tmp_path / "plain", kb), input_edits.HarnessFiles(tmp_path / "edited", kb)
    w = kb.fmt.width

    def value(f: input_edits.HarnessFiles, b: int, word: int) -> float:
        return float(kb.fmt.decode(np.uint64(f.word("body", 0, b, word * w, w))))

    ratios = []
    for b in range(before.reg("num_bodies")):
        for word in (BODY_INV_MASS, BODY_INV_INERTIA, BODY_INV_INERTIA + 2):
            old, new = value(before, b, word), value(after, b, word)
            if old == 0:
                assert new == 0
            else:
                ratios.append(new / old)
    assert ratios and all(0.25 * (1 - 1e-6) <= r <= 4.0 * (1 + 1e-6) for r in ratios)  # within fp32's rounding
    assert len(set(np.round(ratios, 6))) > len(ratios) // 2  # a factor per body and word, not one for all


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


def test_headline_configurations_build_their_parameters() -> None:
    """The fitting headline (impulses in the records, fp16 and fp32) and the Bullet 2 worlds' build (a friction
    coefficient per manifold, 6 inverse-inertia words) are configurations with their own builds, each compiled
    with the coverage profile into its own directory."""
    params = {n: configurations.BY_NAME[n].build().parameters
              for n in ("stream-fp16-records", "stream-fp32-records", "stream-fp32-mu")}
    assert params["stream-fp16-records"]["IMPULSES_IN_RECORDS"] == 1 and params["stream-fp16-records"]["MAN_BITS"] == 10
    assert params["stream-fp32-records"]["IMPULSES_IN_RECORDS"] == 1 and params["stream-fp32-records"]["MAN_BITS"] == 23
    assert (params["stream-fp32-mu"]["MU_W"], params["stream-fp32-mu"]["IINV_W"]) == (1, 6)
    assert "IMPULSES_IN_RECORDS" not in configurations.BY_NAME["stream-fp32"].build().parameters
    kb = build.coverage_kernel_build(configurations.BY_NAME["stream-fp16-records"].build())
    assert kb.compile_profile == build.COVERAGE_COMPILE_PROFILE and kb.name.endswith("_ir")
    assert build.coverage_kernel_build(kb, "o0").name.endswith("_ir_o0")
    labels = {c.label for c in cases.CASES_OF["stream-fp16-records"]}
    assert {"stream-fp16-records-pile-hazard-zcu102-warm", "stream-fp16-records-stack-independent-zcu102",
            "stream-fp16-records-pile-hazard-zcu102-interleaved-warm-stalls"} <= labels
    assert all(f"stream-fp16-records-stack-bad-{e.name}" in labels for e in input_edits.RECORDS_BAD_INPUT_EDITS)
    assert "stream-fp16-records-stack-bad-tlast_late" not in labels


def test_records_cases_write_the_impulse_plan_and_the_warm_start(tmp_path: Path) -> None:
    """A records case writes the impulse plan the harness's DMA model follows and reads with less than the whole
    DDR bandwidth; the warm start puts other impulse words into the records than the cold start (zeros); the
    independent manifolds name one body each."""
    by_label = {c.label: c for c in cases.CASES_OF["stream-fp16-records"]}
    cold = runs.prepare_case(by_label["stream-fp16-records-pile-hazard-zcu102"], tmp_path / "cold")
    runs.prepare_case(by_label["stream-fp16-records-pile-hazard-zcu102-warm"], tmp_path / "warm")
    assert (tmp_path / "cold" / "impulse_plan.bin").stat().st_size > 0 and 0.5 < cold.read_share < 1.0
    assert (tmp_path / "cold" / "cons.bin").read_bytes() != (tmp_path / "warm" / "cons.bin").read_bytes()
    job = configurations.BY_NAME["stream-fp16-records"].job(
        scenes.load_or_capture("stack", **KERNEL_TEST_SCENES["stack"]), SolverParams(4), "hazard")
    ind = cases.independent_manifolds(job)
    assert len(set(ind.cons.body_b.tolist())) == ind.cons.num_manifolds and not ind.cons.body_a.any()
    warm = cases.warm_start(job)
    assert warm.initial is not None and (warm.initial.normal >= 0).all() and warm.initial.normal.any()


def test_friction_coefficient_words_follow_the_build(tmp_path: Path) -> None:
    """A scene with a coefficient per manifold runs on a MU_W = 0 build with the kernel's one coefficient; the
    MU_W = 1 build refuses a scene without one (a clear error, no inputs written)."""
    rotated = scenes.load_or_capture(*cases.SCENES["rotated"][:1], **cases.SCENES["rotated"][1])
    assert configurations.BY_NAME["stream-fp32-mu"].job(rotated, SolverParams(4), "hazard").friction_words == 1
    assert configurations.BY_NAME["stream-fp32-inertia6"].job(rotated, SolverParams(4), "hazard").friction_words == 0
    stack = scenes.load_or_capture("stack", **KERNEL_TEST_SCENES["stack"])
    with pytest.raises(ValueError, match="MU_W = 1"):
        configurations.BY_NAME["stream-fp32-mu"].job(stack, SolverParams(4), "hazard")


def test_every_waiver_names_a_line_the_rtl_has() -> None:
    """Each waiver's text starts a line of its file (a waiver whose line was rewritten would waive nothing and
    leave its point counted as uncovered)."""
    for w in waivers.WAIVERS:
        lines = (REPO_ROOT / w.file).read_text().splitlines()
        assert any(w.matches(w.file, line) for line in lines), (w.file, w.source)


def test_waivers_of_a_parameter_set_hold_only_for_it() -> None:
    """A loop with no iteration in one parameter set (the lane-collision loop with one lane, the bank-port check's
    without lanes or banks) is waived there only: the builds that run it must cover it."""
    def sources(name: str) -> set[str]:
        return {w.source for w in waivers.waivers_for(configurations.BY_NAME[name])}
    lanes_loop = "for (int k = 0; k < l; k++) begin"
    bank_loop = "for (int k = 0; k < l; k++) begin   // the earlier issuing lanes' reads"
    assert {lanes_loop, bank_loop} <= sources("stream-fp16-records")
    assert lanes_loop not in sources("window-fp32-l2") and bank_loop in sources("window-fp32-l2")
    assert lanes_loop not in sources("window-fp16-records-l2") and bank_loop not in sources("window-fp16-records-l2")
    assert len(sources("stream-fp32")) == len(waivers.WAIVERS)


def test_toggle_waiver_sets_a_signal_aside() -> None:
    """A toggle waiver names a signal of a file: its uncovered points count in the figure with waivers (and the
    goal), never in the measured one; a signal it does not name stays uncovered."""
    merged = data.merge(data.parse(CANNED.read_text()))
    plain = report.summarize(merged, root=Path("/repo"), toggle_waivers=())
    w = waivers.ToggleWaiver("rtl/a.sv", "q", "constant")
    waived = report.summarize(merged, root=Path("/repo"), toggle_waivers=[w])
    assert plain.total.toggle == waived.total.toggle == [2, 3]
    assert plain.toggle_with_waivers == [2, 3] and waived.toggle_with_waivers == [3, 3]
    other = report.summarize(merged, root=Path("/repo"), toggle_waivers=[waivers.ToggleWaiver("rtl/a.sv", "p", "x")])
    assert other.toggle_with_waivers == [2, 3] and not other.toggle_waived


def test_records_edits_keep_the_stream_and_the_arguments(tmp_path: Path) -> None:
    """The moved TLAST keeps every beat (the harness's impulse plan pairs records with slots and passes) and moves
    pass 0's TLAST onto pass 1's first record; the argument-bits edit ends with the run's own argument writes."""
    case = next(c for c in cases.CASES_OF["stream-fp16-records"] if c.label.endswith("bad-zero_bodies"))
    runs.prepare_case(case, tmp_path)  # an edit of the registers only: the constraint stream as written
    kb = case.configuration.build()
    files = input_edits.HarnessFiles(tmp_path, kb)
    data_before, last_before = (a.copy() for a in files.streams["cons"])
    first_of_pass1 = files.record("cons", 1, 0)
    input_edits.edit_tlast_moved(files, kb)
    data_after, last_after = files.streams["cons"]
    assert np.array_equal(data_after, data_before) and last_after.sum() == last_before.sum()
    assert last_before[np.flatnonzero(last_before)[0]] and not last_after[np.flatnonzero(last_before)[0]]
    assert last_after[first_of_pass1[-1]] and np.flatnonzero(last_after)[0] == first_of_pass1[-1]
    own = files.regs.copy()
    input_edits.edit_argument_bits(files, kb)
    values = {}
    for offset, value in files.regs:
        values[int(offset)] = int(value)
    assert all(values[int(o)] == int(v) for o, v in own)
    assert values[input_edits.OFFSET["lag"]] == 0 and len(files.regs) > len(own)


def test_tied_off_impulse_stream_waived_only_where_tied_off() -> None:
    """The impulse-out stream is waived on the on-chip builds and measured on the records builds."""
    def signals(name: str) -> set[str]:
        return {w.signal for w in waivers.toggle_waivers_for(configurations.BY_NAME[name])}
    assert "m_axis_imp_TDATA" in signals("stream-fp32") and "m_axis_imp_TDATA" not in signals("stream-fp16-records")
    assert "stat_cycles" in signals("stream-fp16-records")
