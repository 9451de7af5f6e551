"""The resource model: memories mapped with the copies their ports need, delay lines, the per-operator sum of a
pipe, the verdict against a platform, and the fit lines of a run."""

from __future__ import annotations

import dataclasses
import math

import pytest

from models.formats.number_format import FP16, FP32
from sim.fit import resource_model as rm
from sim.report.run_result import FIT_SECTION, ModelRunResult, sections
from models.timing import platforms

ZCU102, U280 = platforms.get_platform("zcu102"), platforms.get_platform("u280")
THESIS = (38_881, 147_485)


def test_true_dual_port_serves_two_reads_and_lvt_banks_grow_with_ports() -> None:
    one = rm.memories(rm.KernelConfig(FP32, 1024, 1024))
    four = rm.memories(rm.KernelConfig(FP32, 1024, 1024, lanes=4, window=1024))
    assert (one[0].copies, one[0].true_dual_port, one[1].copies) == (1, True, 4)
    assert (four[0].copies, four[1].copies) == (4, 64)  # 8 read ports: 4 TDP copies; 8W8R: 64 banks
    banked = rm.memories(rm.KernelConfig(FP32, 1024, 1024, lanes=4, window=1024, body_ports="banked", body_banks=8))
    assert banked[1].copies == 8 and banked[1].depth == 128 and banked[1].true_dual_port  # one copy in 8 banks
    # a true dual-port block is at most 36 bits wide: 1K x 72 takes two RAMB36, simple dual-port one
    assert rm.bram36_for(512, 72) == 1 and rm.bram36_for(512, 72, true_dual_port=True) == 2
    assert rm.bram36_for(1024, 72) == 2 and rm.bram36_for(1024, 72, true_dual_port=True) == 2
    assert rm.bram36_for(1024, 36, true_dual_port=True) == 1 and rm.bram36_for(1024, 18, true_dual_port=True) == 0.5


def test_levers_shrink_the_memories() -> None:
    base = rm.KernelConfig(FP32, *THESIS, window=16384)
    lean = rm.KernelConfig(FP32, *THESIS, window=16384, impulses_resident=False, body_words="solve")

    def bram(cfg: rm.KernelConfig) -> float:
        return sum(m.resources().bram36 for m in rm.memories(cfg))

    names = [m.name for m in rm.memories(lean)]
    assert not any("impulses lam" in n for n in names) and any("impulse ring" in n for n in names)  # in the ring
    assert bram(lean) < bram(base)


def test_window_rings() -> None:
    """The window kernel's rings (rtl/pgs_ring_ram.sv): the records' words in block RAM (a fetch of the records
    design streams one kind: the contact record with lam[4], 27 words; on-chip impulses: both kinds' 37), their
    heads in block RAM (two 16-bit body indices for the thesis's bodies and 6 flag bits per lane), the impulse ring
    (4 words per lane) with the impulses in the records."""
    by_name = lambda cfg: {m.name.split(" (")[0]: m for m in rm.memories(cfg)}  # noqa: E731
    records = by_name(rm.KernelConfig(FP16, *THESIS, lanes=2, window=8192, impulses_resident=False))
    resident = by_name(rm.KernelConfig(FP16, *THESIS, lanes=2, window=8192))
    assert records["record ring"].width == 2 * 27 * 16 and resident["record ring"].width == 2 * 37 * 16
    heads = records["record ring heads"]
    assert not heads.distributed and heads.width == 2 * (2 * 16 + 6) and heads.depth == 8192
    assert heads.resources().lut == 0 and heads.resources().bram36 == rm.bram36_for(8192, 76) == 18  # 4K x 9 each
    # a bit per slot (of each lane): read as a record is written (block RAM) with the impulses in the records, at the
    # offered slot (LUT RAM, RAM64X1D: 2 LUTs per 64 bits and a mux) with the impulses on chip
    flags, resident_flags = records["rejected-slot flags"], resident["rejected-slot flags"]
    assert (flags.depth, flags.width, flags.copies) == (-(-THESIS[1] // 2), 1, 2) and flags.resources().lut == 0
    assert resident_flags.resources().lut == 2 * (2 * 1153 + 384) and resident_flags.resources().bram36 == 0
    assert (records["impulse ring"].width, records["impulse ring"].copies) == (64, 2) and "impulse ring" not in resident
    # the control of the window kernel: Yosys's run of it (with the impulses in the records) where there is one
    part = rm.control_resources(rm.KernelConfig(FP32, *THESIS, window=8192, impulses_resident=False), rm.figures())
    assert "window kernel's control" in part.source


def test_uram_takes_the_deep_arrays_where_the_platform_has_it() -> None:
    cfg = rm.KernelConfig(FP32, *THESIS)
    on_u280, on_zcu = rm.estimate(cfg, U280).total, rm.estimate(cfg, ZCU102).total
    assert on_zcu.uram == 0 and on_u280.uram > 0 and on_u280.bram36 < on_zcu.bram36
    assert rm.uram_for(4096, 72) == 1 and rm.uram_for(4097, 73) == 4


def test_delay_lines() -> None:
    assert rm.delay_line_resources(rm.DelayLine(0, 3, (1, 3)), 32) == rm.Resources(ff=96)  # shift register
    short = rm.delay_line_resources(rm.DelayLine(0, 20, (20,)), 16)  # 16 bit-reads: two RAM32M16
    assert short.lut == 16 + 5 and short.ff == 16 + 5
    deep = rm.delay_line_resources(rm.DelayLine(0, 137, (4, 53, 137)), 32)  # 3 taps of 32 bits, 3 x 64 deep
    assert deep.lut == 8 * 3 * math.ceil(96 / 7) + 96 * 1 + 8 and deep.ff == 96 + 8


def test_delay_lines_in_block_ram() -> None:
    """From the build's DELAY_BLOCK_MIN_DEPTH on, a RAM line is one simple dual-port block RAM array per tap of delay
    >= 2 (the array's output latch is the tap's register) and no LUT RAM; shallower lines and shift registers are
    as before."""
    line = rm.DelayLine(0, 137, (1, 53, 137))
    assert rm.delay_line_resources(line, 32, 65) == rm.Resources(lut=8, ff=32 + 8, bram36=2 * 0.5)  # 2 RAMB18
    assert rm.delay_line_resources(rm.DelayLine(64, 137, (137,)), 32, 65).bram36 == 1  # 512 x 72: one RAMB36
    assert rm.delay_line_resources(line, 32, 138) == rm.delay_line_resources(line, 32)
    assert rm.delay_line_resources(rm.DelayLine(0, 3, (3,)), 32, 4) == rm.Resources(ff=96)
    with pytest.raises(ValueError, match="at least 4"):
        rm.KernelConfig(FP32, 1, 1, delay_block_min_depth=3)


def test_the_records_design_keeps_its_long_delay_lines_in_block_ram() -> None:
    """The fp32 records design's build puts its delay lines from 65 deep in block RAM (models/kernel/delay_lines.py),
    the estimate counts them there, and with the tangent basis derived on chip that is what makes it fit the zcu102
    (87.6% of the LUTs with every line in LUT RAM); the fp16 records design keeps them in LUT RAM."""
    from models.kernel.delay_lines import BLOCK_MIN_DEPTH
    from models.timing.platforms import get_preset
    from models.tests.test_body_banks import pile_job
    from sim.compile.kernel_build import KernelBuild

    job = pile_job().tangents_derived()
    assert job.delay_block_min_depth == BLOCK_MIN_DEPTH == rm.config_for_job(job).delay_block_min_depth
    kb = KernelBuild.for_job(job, get_preset("zcu102"))
    assert kb.parameters["DELAY_BLOCK_MIN_DEPTH"] == BLOCK_MIN_DEPTH and kb.name.endswith(f"_dl{BLOCK_MIN_DEPTH}")
    fp16 = dataclasses.replace(pile_job(), fmt=FP16)
    assert fp16.delay_block_min_depth == 0 and "DELAY_BLOCK_MIN_DEPTH" not in KernelBuild.for_job(
        fp16, get_preset("zcu102")).parameters
    lutram = rm.KernelConfig(FP32, *THESIS, impulses_resident=False, body_ports="banked", body_banks=2,
                             tangents_on_chip=True, shared_datapath=False)
    block = dataclasses.replace(lutram, delay_block_min_depth=BLOCK_MIN_DEPTH)
    v0, v1 = rm.fit(lutram, ZCU102), rm.fit(block, ZCU102)
    assert not v0.fits and v0.overflows == ["LUT"]
    assert v1.fits and v1.shares["LUT"] < v0.shares["LUT"] - 0.05 and v1.shares["BRAM36"] > v0.shares["BRAM36"]
    assert "delay lines from 65 deep in block RAM" in v1.config
    # the shared datapath (one per lane, the build's default) fits with every line in LUT RAM too
    shared = rm.fit(dataclasses.replace(lutram, shared_datapath=True), ZCU102)
    assert shared.fits and shared.shares["LUT"] < v0.shares["LUT"] - 0.04


def test_control_of_the_body_stream_width() -> None:
    """The control's figure is Yosys's of the build's body-stream width (BODY_BITS=256 has its own run); a width no
    run has takes the 128-bit one and says so."""
    data = rm.figures()
    base = rm.KernelConfig(FP32, *THESIS, impulses_resident=False, body_ports="banked", body_banks=2)
    parts = {b: rm.control_resources(dataclasses.replace(base, body_bits=b), data) for b in (128, 256, 512)}
    assert parts[128].resources == rm.Resources.from_dict(data["units"]["fp32"]["control"])
    assert parts[256].resources == rm.Resources.from_dict(data["units"]["fp32"]["control_b256"])
    assert parts[256].source == "Yosys" and parts[256].resources != parts[128].resources
    assert parts[512].resources == parts[128].resources and "128-bit body streams (none of 512" in parts[512].source
    assert "256-bit body streams" in dataclasses.replace(base, body_bits=256).describe()


def test_pipe_shapes_follow_the_generator() -> None:
    contact = rm.pipe_shape("pgs_contact_pipe", FP32.man_bits)
    assert contact.operators == {"fp_add": 152, "fp_mul": 178, "fp_minmax": 4} and contact.latency == 179
    integ16, integ32 = (rm.pipe_shape("pgs_integrate_pipe", f.man_bits) for f in (FP16, FP32))
    assert integ32.latency - integ16.latency == 4 * (FP32.man_bits - FP16.man_bits)


def test_the_shared_datapath_counts_its_operators_once() -> None:
    """A lane's shared datapath (rtl/gen/shared_datapath.py): its operators are the contact pipe's and the few the
    friction pass needs of its own, its delay lines one per source, its multiplexers a LUT per bit; per lane it costs
    well under the two pipes (LUT and DSP), at the contact pipe's latency. The thesis frame's fitting designs with it,
    their lines in LUT RAM: below the two pipes' LUT and block RAM."""
    from rtl.gen.kernel_graphs import SHARED_GRAPHS

    shared = rm.pipe_shape("pgs_shared_pipe", FP32.man_bits)
    contact, friction = (rm.pipe_shape(n, FP32.man_bits) for n in ("pgs_contact_pipe", "pgs_friction_pipe"))
    stats = SHARED_GRAPHS["pgs_shared_pipe"]().stats(FP32.man_bits)
    assert shared.latency == contact.latency == 179 and shared.kind_stages == 179
    assert shared.operators == {m: stats[m] for m in ("fp_add", "fp_minmax", "fp_mul")}
    assert all(contact.operators[m] <= n < contact.operators[m] + friction.operators[m]
               for m, n in shared.operators.items())
    assert shared.muxes == stats["operand_muxes"] + stats["output_muxes"] > 0
    cfg = rm.KernelConfig(FP32, 0, 0)
    one, _ = rm.pipe_resources("pgs_shared_pipe", cfg, rm.figures())
    two = rm.pipe_resources("pgs_contact_pipe", cfg, rm.figures())[0] + rm.pipe_resources("pgs_friction_pipe", cfg,
                                                                                         rm.figures())[0]
    assert one.lut < 0.85 * two.lut and one.dsp < 0.7 * two.dsp
    assert rm.lane_pipes(dataclasses.replace(cfg, lanes=1)) == [("pgs_shared_pipe", 1)]
    assert rm.lane_pipes(dataclasses.replace(cfg, shared_datapath=False)) == [("pgs_contact_pipe", 1),
                                                                              ("pgs_friction_pipe", 1)]
    for fmt, lanes in ((FP32, 1), (FP16, 2)):
        window = rm.KernelConfig(fmt, *THESIS, lanes=lanes, window=8192, impulses_resident=False, body_ports="banked",
                                 body_banks=8 * lanes, body_bits=256)
        old = rm.fit(dataclasses.replace(window, shared_datapath=False, delay_block_min_depth=129), ZCU102)
        new = rm.fit(window, ZCU102)
        assert new.fits and new.shares["LUT"] < old.shares["LUT"] - 0.05 and new.shares["BRAM36"] < old.shares["BRAM36"]
        assert "one datapath per lane" in new.config


def test_per_operator_sum_uses_the_committed_figures_and_vendor_where_published() -> None:
    data = rm.figures()
    cfg = rm.KernelConfig(FP32, 0, 0)
    yosys, sources = rm.pipe_resources("pgs_contact_pipe", cfg, data)
    add = rm.operator_figure("fp_add", FP32, data=data).resources
    mul = rm.operator_figure("fp_mul", FP32, data=data).resources
    assert yosys.dsp == 152 * add.dsp + 178 * mul.dsp + 4 * rm.operator_figure("fp_minmax", FP32, data=data).resources.dsp
    assert any(s.startswith("152 fp_add (Yosys)") for s in sources)
    vendor, vsources = rm.pipe_resources("pgs_contact_pipe", rm.KernelConfig(FP32, 0, 0, operator_source="vendor"),
                                         data)
    # the published forms: fadd full_dsp (2 DSP48E2) for each adder, fmul max_dsp (3) for each multiplier
    assert vendor.dsp - yosys.dsp == 152 * (2 - add.dsp) + 178 * (3 - mul.dsp)
    assert any("fadd full_dsp" in s for s in vsources) and any("178 fp_mul (fmul max_dsp" in s for s in vsources)
    with pytest.raises(KeyError, match="e6m9"):
        rm.operator_figure("fp_add", rm.NumberFormat("e6m9", 6, 9), data=data)


def test_verdicts_of_the_thesis_frame() -> None:
    stream32 = rm.fit(rm.KernelConfig(FP32, *THESIS), ZCU102)
    assert not stream32.fits and stream32.overflows[0] == "BRAM36" and stream32.shares["BRAM36"] > 1
    assert "DOES NOT FIT the zcu102: BRAM36" in stream32.headline()
    tiny = rm.fit(rm.KernelConfig(FP16, 217, 635), ZCU102)
    assert tiny.fits and tiny.headline() == "FITS the zcu102" and all(tiny.shares[k] < 0.85 for k in rm.KEYS)
    assert rm.fit(rm.KernelConfig(FP32, *THESIS), U280).fits


def test_bad_configurations() -> None:
    with pytest.raises(ValueError, match="power of two"):
        rm.KernelConfig(FP32, 1, 1, lanes=3, window=16)
    with pytest.raises(ValueError, match="window kernel"):
        rm.KernelConfig(FP32, 1, 1, lanes=2)
    with pytest.raises(ValueError, match="body_words"):
        rm.KernelConfig(FP32, 1, 1, body_words="some")


def test_fit_section_of_a_run() -> None:
    v = rm.fit(rm.KernelConfig(FP32, *THESIS), ZCU102)
    result = ModelRunResult("r", "thesis", THESIS[0], THESIS[1], "hazard", "zcu102", {}, fit=v)
    rows = sections(result)[FIT_SECTION]
    assert rows["configuration"].startswith("fp32, streaming kernel, 38,881 bodies")
    assert any(val.startswith("DOES NOT FIT") for val in rows.values())
    assert "BRAM36" in rows["LUT, FF, DSP, BRAM36, URAM (share of the device)"]
    none = sections(ModelRunResult("r", "x", 1, 1, "hazard", "ideal", {}, fit=rm.NoEstimate("no platform")))
    assert none[FIT_SECTION] == {"verdict": "no estimate (no platform)"}


def test_redesign_table(capsys: pytest.CaptureFixture[str]) -> None:
    from sim.studies import redesign_fit

    assert redesign_fit.main(["--formats", "fp16", "--platform", "u280"]) == 0
    out = capsys.readouterr().out
    assert "fitting designs, fastest floor first" in out and "| fp16 | window x4 |" in out
    assert redesign_fit.main(["--formats", "fp64"]) == 2


def test_banked_body_velocities_of_the_records_design() -> None:
    """One lane, banked: one copy of the velocities in true dual-port banks (rtl/pgs_body_vel_banks.sv) and their
    multiplexers; the thesis frame's fp32 records design then fits the zcu102 where the live-value table does not."""
    banked = rm.KernelConfig(FP32, 38_881, 1, impulses_resident=False, body_ports="banked", body_banks=2)
    vel = rm.memories(banked)[1]
    assert (vel.copies, vel.depth, vel.width, vel.true_dual_port) == (2, 19_441, 192, True)
    assert vel.resources().bram36 == 2 * 19 * 11 * 0.5  # per bank 19 x 11 RAMB18 of 1K x 18 (true dual-port)
    est = rm.estimate(banked, ZCU102)
    assert any(p.name.startswith("body bank port multiplexers") and p.resources.lut > 0 for p in est.parts)
    lvt = rm.fit(rm.KernelConfig(FP32, *THESIS, impulses_resident=False), ZCU102)
    fits = rm.fit(rm.KernelConfig(FP32, *THESIS, impulses_resident=False, body_ports="banked", body_banks=2), ZCU102)
    assert not lvt.fits and lvt.overflows[0] == "BRAM36"
    assert fits.fits and fits.shares["BRAM36"] < 0.7 and "2 true dual-port banks" in fits.config
    with pytest.raises(ValueError, match="power of two"):
        rm.KernelConfig(FP32, 1, 1, body_ports="banked", body_banks=3)


def test_tangent_basis_on_chip_in_the_estimate() -> None:
    """The job with the tangents derived on chip: the friction pipe that derives them in the estimate, and the build
    that instantiates it (TANGENTS_ON_CHIP)."""
    from models.timing.platforms import get_preset
    from models.tests.test_body_banks import pile_job
    from sim.compile.kernel_build import KernelBuild

    derived = pile_job().tangents_derived()
    cfg = rm.config_for_job(derived)
    assert cfg.tangents_on_chip and "tangent basis derived on chip" in cfg.describe()
    parts = {p.name: p.resources for p in rm.estimate(cfg).parts}
    base = {p.name: p.resources for p in rm.estimate(rm.config_for_job(pile_job())).parts}
    assert parts["pgs_shared_pipe_tb x 1"].lut > base["pgs_shared_pipe x 1"].lut
    two = {p.name: p.resources for p in rm.estimate(dataclasses.replace(cfg, shared_datapath=False)).parts}
    two_base = {p.name: p.resources for p in rm.estimate(rm.config_for_job(pile_job().with_datapath(False))).parts}
    assert two["pgs_friction_pipe_tb x 1"].lut > two_base["pgs_friction_pipe x 1"].lut
    assert KernelBuild.for_job(derived, get_preset("zcu102")).parameters["TANGENTS_ON_CHIP"] == 1


def test_soft_contact_pipe_adds_four_multipliers() -> None:
    """The soft contact pipe (SOFT_CONTACT) is the rigid pipe plus one fp_mul per point (its b > 0 test is
    combinational, no comparator): the estimate grows by those and their delay lines, the memories do not."""
    rigid, soft = rm.pipe_shape("pgs_contact_pipe", 23), rm.pipe_shape("pgs_contact_pipe_soft", 23)
    assert soft.latency == rigid.latency
    assert {k: soft.operators[k] - rigid.operators.get(k, 0) for k in soft.operators} == {
        "fp_add": 0, "fp_minmax": 0, "fp_mul": 4}
    base = rm.KernelConfig(FP32, 38_881, 147_485, impulses_resident=False, body_ports="banked", body_banks=2,
                           shared_datapath=False)
    a, b = rm.estimate(base).total, rm.estimate(dataclasses.replace(base, soft_contact=True)).total
    assert b.dsp - a.dsp == 8 and b.bram36 == a.bram36 and b.lut > a.lut
    assert "soft contact pipe" in dataclasses.replace(base, soft_contact=True).describe()


def _operator_data(fmt_name: str, fabric: rm.Resources, dsp: rm.Resources) -> dict:
    """The committed figures with fp_add and fp_add_dsp of ``fmt_name`` replaced."""
    data = rm.figures()
    ops = dict(data["operators"][fmt_name])
    for name, r in (("fp_add", fabric), ("fp_add_dsp", dsp)):
        ops[name] = {**ops[name], "LUT": r.lut, "FF": r.ff, "DSP": r.dsp}
    return {**data, "operators": {**data["operators"], fmt_name: ops}}


def test_adder_form_counts_each_fp_add_with_its_figure() -> None:
    cfg = rm.KernelConfig(FP32, *THESIS, window=16384)
    data = _operator_data("fp32", rm.Resources(lut=400, ff=200), rm.Resources(lut=100, ff=220, dsp=2))
    fabric = rm.estimate(cfg, ZCU102, data).total
    dsp = rm.estimate(dataclasses.replace(cfg, adders="dsp"), ZCU102, data).total
    adders = sum(n * rm.pipe_shape(name, FP32.man_bits).operators.get("fp_add", 0)
                 for name, n in rm.lane_pipes(cfg) + [("pgs_integrate_pipe", 1)])
    assert adders > 100  # every fp_add instance of the lane's datapath and the integrate pipe
    assert fabric.lut - dsp.lut == pytest.approx(300 * adders)
    assert dsp.dsp - fabric.dsp == pytest.approx(2 * adders)
    assert dsp.ff - fabric.ff == pytest.approx(20 * adders)
    assert "fp_add_dsp" in rm.operator_sources(dataclasses.replace(cfg, adders="dsp"))
    assert "DSP48E2 adders" in dataclasses.replace(cfg, adders="dsp").describe()
    with pytest.raises(ValueError, match="adders"):
        rm.KernelConfig(FP32, 1, 1, adders="carry")


def test_the_fit_chooses_the_dsp_adders_only_where_they_ease_the_tighter_resource(monkeypatch) -> None:
    cfg = rm.KernelConfig(FP32, *THESIS, window=16384)
    # LUT the tighter resource, the DSPs within the usable share: the DSP form
    cheap = _operator_data("fp32", rm.Resources(lut=443, ff=192), rm.Resources(lut=226, ff=177, dsp=2))
    monkeypatch.setattr(rm, "figures", lambda path=rm.FIGURES_FILE: cheap)
    assert rm.with_chosen_adders(cfg, ZCU102).adders == "dsp"
    # a run's verdict counts the adders it built, the fit's pick a line beside it with the option that builds it
    v = rm.fit_or_reason(cfg, ZCU102, advise_adders=True)
    assert isinstance(v, rm.FitVerdict) and v.adders == "fabric" and rm.picked_adders(v) == "dsp"
    assert v.shares == rm.fit(cfg, ZCU102).shares and v.other_adders is not None
    line = rm.adders_text(v)
    assert line.startswith("fp_add (fabric) built; the fit picks fp_add_dsp (dsp): LUT ")
    assert line.endswith("ADD_DSP=1 (--add-dsp 1)") and line in rm.fit_rows(v).values()
    assert f"LUT {100 * v.other_adders.shares['LUT']:.1f}% against {100 * v.shares['LUT']:.1f}%" in line
    dsp = rm.fit_or_reason(dataclasses.replace(cfg, adders="dsp"), ZCU102, advise_adders=True)
    assert isinstance(dsp, rm.FitVerdict) and dsp.adders == "dsp" and rm.picked_adders(dsp) == "dsp"
    assert "fp_add_dsp (dsp) built, the fit's pick too" in rm.adders_text(dsp)
    plain = rm.fit_or_reason(cfg, ZCU102)  # not asked (the XLS datapath): no pick
    assert isinstance(plain, rm.FitVerdict) and plain.other_adders is None and "not figured" in rm.adders_text(plain)
    # a DSP form that saves no LUT: fabric
    same = _operator_data("fp32", rm.Resources(lut=443, ff=192), rm.Resources(lut=443, ff=192, dsp=2))
    monkeypatch.setattr(rm, "figures", lambda path=rm.FIGURES_FILE: same)
    assert rm.with_chosen_adders(cfg, ZCU102).adders == "fabric"
    same_v = rm.fit_or_reason(cfg, ZCU102, advise_adders=True)
    assert isinstance(same_v, rm.FitVerdict) and rm.picked_adders(same_v) == "fabric"
    # a DSP form that would take the DSPs past their usable share: fabric
    hungry = _operator_data("fp32", rm.Resources(lut=443, ff=192), rm.Resources(lut=10, ff=10, dsp=20))
    monkeypatch.setattr(rm, "figures", lambda path=rm.FIGURES_FILE: hungry)
    over = rm.fit(dataclasses.replace(cfg, adders="dsp"), ZCU102)
    assert over.shares["DSP"] > over.limits["DSP"]
    assert rm.with_chosen_adders(cfg, ZCU102).adders == "fabric"


def test_a_job_built_with_the_dsp_adders_is_judged_with_their_figure() -> None:
    """``--add-dsp 1`` (KernelJob.add_dsp): the build takes ADD_SHIFT_DSP = 1 in a build of its own, and make sim's
    verdict counts fp_add_dsp's figure for every adder; the XLS datapath refuses it."""
    from models.tests.test_body_banks import pile_job
    from models.timing.platforms import get_preset
    from sim.compile.kernel_build import KernelBuild

    fabric_job, dsp_job = pile_job(), pile_job().with_adders(True)
    assert rm.config_for_job(fabric_job).adders == "fabric" and rm.config_for_job(dsp_job).adders == "dsp"
    fabric, dsp = rm.kernel_fit(fabric_job, "zcu102"), rm.kernel_fit(dsp_job, "zcu102")
    assert isinstance(fabric, rm.FitVerdict) and isinstance(dsp, rm.FitVerdict)
    assert dsp.adders == "dsp" and dsp.total == rm.fit(rm.config_for_job(dsp_job), ZCU102).total
    assert dsp.total.dsp > fabric.total.dsp and dsp.total.lut < fabric.total.lut
    assert dsp.other_adders is not None and dsp.other_adders.total == fabric.total
    assert "fp_add_dsp" in dsp.operator_sources and "DSP48E2 adders" in dsp.config
    kb, kb0 = KernelBuild.for_job(dsp_job, get_preset("zcu102")), KernelBuild.for_job(fabric_job, get_preset("zcu102"))
    assert kb.parameters["ADD_SHIFT_DSP"] == 1 and "ADD_SHIFT_DSP" not in kb0.parameters and kb.name != kb0.name
    with pytest.raises(ValueError, match="DATAPATH=xls does not cover ADD_DSP=1"):
        KernelBuild.for_job(dsp_job.with_datapath(False), get_preset("zcu102"), datapath="xls")


def test_the_scene_inertia_keeps_two_words_per_body_fewer_on_chip() -> None:
    """``inertia_words`` (IINV_W): the body constants are pos, q, 1/m and the inverse inertia's words, so the 1-word
    build of an isotropic scene (make sim INERTIA=scene) keeps 9 words per body, 2 fewer than the default build's 11
    (the thesis frame in fp32: 304 BRAM36 in place of 380), on the 1-word shared datapath; a job built so is judged
    with it."""
    from models.tests.test_body_banks import pile_job

    cfg = rm.KernelConfig(FP32, *THESIS, window=8192, impulses_resident=False, body_ports="banked", body_banks=8)
    scalar = dataclasses.replace(cfg, inertia_words=1)
    const = {c.inertia_words: rm.memories(c)[0] for c in (cfg, scalar)}
    assert (rm.body_const_words(cfg), rm.body_const_words(scalar)) == (11, 9)
    assert (const[3].width, const[1].width) == (11 * 32, 9 * 32)
    assert (const[3].resources().bram36, const[1].resources().bram36) == (380, 304)
    assert rm.lane_pipes(scalar) == [("pgs_shared_pipe_scalar", 1)] and "1-word inverse inertia" in scalar.describe()
    assert rm.estimate(cfg, ZCU102).total.bram36 - rm.estimate(scalar, ZCU102).total.bram36 == 76
    assert rm.body_const_words(dataclasses.replace(scalar, body_words="solve")) == 2
    with pytest.raises(ValueError, match="1, 3 or 6"):
        rm.KernelConfig(FP32, 1, 1, inertia_words=2)
    job = pile_job()
    assert rm.config_for_job(job).inertia_words == 3 and rm.config_for_job(job.with_inertia(True)).inertia_words == 1

