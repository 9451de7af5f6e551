"""The XLS datapath (rtl/generated/xls/, written by ``make xls``: rtl/gen/xls_flow.py) bit for bit and cycle for cycle.

* The committed files are current: the DSLX and the pipe modules equal what the generator writes now, and every
  XLS module's recorded digest is that of the DSLX, the operators, the XLS version and the options it would be
  compiled from today (a fast check: nothing is scheduled); the chained segments add up to each hand pipe's
  LATENCY in every format.
* The DSLX of each pipe (``<pipe>_pipe_words``, the chained segments as one function) in the XLS JIT equals the
  golden model on the pipe vectors of ``test_kernel_pipes.py`` (scene inputs and perturbations), and its event
  counts the graph twin's.
* The XLS Verilog of each pipe, inside its pipe module, in the compiled pipe driver of ``test_kernel_pipes.py``:
  every output word equal to the golden model's, LATENCY, order, tag and reset as the hand pipe's, the event
  counts the twin's (with idle cycles between the records).
* The kernel with the XLS pipes (``KernelBuild(datapath="xls")``, what ``make sim DATAPATH=xls`` builds) on the
  pile in binary32 and binary16 with deterministic streams: every trace record and body bit for bit against the
  golden model, every retire cycle, the total and the stall and bubble counters equal to the cycle model's, the
  event counters the golden model's prediction.
* Builds XLS does not cover are refused with one line.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from cocotb_tests.test_kernel_pipes import (FORMATS, PIPES, Harness, build_harness, check_pipe_bit_exact, count_flags,
                                            golden_bits, make_vectors, seed_for)
from models import scenes
from models.timing import cycle_model
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import BF16, EVENT_NAMES, FP16, FP32
from models.scenes.kernel_scenes import KERNEL_TEST_SCENES
from rtl.gen.file_list import kernel_sources
from rtl.gen.kernel_graphs import GRAPHS
from rtl.gen.operator_schedule import schedule
from rtl.gen.xls_flow import (MANIFEST, XLS_DIR, XLS_FORMATS, XLS_PIPES, dslx_path, ir_file, jit_words, modules,
                              recorded_digest, render, splits, stale, wrapper_path, xls_sources)
from sim.compile.kernel_build import XLS_UNCOVERED, KernelBuild, check_datapath, default_window
from sim.drive.kernel_step import golden_step, run_kernel_step
from sim.compare import retire_cycles

REPO = Path(__file__).resolve().parents[1]
RTL = REPO / "rtl"
PIPE_OF = {spec.module: name for name, spec in PIPES.items()}
XLS_PARAMS = [(PIPE_OF[p], f.name) for f in XLS_FORMATS for p in XLS_PIPES]


def test_xls_datapath_is_current() -> None:
    paths = stale()
    assert not paths, f"stale XLS datapath files (regenerate with make xls): {[str(p) for p in paths]}"
    want = set(render()) | {m.path for m in modules()} | {MANIFEST}
    extra = set(XLS_DIR.iterdir()) - want
    assert set(XLS_DIR.iterdir()) == want, f"files in rtl/generated/xls/ the flow does not write: {extra}"
    manifest = json.loads(MANIFEST.read_text())["modules"]
    for m in modules():
        assert recorded_digest(m.path) is not None and manifest[m.name]["stages"] == m.stages
        assert f"module {m.name}(" in m.path.read_text()
    for pipe, split in splits().items():
        for fmt in XLS_FORMATS:
            assert split.latency(fmt.man_bits) == schedule(GRAPHS[pipe]()).latency_for(fmt.man_bits), (pipe, fmt.name)


@pytest.mark.parametrize("pipe,fmt_name", XLS_PARAMS, ids=[f"{p}-{f}" for p, f in XLS_PARAMS])
def test_dslx_pipe_matches_golden(pipe: str, fmt_name: str) -> None:
    """The DSLX of the pipe in the XLS JIT (the committed rtl/generated/xls/<pipe>.x) against the golden model."""
    fmt = FORMATS[fmt_name]
    spec = PIPES[pipe]
    split = splits()[spec.module]
    dslx = dslx_path(spec.module).read_text()
    ir = ir_file(spec.module, dslx).read_text()
    seed = seed_for(fmt_name, pipe)
    bits, flags, counts = make_vectors(pipe, fmt, seed)
    count = count_flags(len(bits), seed)
    words = np.concatenate([bits.astype(np.uint64)] + ([flags.astype(np.uint64)[:, None]] if spec.spin else []),
                           axis=1)
    n_out = len(spec.out_names)
    out = jit_words(ir, spec.module, f"{split.prefix}_pipe_words_e{fmt.exp_bits}m{fmt.man_bits}", words, fmt.width,
                    n_out + 3)
    want = golden_bits(pipe, fmt, bits, flags).astype(np.uint64)
    bad = np.argwhere(out[:, :n_out] != want)
    assert not len(bad), f"{spec.module} {fmt_name}: {len(bad)} words differ, first (vector, word) {bad[:6].tolist()}"
    x = fmt.decode(bits[count].astype(np.uint64))
    with np.errstate(all="ignore"):
        twin = GRAPHS[spec.module]().count_events(fmt, x, flags[count][:, None] if spec.spin else None).as_dict()
    got = dict(zip(EVENT_NAMES, (int(v) for v in out[count, n_out:].sum(axis=0))))
    print(f"\n[{spec.module} {fmt_name}] {len(bits)} vectors {counts}: 0 differing words; events {got}")
    assert got == twin
    if fmt_name == "fp16":  # not vacuous: fp16 flushes in every pipe
        assert got["underflow"] > 0


@pytest.fixture(scope="module", params=XLS_PARAMS, ids=[f"{p}-{f}" for p, f in XLS_PARAMS])
def xls_harness(request: pytest.FixtureRequest) -> Harness:
    pipe, fmt_name = request.param
    module = PIPES[pipe].module
    fmt = FORMATS[fmt_name]
    xls_modules = [m.path for m in modules() if m.pipe == module and m.fmt == fmt]
    sources = [RTL / "pgs_fp_pkg.sv", RTL / "pgs_delay.sv", RTL / "fp" / "fp_valid_pipe.sv", *xls_modules,
               wrapper_path(module)]
    return build_harness(pipe, fmt_name, sources, f"{module}_{fmt_name}_xls")


def test_xls_pipe_bit_exact(xls_harness: Harness, tmp_path: Path) -> None:
    """XLS's Verilog of the pipe, in its pipe module, through the hand pipes' compiled driver."""
    check_pipe_bit_exact(xls_harness, tmp_path)


@pytest.mark.parametrize("fmt", XLS_FORMATS, ids=lambda f: f.name)
def test_kernel_with_xls_pipes(fmt, tmp_path: Path) -> None:
    """The kernel built with the XLS pipes on the pile (4 iterations, hazard order, zcu102 DMA model, deterministic
    streams): bit-exact, every retire cycle the cycle model's, the event counters the golden model's."""
    frame = scenes.load_or_capture("pile", **KERNEL_TEST_SCENES["pile"])
    # XLS compiles the contact and the friction pipe: two pipes per lane
    job = KernelJob.from_frame(frame, fmt, SolverParams(4), "hazard",
                               default_window(fmt, 512, shared_datapath=False)).with_datapath(False)
    preset = get_preset("zcu102")
    golden = golden_step(job)
    res = run_kernel_step(job, preset, tmp_path, seed=1, golden=golden, keep_trace=True, datapath="xls")
    assert res.comparison.first_mismatch is None, res.comparison.first_mismatch
    assert res.bit_exact and res.comparison.records == job.manifold_passes
    agree = retire_cycles.compare_run(cycle_model.predict_job(job, preset), res, job.slots)
    got = {name: int(res.registers[f"fp_{name}"]) for name in EVENT_NAMES}
    print(f"\n[pile/{fmt.name}/XLS pipes] build {res.build_seconds:.1f} s; {res.comparison.records} trace records, "
          f"{res.comparison.bodies} bodies, {res.comparison.differing_bits} differing bits; {agree.describe()}; "
          f"events {got}")
    assert agree.ok, agree.first_mismatch
    assert got == golden.events.as_dict()


def test_xls_builds_refused_with_one_line() -> None:
    """Every build option XLS has no pipes for is refused by the one check (sim.compile.kernel_build.check_datapath),
    in one line naming it; the options a command line knows before its frame are refused the same way."""
    assert KernelBuild(FP32, datapath="xls", shared_datapath=False).name == "pgs_kernel_e8m23_c512_split_xls"
    cases = {"FORMAT=bf16": dict(fmt=BF16), "IINV_W = 1 or 6": dict(fmt=FP16, inertia_words=6),
             "MU_W = 1": dict(fmt=FP32, friction_words=1), "TANGENTS=chip": dict(fmt=FP32, tangents_on_chip=True),
             "SOFT_CONTACT": dict(fmt=FP32, soft_contact=True), "sign bug": dict(fmt=FP32, friction_sign_bug=True),
             "SHARED_DATAPATH=1": dict(fmt=FP32, shared_datapath=True), "ADD_DSP=1": dict(fmt=FP32, add_dsp=True)}
    assert len(cases) == len(XLS_UNCOVERED) + 1  # each row of the table, and a format
    for what, kw in cases.items():
        with pytest.raises(ValueError) as info:
            KernelBuild(datapath="xls", **({"shared_datapath": False} | kw))  # this option alone uncovered
        msg = str(info.value)
        assert "\n" not in msg and msg.startswith("DATAPATH=xls does not cover ") and what in msg, msg
        KernelBuild(**kw)  # the hand pipes cover it
    with pytest.raises(ValueError, match="does not cover FORMAT=bf16 .*; TANGENTS=chip"):
        check_datapath("xls", BF16, {"tangents_on_chip": True})
    check_datapath("xls", FP16, {"tangents_on_chip": False, "shared_datapath": False})
    with pytest.raises(ValueError, match="datapath 'hls'"):
        KernelBuild(FP32, datapath="hls")


def test_xls_sources_replace_the_three_pipes() -> None:
    base = kernel_sources()
    src = xls_sources(base)
    names = [p.name for p in src]
    for pipe in XLS_PIPES:
        assert wrapper_path(pipe) in src and RTL / "generated" / f"{pipe}.sv" not in src
        mods = [m.path for m in modules() if m.pipe == pipe]
        assert all(src.index(m) < src.index(wrapper_path(pipe)) for m in mods)
    assert len(src) == len(base) + len(modules()) and len(set(names)) == len(names)
    assert KernelBuild(FP16, datapath="xls", shared_datapath=False).sources()[-1].name == "pgs_kernel.sv"


def test_split_graph_segments_and_refusal() -> None:
    """A graph splits at its top-level scopes: each segment reads the pipe inputs it needs and the values earlier
    segments computed, and is as deep as the hand pipe's cycles for it; scopes that do not end in order are
    refused."""
    from rtl.gen.dataflow import Graph
    from rtl.gen.dslx_emit import DslxError, split_graph

    g = Graph("toy")
    a, b = g.input("a"), g.input("b")
    with g.scope("s0"):
        x = (a * b).named("x")
    with g.scope("s1"):
        y = (x + a).named("y")
    g.output("y", y)
    split = split_graph(g)
    s0, s1 = split.segments
    assert [s.name for s in split.segments] == ["toy_s0", "toy_s1"]
    assert (s0.depth(23), s1.depth(23), split.latency(23)) == (3, 4, 7)  # fp_mul 3, fp_add 4
    assert s1.inputs == (a,) and s1.carried_in == (x,) and s0.carried_out == (x,) and s1.carried_out == (y,)
    g = Graph("late")
    a, b = g.input("a"), g.input("b")
    with g.scope("long"):
        x = ((a * b) * a).named("x")
    with g.scope("short"):
        y = (a + b).named("y")
    with g.scope("last"):
        z = (x + y).named("z")
    g.output("z", z)
    with pytest.raises(DslxError, match="scope 'short' ends at cycle 4, not after the previous one \\(6\\)"):
        split_graph(g)
