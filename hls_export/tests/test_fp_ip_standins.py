"""The Floating-Point Operator stand-ins (hls_export/fp_ip) in simulation, and their generator.

``test_standins_simulated`` builds ``fp_ip_standins_tb.sv`` (one stand-in per operation behind an HLS
wrapper's input buffer, C_LATENCY above the rtl/fp latencies, and equal to it on one channel) with Verilator
for binary32 and binary16 and drives it from ``fp_ip_standins_main.cpp``: every special pair of
``sim.drive.fp_operator_vectors.special_values``, its ``directed_pairs`` and random bit patterns, one vector
per enabled cycle (3 % idle), ``aclken`` = 0 on 30 % of the cycles (seeded: ``SEED=<int>`` overrides, printed).
The driver checks that each result leaves exactly C_LATENCY enabled cycles after its operands, that nothing
moves on a disabled cycle, and that no stray tvalid appears; this test checks every result bit for bit
against ``sim.drive.fp_operator_vectors.golden`` (models/formats/number_format.py), the compare for all 8 predicate
codes. ``test_too_short_latency_fails*`` check the elaboration error (and, built with -Wno-fatal, the same message from
the simulation at time 0); ``test_generator_*`` run ``hls_export/fp_ip/standins.py`` on a small hand-written fake export
(no real export exists here) and lint the wrappers it writes.
"""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

from hls_export.fp_ip.standins import StandinError, find_ip_cores, standin_sources, write_standins
from models.formats.number_format import FP16, FP32, NumberFormat
from sim.drive import fp_operator_vectors as fpv
from sim.compile.verilator_build import QUICK_COMPILE_ARGS, REPO_ROOT, build, ensure_verilator_env, rtl_sources
from sim.drive.seed import run_seed

HERE = Path(__file__).resolve().parent
CHANNELS = ("add", "sub", "mul", "div", "sqrt", "cmp")
# C_LATENCY per format: above the rtl/fp operator's latency, except one channel exactly at it (no padding)
LATENCIES = {"fp32": {"add": 11, "sub": 4, "mul": 8, "div": 30, "sqrt": 29, "cmp": 2},
             "fp16": {"add": 6, "sub": 5, "mul": 3, "div": 17, "sqrt": 16, "cmp": 3}}
FORMATS = {"fp32": FP32, "fp16": FP16}
OP_LATENCY = {"add": lambda m: 4, "sub": lambda m: 4, "mul": lambda m: 3, "div": lambda m: m + 5,
              "sqrt": lambda m: m + 4, "cmp": lambda m: 1}   # rtl/fp/README.md; cmp: fp_minmax LATENCY 1


def make_vectors(fmt: NumberFormat, rng: np.random.Generator) -> tuple[np.ndarray, dict[str, int]]:
    """Records {a, b, predicate}: special pairs, directed pairs, random patterns; random compare predicates."""
    sp = fpv.special_values(fmt)
    ga, gb = np.meshgrid(sp, sp, indexing="ij")
    sets = {"special_pairs": np.stack([ga.ravel(), gb.ravel()], axis=1),
            "directed": fpv.directed_pairs(fmt, rng, 1024),
            "random": rng.integers(0, 1 << fmt.width, size=(1 << 16, 2), dtype=np.uint64).astype(np.uint32)}
    ab = np.concatenate(list(sets.values())).astype(np.uint32)
    # s_axis_operation_tdata: predicate code in bits [5:3], 3'b100 (compare) below, as the HLS fcmp wrappers send
    pred = (rng.integers(0, 8, len(ab)).astype(np.uint32) << 3) | 4
    return np.concatenate([ab, pred[:, None]], axis=1), {k: len(v) for k, v in sets.items()}


def golden_cmp(flags: np.ndarray, pred: np.ndarray) -> np.ndarray:
    """m_axis_result_tdata of the compare, from the golden flags ({unordered, eq, lt} in bits 2..0)."""
    lt, eq, un = flags & 1, (flags >> 1) & 1, (flags >> 2) & 1
    gt = 1 - (lt | eq | un)
    code = (pred >> 3) & 7
    table = np.stack([un, lt, eq, lt | eq, gt, 1 - eq, gt | eq, (un << 3) | (gt << 2) | (lt << 1) | eq])
    return table[code, np.arange(len(code))].astype(np.uint32)


@pytest.mark.parametrize("fmt_name", ["fp32", "fp16"])
def test_standins_simulated(fmt_name: str, tmp_path: Path) -> None:
    fmt = FORMATS[fmt_name]
    lat = LATENCIES[fmt_name]
    seed = run_seed() + (0 if fmt_name == "fp32" else 1)
    t0 = time.monotonic()
    exe = build(
        sources=rtl_sources("rtl/fp") + standin_sources() + [HERE / "fp_ip_standins_tb.sv"],
        top="fp_ip_standins_tb",
        parameters={"EXP_BITS": fmt.exp_bits, "MAN_BITS": fmt.man_bits,
                    **{f"LAT_{ch.upper()}": lat[ch] for ch in CHANNELS}},
        cpp_files=[HERE / "fp_ip_standins_main.cpp"],
        name=f"fp_ip_standins_tb_{fmt_name}",
        extra_args=QUICK_COMPILE_ARGS,
    )
    t1 = time.monotonic()
    vec, counts = make_vectors(fmt, np.random.default_rng(seed))
    vec.astype("<u4").tofile(tmp_path / "in.bin")
    proc = subprocess.run([str(exe), str(tmp_path / "in.bin"), str(tmp_path / "out.bin"), str(seed), "300", "30"],
                          capture_output=True, text=True)
    t2 = time.monotonic()
    print(f"\n[{fmt_name}] SEED={seed} (SEED= overrides the base); {len(vec)} vectors {counts}; build {t1 - t0:.1f} s, "
          f"sim {t2 - t1:.1f} s\n{proc.stdout.strip()}")
    assert proc.returncode == 0, f"harness failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}"
    res = np.fromfile(tmp_path / "out.bin", dtype="<u4").reshape(-1, len(CHANNELS))
    assert res.shape[0] == len(vec)
    log = proc.stdout.splitlines()
    assert log[0] == "latencies " + " ".join(f"{ch}={lat[ch]}" for ch in CHANNELS)
    stats = dict(kv.split("=") for kv in log[1].split())
    assert int(stats["vectors"]) == int(stats["results"]) == len(vec)
    # aclken was 0 on about 30 % of the cycles, and outputs were checked holding a valid result many times
    assert 0.25 < int(stats["disabled"]) / int(stats["cycles"]) < 0.35
    assert int(stats["held_valid_checks"]) > len(vec)

    exp = fpv.golden(fmt, vec[:, 0], vec[:, 1])
    exp["cmp"] = golden_cmp(exp["flags"], vec[:, 2])
    failures = []
    for i, ch in enumerate(CHANNELS):
        bad = np.flatnonzero(res[:, i] != exp[ch])
        if bad.size:
            failures.append(f"{ch}: {bad.size} mismatches, first a=0x{vec[bad[0], 0]:x} b=0x{vec[bad[0], 1]:x} "
                            f"pred=0x{vec[bad[0], 2]:02x} got=0x{res[bad[0], i]:x} expected=0x{exp[ch][bad[0]]:x}")
    # not vacuous: every compare outcome of every predicate occurs
    codes = (vec[:, 2] >> 3) & 7
    assert all(len(np.unique(exp["cmp"][codes == c])) >= 2 for c in range(7))
    assert len(np.unique(exp["cmp"][codes == 7])) == 4
    print(f"[{fmt_name}] {len(vec) * len(CHANNELS)} results compared bit for bit: {len(failures)} channels with "
          "mismatches")
    assert not failures, "\n".join(failures)


def _lint(sources: list[Path], top: str, params: dict[str, str | int] | None = None,
          extra: tuple[str, ...] = ()) -> subprocess.CompletedProcess[str]:
    cmd = [str(ensure_verilator_env()), "--lint-only", "-Wall", *extra, "--top-module", top]
    cmd += [f"-G{k}={v}" for k, v in (params or {}).items()]
    return subprocess.run(cmd + [str(s) for s in sources], capture_output=True, text=True, cwd=REPO_ROOT)


@pytest.mark.parametrize("op", CHANNELS)
def test_too_short_latency_fails(op: str) -> None:
    """C_LATENCY one below the operator's latency stops elaboration with the stand-in's message; equal lints clean."""
    for fmt in (FP32, FP16):
        need = OP_LATENCY[op](fmt.man_bits)
        params = {"OPERATION": f'"{op}"', "EXP_BITS": fmt.exp_bits, "MAN_BITS": fmt.man_bits}
        bad = _lint(rtl_sources("rtl/fp") + standin_sources(), "fp_ip_standin", {**params, "C_LATENCY": need - 1})
        assert bad.returncode != 0
        assert f"fp_ip_standin ({op}): C_LATENCY = {need - 1} is shorter than the latency of the rtl/fp operator " \
               f"({need} cycles)" in bad.stderr, bad.stderr
        ok = _lint(rtl_sources("rtl/fp") + standin_sources(), "fp_ip_standin", {**params, "C_LATENCY": need})
        assert ok.returncode == 0 and "%Warning" not in ok.stderr, ok.stderr


def test_too_short_latency_fails_at_start_without_fatal_warnings() -> None:
    """Built with -Wno-fatal (as generated HLS Verilog may need), the too-short stand-in stops at time 0 instead."""
    exe = build(sources=rtl_sources("rtl/fp") + standin_sources(), top="fp_ip_standin",
                parameters={"OPERATION": "cmp", "C_LATENCY": 0}, name="fp_ip_standin_cmp_latency0",
                extra_args=["--main", "-Wno-fatal", "-Wno-lint", *QUICK_COMPILE_ARGS], quiet=True)
    r = subprocess.run([str(exe)], capture_output=True, text=True)
    assert r.returncode != 0
    assert "fp_ip_standin (cmp): C_LATENCY = 0 is shorter than the latency of the rtl/fp operator (1 cycles)" \
        in r.stdout + r.stderr, r.stdout + r.stderr


# --- the generator on a fake export ------------------------------------------------------------------------
# What Vitis HLS writes (abridged): per operator a wrapper `<top>_<op>_..._<stages>_<impl>_1` with ports clk,
# reset, ce, din0, din1 (opcode for compares), dout, which registers its inputs and instantiates `..._ip`; the
# IP's configuration in `<name>_ip.tcl` (create_ip + set_property CONFIG.*) or in the IP's own `<name>_ip.v`
# (floating_point_v7_1_<n> #(.C_LATENCY(..), .C_HAS_<OP>(1), ...)).
WRAPPER = """module {top}_{op}_{w}ns_{w}ns_{ow}_{st}_{impl}_1 #(parameter ID = 1, NUM_STAGE = {st},
    din0_WIDTH = {w}, din1_WIDTH = {w}, dout_WIDTH = {ow}) (
    input  wire clk, input wire reset, input wire ce,
    input  wire [din0_WIDTH-1:0] din0, input wire [din1_WIDTH-1:0] din1,{opcode_port}
    output wire [dout_WIDTH-1:0] dout);
wire a_tvalid; wire [{w1}:0] a_tdata; wire b_tvalid; wire [{w1}:0] b_tdata;{op_wires}
wire r_tvalid; wire [{rw1}:0] r_tdata;
reg [din0_WIDTH-1:0] din0_buf1; reg [din1_WIDTH-1:0] din1_buf1; reg ce_r; reg [dout_WIDTH-1:0] dout_r;
{top}_{op}_{w}ns_{w}ns_{ow}_{st}_{impl}_1_ip {top}_{op}_{w}ns_{w}ns_{ow}_{st}_{impl}_1_ip_u (
    .aclk                 ( clk ),
    .aclken               ( ce ),
    .s_axis_a_tvalid      ( a_tvalid ),
    .s_axis_a_tdata       ( a_tdata ),{b_ports}{op_ports}
    .m_axis_result_tvalid ( r_tvalid ),
    .m_axis_result_tdata  ( r_tdata )
);
assign a_tvalid = 1'b1; assign a_tdata = din0_buf1; assign b_tvalid = 1'b1; assign b_tdata = din1_buf1;{op_assign}
always @(posedge clk) if (ce) begin din0_buf1 <= din0; din1_buf1 <= din1; end
always @(posedge clk) ce_r <= ce;
always @(posedge clk) if (ce_r) dout_r <= r_tdata[dout_WIDTH-1:0];
assign dout = ce_r ? r_tdata[dout_WIDTH-1:0] : dout_r;
endmodule
"""
TCL = """# BEGIN Vivado Commands
set vivado_ver [version -short]
set fpo_ver 7.1
create_ip -name floating_point -version $fpo_ver -vendor xilinx.com -library ip -module_name {name}
# BEGIN Vivado Parameters
set_property -dict [list CONFIG.a_precision_type {prec} \\
                          CONFIG.add_sub_value {addsub} \\
                          CONFIG.c_a_exponent_width {e} \\
                          CONFIG.c_a_fraction_width {f} \\
                          CONFIG.c_compare_operation Programmable \\
                          CONFIG.c_latency {lat} \\
                          CONFIG.component_name {name} \\
                          CONFIG.flow_control NonBlocking \\
                          CONFIG.has_aclken true \\
                          CONFIG.has_aresetn false \\
                          CONFIG.operation_type {optype} \\
                          CONFIG.result_precision_type {prec}] -objects [get_ips {name}] -quiet
set_property generate_synth_checkpoint false [get_files {name}.xci]
"""
IP_V = """`timescale 1 ns / 1 ps
module {name} (aclk, aclken, s_axis_a_tvalid, s_axis_a_tdata, s_axis_b_tvalid, s_axis_b_tdata,
  s_axis_operation_tvalid, s_axis_operation_tdata, m_axis_result_tvalid, m_axis_result_tdata);
input wire aclk;
input wire aclken;
input wire s_axis_a_tvalid;
input wire [{w1}:0] s_axis_a_tdata;
input wire s_axis_b_tvalid;
input wire [{w1}:0] s_axis_b_tdata;
input wire s_axis_operation_tvalid;
input wire [7:0] s_axis_operation_tdata;
output wire m_axis_result_tvalid;
output wire [7:0] m_axis_result_tdata;
  floating_point_v7_1_15 #(
    .C_XDEVICEFAMILY("zynquplus"),
    .C_PART("xczu9eg-ffvb1156-2-e"),
    .C_HAS_ADD(0),
    .C_HAS_SUBTRACT(0),
    .C_HAS_MULTIPLY(0),
    .C_HAS_DIVIDE(0),
    .C_HAS_SQRT(0),
    .C_HAS_COMPARE(1),
    .C_A_WIDTH({w}),
    .C_A_FRACTION_WIDTH({f}),
    .C_LATENCY({lat}),
    .C_COMPARE_OPERATION(8)
  ) inst (.aclk(aclk), .aclken(aclken), .s_axis_a_tvalid(s_axis_a_tvalid), .s_axis_a_tdata(s_axis_a_tdata));
endmodule
"""


def _fake_core(top: str, op: str, lat: int, fmt: NumberFormat, via: str, stages: int) -> dict[str, str]:
    """Files of one fake operator core: its HLS wrapper, and its configuration as ``.tcl`` or ``_ip.v``."""
    w, prec = fmt.width, {8: "Single", 5: "Half"}[fmt.exp_bits]
    letter = {8: "f", 5: "h"}[fmt.exp_bits]
    cmp = op == "cmp"
    sqrt = op == "sqrt"
    ow = 1 if cmp else w
    name = f"{top}_{letter}{op}_{w}ns_{w}ns_{ow}_{stages}_{'no_dsp' if cmp else 'full_dsp'}_1"
    wrapper = WRAPPER.format(
        top=top, op=f"{letter}{op}", w=w, w1=w - 1, ow=ow, st=stages, impl="no_dsp" if cmp else "full_dsp",
        rw1=7 if cmp else w - 1,
        opcode_port="\n    input  wire [4:0] opcode," if cmp else "",
        op_wires=" wire op_tvalid; reg [7:0] op_tdata;" if cmp else "",
        b_ports="" if sqrt else "\n    .s_axis_b_tvalid      ( b_tvalid ),\n    .s_axis_b_tdata       ( b_tdata ),",
        op_ports=("\n    .s_axis_operation_tvalid ( op_tvalid ),\n    .s_axis_operation_tdata ( op_tdata ),"
                  if cmp else ""),
        op_assign=("\nassign op_tvalid = 1'b1;\nalways @(*) case (opcode) 5'b00001: op_tdata = 8'b00010100; "
                   "5'b00100: op_tdata = 8'b00001100; default: op_tdata = 8'b00010100; endcase") if cmp else "")
    files = {f"{name}.v": wrapper}
    if via == "tcl":
        optype = {"add": "Add_Subtract", "sub": "Add_Subtract", "mul": "Multiply", "div": "Divide",
                  "sqrt": "Square_root", "cmp": "Compare"}[op]
        files[f"{name}_ip.tcl"] = TCL.format(name=f"{name}_ip", prec=prec, e=fmt.exp_bits, f=fmt.man_bits + 1,
                                             lat=lat, optype=optype, addsub={"sub": "Subtract"}.get(op, "Add"))
    else:
        assert cmp, "the fake _ip.v is a compare core"
        files[f"{name}_ip.v"] = IP_V.format(name=f"{name}_ip", w=w, w1=w - 1, f=fmt.man_bits + 1, lat=lat)
    return files


FAKE_CORES = [  # (operation, C_LATENCY, format, configuration in, wrapper stages)
    ("add", 11, FP32, "tcl", 13), ("sub", 4, FP32, "tcl", 6), ("mul", 8, FP32, "tcl", 10), ("div", 30, FP32, "tcl", 32),
    ("sqrt", 29, FP32, "tcl", 31), ("cmp", 2, FP32, "v", 4), ("add", 5, FP16, "tcl", 7), ("cmp", 1, FP16, "v", 3),
]


def _fake_export(folder: Path, cores: list[tuple[str, int, NumberFormat, str, int]]) -> list[str]:
    """Write a fake export (wrappers, configurations, a top instantiating every wrapper); return the IP names."""
    folder.mkdir(parents=True, exist_ok=True)
    names, inst = [], []
    for k, (op, lat, fmt, via, stages) in enumerate(cores):
        for fname, text in _fake_core("pgs_kernel", op, lat, fmt, via, stages).items():
            (folder / fname).write_text(text)
            if fname.endswith("_1.v"):
                wrapper = fname[:-2]
                names.append(wrapper + "_ip")
                ow = 1 if op == "cmp" else fmt.width
                opcode = " .opcode(5'd1)," if op == "cmp" else ""
                inst.append(f"wire [{ow - 1}:0] y{k};\n{wrapper} #(.ID({k})) u{k} (.clk(ap_clk), .reset(ap_rst), "
                            f".ce(ce), .din0(x[{fmt.width - 1}:0]), .din1(x[{fmt.width - 1}:0]),{opcode} .dout(y{k}));")
    (folder / "pgs_kernel.v").write_text(
        "module pgs_kernel (input wire ap_clk, input wire ap_rst, input wire ce, input wire [31:0] x,\n"
        "                   output wire [31:0] y);\n" + "\n".join(inst) + "\nassign y = {31'd0, ^{"
        + ", ".join(f"y{k}" for k in range(len(cores))) + "}};\nendmodule\n")
    return sorted(names)


def test_generator_on_fake_export(tmp_path: Path) -> None:
    names = _fake_export(tmp_path / "verilog", FAKE_CORES)
    cores = find_ip_cores(tmp_path / "verilog")
    assert [c.name for c in cores] == names
    got = sorted((c.operation, c.c_latency, c.exp_bits, c.man_bits) for c in cores)
    assert got == sorted((op, lat, f.exp_bits, f.man_bits) for op, lat, f, _, _ in FAKE_CORES)
    for c in cores:   # each name's own core: the operation in its name (fadd, hcmp, ...), its source file
        assert f"_{'h' if c.exp_bits == 5 else 'f'}{c.operation}_" in c.name, c
        assert c.sources == [f"{c.name}.tcl" if c.operation != "cmp" else f"{c.name}.v"], c
    sqrt = next(c for c in cores if c.operation == "sqrt")
    assert "s_axis_b_tdata" not in sqrt.ports
    out = tmp_path / "standins"
    paths = write_standins(tmp_path / "verilog", out)
    assert sorted(p.stem for p in paths) == names
    sources = rtl_sources("rtl/fp") + standin_sources()
    for p in paths:   # every wrapper on its own: -Wall clean
        r = _lint(sources + [p], p.stem)
        assert r.returncode == 0 and "%Warning" not in r.stderr, f"{p.name}:\n{p.read_text()}\n{r.stderr}"
    # the whole fake export with the stand-ins instead of its *_ip.v: elaborates (HLS style: lint warnings off)
    export_v = [p for p in sorted((tmp_path / "verilog").glob("*.v")) if not p.name.endswith("_ip.v")]
    r = _lint(sources + paths + export_v, "pgs_kernel", extra=("-Wno-lint", "-Wno-style"))
    assert r.returncode == 0 and "%Error" not in r.stderr, r.stderr
    print(f"\ngenerator: {len(paths)} stand-in wrappers for the fake export, "
          + ", ".join(f"{c.operation}/{c.c_latency}/E{c.exp_bits}M{c.man_bits}" for c in cores))


def test_generator_latency_zero_compare_fails(tmp_path: Path) -> None:
    """A compare core with C_LATENCY 0 (HLS makes those) gets a wrapper whose elaboration stops with the message."""
    _fake_export(tmp_path / "verilog", [("cmp", 0, FP32, "v", 2)])
    (path,) = write_standins(tmp_path / "verilog", tmp_path / "standins")
    r = _lint(rtl_sources("rtl/fp") + standin_sources() + [path], path.stem)
    assert r.returncode != 0
    assert "fp_ip_standin (cmp): C_LATENCY = 0 is shorter than the latency of the rtl/fp operator (1 cycles)" \
        in r.stderr, r.stderr


def test_generator_rejects_what_it_cannot_replace(tmp_path: Path) -> None:
    folder = tmp_path / "verilog"
    files = _fake_core("pgs_kernel", "add", 11, FP32, "tcl", 13)
    for fname, text in files.items():
        (folder / fname).parent.mkdir(parents=True, exist_ok=True)
        (folder / fname).write_text(text.replace("CONFIG.c_latency 11 \\\n", ""))
    with pytest.raises(StandinError, match="no C_LATENCY"):
        find_ip_cores(folder)
    for fname, text in files.items():
        (folder / fname).write_text(text.replace("CONFIG.add_sub_value Add", "CONFIG.add_sub_value Both"))
    with pytest.raises(StandinError, match="add_sub_value"):
        find_ip_cores(folder)
    for fname, text in files.items():
        (folder / fname).write_text(text.replace(".aclken               ( ce ),", ".aresetn ( reset ),"))
    with pytest.raises(StandinError, match="aresetn"):
        find_ip_cores(folder)
