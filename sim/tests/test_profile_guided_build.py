"""The profile-guided build (``sim.compile.verilator_build.profile_guided_build``) on a small top of its own: both
stages run, the training writes the profile, the finished build is reused until an input changes, a training that
writes no profile fails without a stamp, and the result computes what the plain build computes."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from models.formats.number_format import FP32
from sim.compile.kernel_build import PROFILE_GUIDED, KernelBuild, verilate_kernel
from sim.compile.verilator_build import VerilatorError, build, profile_guided_build

COUNTER_SV = """module pgo_counter #(parameter int STEP = 3) (input logic clk, input logic rst, output logic [31:0] q);
    always_ff @(posedge clk) begin
        if (rst) q <= '0;
        else if (q[0]) q <= q * 32'd5 + 32'd1;
        else q <= q + 32'(STEP);
    end
endmodule
"""
COUNTER_MAIN = """#include "Vpgo_counter.h"
#include "verilated.h"
#include <cstdio>
#include <cstdlib>
int main(int argc, char** argv) {
    Verilated::commandArgs(argc, argv);
    Vpgo_counter top;
    const long cycles = argc > 1 ? std::atol(argv[1]) : 1000;
    top.rst = 1; top.clk = 0; top.eval(); top.clk = 1; top.eval(); top.rst = 0;
    for (long c = 0; c < cycles; ++c) { top.clk = 0; top.eval(); top.clk = 1; top.eval(); }
    std::printf("%u\\n", top.q);
    top.final();
    return 0;
}
"""


def counter_args(tmp: Path, name: str, step: int = 3) -> dict:
    (tmp / "pgo_counter.sv").write_text(COUNTER_SV)
    (tmp / "pgo_counter_main.cpp").write_text(COUNTER_MAIN)
    return {"sources": [tmp / "pgo_counter.sv"], "top": "pgo_counter", "parameters": {"STEP": step},
            "cpp_files": [tmp / "pgo_counter_main.cpp"], "build_dir": tmp / name, "name": name,
            "extra_args": ["-MAKEFLAGS", "OPT_FAST=-O1 OPT_SLOW=-O0 OPT_GLOBAL=-O1"]}


def output(exe: Path, cycles: int = 5000) -> str:
    return subprocess.run([str(exe), str(cycles)], check=True, capture_output=True, text=True).stdout


def test_profile_guided_build(tmp_path: Path) -> None:
    trained: list[Path] = []

    def train(exe: Path) -> None:
        trained.append(exe)
        output(exe, 20000)

    args = counter_args(tmp_path, "pgo")
    exe = profile_guided_build(args, train)
    assert trained == [exe] and exe.is_file()
    mdir = tmp_path / "pgo"
    assert any(mdir.glob("*.gcda")) and (mdir / "profile_guided.stamp").is_file()
    plain = build(**counter_args(tmp_path, "plain"))
    assert output(exe) == output(plain)
    # up to date: no second training
    assert profile_guided_build(args, train) == exe and len(trained) == 1
    # an input changed (a parameter): both stages again
    changed = counter_args(tmp_path, "pgo", step=7)
    assert profile_guided_build(changed, train) == exe and len(trained) == 2
    assert output(exe) == output(build(**counter_args(tmp_path, "plain7", step=7)))


def test_training_without_a_profile_fails_and_leaves_no_stamp(tmp_path: Path) -> None:
    args = counter_args(tmp_path, "pgo")
    with pytest.raises(VerilatorError, match="wrote no profile"):
        profile_guided_build(args, lambda exe: None)
    assert not (tmp_path / "pgo" / "profile_guided.stamp").exists()
    # the next call starts over and finishes
    exe = profile_guided_build(args, lambda exe: output(exe))
    assert (tmp_path / "pgo" / "profile_guided.stamp").is_file() and output(exe)


def test_a_profile_guided_kernel_build_needs_its_training_run() -> None:
    assert PROFILE_GUIDED == {"pgo"}
    with pytest.raises(ValueError, match="needs a training run"):
        verilate_kernel(KernelBuild(FP32, compile_profile="pgo"))
