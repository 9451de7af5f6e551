"""The compiled Verilator harness of the rtl/fp operators: every operator of one format side by side.

``sim/harness/fp_ops_tb.sv`` instantiates every rtl/fp operator for one format (``EXP_BITS``, ``MAN_BITS``);
``sim/harness/fp_ops_main.cpp`` drives it with one operand pair per cycle and random idle cycles, and writes the
results of every operator (``sim.drive.fp_operator_vectors.OPS``) per vector, and on its first line each operator's
LATENCY. Built into ``build/verilator/fp_ops_tb_<format>/``; with ``add_dsp`` the adders are fp_add's DSP48E2 form
(``SHIFT_DSP = 1``), built into ``build/verilator/fp_ops_tb_<format>_add_dsp/``.

    exe = build_fp_operator_harness("fp16")
    exe = build_fp_operator_harness("fp16", add_dsp=True)
    results, proc = run_fp_operator_harness(exe, vec, tmp_dir, seed)
"""

from __future__ import annotations

import subprocess
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from models.formats.number_format import NumberFormat
from sim.drive.fp_operator_vectors import FORMATS
from sim.compile.kernel_build import HARNESS_DIR
from sim.compile.verilator_build import build, rtl_sources

TOP = "fp_ops_tb"
TESTBENCH = HARNESS_DIR / "fp_ops_tb.sv"
DRIVER = HARNESS_DIR / "fp_ops_main.cpp"
MINMAX_LATENCY = 2
IDLE_PERCENT = 30  # random idle cycles between operand pairs


def harness_name(fmt_name: str, add_dsp: bool = False) -> str:
    """The build directory name of a format's harness (its adders' form)."""
    return f"{TOP}_{fmt_name}" + ("_add_dsp" if add_dsp else "")


def harness_parameters(fmt: NumberFormat, add_dsp: bool = False) -> dict[str, int]:
    return {"EXP_BITS": fmt.exp_bits, "MAN_BITS": fmt.man_bits, "MINMAX_LATENCY": MINMAX_LATENCY,
            "ADD_DSP": int(add_dsp)}


def harness_sources() -> list[Path]:
    """The rtl/fp operators and the testbench top."""
    return rtl_sources("rtl/fp") + [TESTBENCH]


def build_fp_operator_harness(fmt_name: str, build_dir: Path | None = None, extra_sources: Sequence[Path] = (),
                              extra_cpp_files: Sequence[Path] = (), extra_args: Sequence[str] = (),
                              add_dsp: bool = False) -> Path:
    """Build the harness of ``fmt_name`` (plus ``extra_*``, e.g. coverage hooks; ``add_dsp``: the adders in their
    DSP48E2 form); return the executable."""
    return build([*harness_sources(), *extra_sources], TOP,
                 parameters=harness_parameters(FORMATS[fmt_name], add_dsp), cpp_files=[DRIVER, *extra_cpp_files],
                 build_dir=build_dir, name=harness_name(fmt_name, add_dsp),
                 extra_args=list(extra_args))


def run_fp_operator_harness(exe: Path, vec: np.ndarray, work_dir: Path, seed: int,
                            env: Mapping[str, str] | None = None) -> tuple[np.ndarray, subprocess.CompletedProcess]:
    """Run ``vec`` ((N, 2) operand bit patterns) through the harness in ``work_dir``; return the flat results (one
    word per operator of ``OPS`` and vector, when it finished) and the finished process (its stdout: the
    latencies and the counts)."""
    inp, outp = work_dir / "in.bin", work_dir / "out.bin"
    vec.astype("<u4").tofile(inp)
    proc = subprocess.run([str(exe), str(inp), str(outp), str(seed), str(IDLE_PERCENT)], capture_output=True,
                          text=True, env=None if env is None else dict(env))
    return (np.fromfile(outp, dtype="<u4") if outp.exists() else np.zeros(0, np.uint32)), proc
