"""The kernel build description (sim/compile/kernel_build.py) and the harness's register writes
(sim/drive/harness_run.py), without building anything."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from models.kernel import register_map
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.golden.integrator import IntegrationParams
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32
from sim.drive.cocotb_run import kernel_cocotb_build
from sim.drive.harness_run import register_writes, write_inputs
from sim.compile.kernel_build import HARNESS, PUBLIC_VLT, VARIANT_ROOT, KernelBuild


def test_names_are_distinct_per_description() -> None:
    """Every field that changes the build changes the directory name; the default keeps its historic name."""
    base = KernelBuild(FP32)
    assert base.name == "pgs_kernel_e8m23_c512"
    variants = [KernelBuild(FP16), KernelBuild(FP32, cons_bits=256),
                KernelBuild(FP32, body_in_bits=512, body_out_bits=512), KernelBuild(FP32, window=1024),
                KernelBuild(FP32, window=1024, window_ctx=4), KernelBuild(FP32, window=1024, lanes=2),
                KernelBuild(FP32, waves=True), KernelBuild(FP32, friction_sign_bug=True),
                KernelBuild(FP32, compile_profile="o0"), KernelBuild(FP32, inertia_words=1),
                KernelBuild(FP32, inertia_words=6), KernelBuild(FP32, inertia_words=6, friction_words=1),
                KernelBuild(FP32, soft_contact=True)]
    names = [base.name] + [v.name for v in variants]
    assert len(set(names)) == len(names), names
    assert len({base, *variants}) == len(names)  # hashable, distinct
    assert KernelBuild(FP32, window=1024, lanes=2).name == "pgs_kernel_e8m23_c512_w1024x8_l2"
    assert KernelBuild(FP32, waves=True).name == "pgs_kernel_e8m23_c512_waves"
    assert KernelBuild(FP32, inertia_words=6).name == "pgs_kernel_e8m23_c512_i6"
    with pytest.raises(ValueError, match="compile profile"):
        KernelBuild(FP32, compile_profile="fast")
    assert KernelBuild(FP32, inertia_words=6, friction_words=1).name == "pgs_kernel_e8m23_c512_i6_mu"
    with pytest.raises(ValueError, match="1, 3 or 6"):
        KernelBuild(FP32, inertia_words=4)
    with pytest.raises(ValueError, match="0 or 1 friction-coefficient words"):
        KernelBuild(FP32, friction_words=2)
    for lanes, window in ((2, 0), (3, 1024)):
        with pytest.raises(ValueError, match="lanes must be a power of two"):
            KernelBuild(FP32, window=window, lanes=lanes)
    tb = KernelBuild(FP32, impulses_in_records=True, body_banks=2, tangents_on_chip=True, delay_block_min_depth=65)
    assert tb.name == "pgs_kernel_e8m23_c512_ir_bk2_tb_dl65" and tb.parameters["TANGENTS_ON_CHIP"] == 1
    assert "TANGENTS_ON_CHIP" not in KernelBuild(FP32, impulses_in_records=True, body_banks=2).parameters
    assert (tb.layout.friction_beats, tb.defines["FRICTION_LAM_BIT"]) == (1, 64 + 8 * 32)
    for bad in ({"window": 1024}, {"inertia_words": 6}, {"friction_words": 1}, {"friction_sign_bug": True}):
        with pytest.raises(ValueError, match="tangent basis derived on chip"):
            KernelBuild(FP32, tangents_on_chip=True, **bad)


def test_parameters_defines_and_args() -> None:
    kb = KernelBuild(FP16, cons_bits=256, window=1024, lanes=2, waves=True)
    assert kb.parameters == {"EXP_BITS": 5, "MAN_BITS": 10, "MAX_BODIES": 65536, "MAX_MANIFOLDS": 262144,
                             "BODY_IN_W": 128, "CONS_W": 256, "BODY_OUT_W": 128, "WINDOW": 1024, "WINDOW_CTX": 8,
                             "LANES": 2}
    assert kb.defines == {"BODY_IN_BYTES": 16, "CONS_BYTES": 32, "BODY_OUT_BYTES": 16, "TRACE_BYTES": 2 * 16 + 8,
                          "LANES": 2}
    assert "--trace-fst" in kb.compile_args and "--trace-fst" not in KernelBuild(FP16).compile_args
    assert "OPT_FAST=-O0 OPT_SLOW=-O0 OPT_GLOBAL=-O0" in KernelBuild(FP32, compile_profile="o0").compile_args
    # the inverse-inertia words only where they differ from the default build's 3 (the historic parameter sets)
    assert "IINV_W" not in kb.parameters and KernelBuild(FP32, inertia_words=6).parameters["IINV_W"] == 6
    assert "MU_W" not in kb.parameters and KernelBuild(FP32, friction_words=1).parameters["MU_W"] == 1
    sources = kb.sources()
    assert any(s.name == "pgs_kernel.sv" for s in sources) and all(s.suffix == ".sv" for s in sources)
    assert HARNESS.is_file() and PUBLIC_VLT.is_file()


def test_friction_sign_bug_swaps_the_friction_pipe() -> None:
    """The bug build has the product parameters and sources except the friction pipe and the shared datapath (the
    friction pass of either lane form), variants generated outside rtl/."""
    good, bad = KernelBuild(FP32), KernelBuild(FP32, friction_sign_bug=True)
    assert bad.parameters == good.parameters
    swapped = [(g, b) for g, b in zip(good.sources(), bad.sources(), strict=True) if g != b]
    assert [(g.name, b.name) for g, b in swapped] == [("pgs_friction_pipe.sv",) * 2, ("pgs_shared_pipe.sv",) * 2]
    for g, b in swapped:
        assert g.parent.name == "generated" and VARIANT_ROOT in b.parents and g.read_text() != b.read_text()


def test_cocotb_build_is_the_harness_build(monkeypatch: pytest.MonkeyPatch) -> None:
    """The cocotb benches build the kernel from the same description as the compiled harness."""
    monkeypatch.setenv("WAVES", "0")
    kb = kernel_cocotb_build("fp32", "zcu102")
    assert kb == KernelBuild(FP32, cons_bits=get_preset("zcu102").stream_bits)
    assert kernel_cocotb_build("fp16", "ideal", friction_sign_bug=True).friction_sign_bug


def test_register_writes_use_the_register_map() -> None:
    """The harness programs every scalar argument at its offset of models/kernel/register_map.py, in argument order;
    the window kernel's two registers only for a window job, the soft contact kernel's two only for a soft job."""
    from types import SimpleNamespace

    ip = IntegrationParams(dt=1 / 60, gravity=(0.0, 0.0, -9.81))
    job = KernelJob(FP32, SimpleNamespace(num_bodies=5), None, np.array([0, 2, -1, 1]),  # type: ignore[arg-type]
                    SolverParams(4, interleaved=True), ip)
    writes = dict(register_writes(job))
    off = register_map.OFFSET
    optional = ("lag", "fetch_passes", "keep_dyn", "keep_static")
    assert [o for o, _ in register_writes(job)] == [off[n] for n in register_map.ARG_NAMES if n not in optional]
    assert writes[off["num_bodies"]] == 5 and writes[off["num_manifolds"]] == 3
    assert writes[off["iterations"]] == 4 and writes[off["options"]] == register_map.OPT_INTERLEAVED
    assert writes[off["dt"]] == int(FP32.encode(np.float64(1 / 60)))
    assert writes[off["gravity_z"]] == int(FP32.encode(np.float64(-9.81)))
    assert writes[off["damping"]] == int(FP32.encode(np.float64(ip.damping)))
    plan = SimpleNamespace(lag=7, fetch_passes=2, slots=np.array([0, 2, 1, -1]))
    windowed = dataclasses.replace(job, record_window=plan)
    wwrites = dict(register_writes(windowed))
    assert wwrites[off["lag"]] == 7 and wwrites[off["fetch_passes"]] == 2 and wwrites[off["num_manifolds"]] == 4
    soft = dict(register_writes(dataclasses.replace(job, params=SolverParams(4, soft_keep=(0.75, 0.5)))))
    assert soft[off["options"]] == register_map.OPT_SOFT_CONTACT
    assert soft[off["keep_dyn"]] == int(FP32.encode(np.float64(0.75)))
    assert soft[off["keep_static"]] == int(FP32.encode(np.float64(0.5)))


def test_soft_contact_build() -> None:
    """The soft contact pipe is its own build (SOFT_CONTACT = 1, off by default), chosen for a soft job; it is built
    for the diagonal inverse inertia on the streaming kernel only, and a soft job on another build is refused
    before any file is written."""
    kb = KernelBuild(FP32, impulses_in_records=True, soft_contact=True)
    assert kb.name == "pgs_kernel_e8m23_c512_ir_soft" and kb.parameters["SOFT_CONTACT"] == 1
    assert "SOFT_CONTACT" not in KernelBuild(FP32).parameters
    for bad in (dict(inertia_words=6), dict(window=1024)):
        with pytest.raises(ValueError, match="soft contact pipe"):
            KernelBuild(FP32, soft_contact=True, **bad)
    ip = IntegrationParams(dt=1 / 120, gravity=(0.0, 0.0, 0.0))
    from types import SimpleNamespace
    job = KernelJob(FP32, SimpleNamespace(num_bodies=5), None, np.array([0, 1]),  # type: ignore[arg-type]
                    SolverParams(1, soft_keep=(0.75, 0.5)), ip)
    with pytest.raises(ValueError, match="needs the kernel build with the soft contact pipe"):
        write_inputs(Path("/nonexistent/never/written"), job, KernelBuild(FP32))


def test_stale_dependency_files_are_dropped(tmp_path) -> None:
    """A build folder whose .d files name a moved source loses those .d files and their objects, nothing else."""
    from sim.compile.verilator_build import drop_stale_dependencies
    source = tmp_path / "main.cpp"
    source.write_text("int main() {}\n")
    (tmp_path / "kept.d").write_text(f"kept.o: {source} \\\n {source}\n")
    (tmp_path / "kept.o").write_bytes(b"\0")
    (tmp_path / "moved.d").write_text(f"moved.o: {source} \\\n {tmp_path / 'old' / 'main.cpp'}\n")
    (tmp_path / "moved.o").write_bytes(b"\0")
    assert drop_stale_dependencies(tmp_path) == [tmp_path / "moved.d"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["kept.d", "kept.o", "main.cpp"]
