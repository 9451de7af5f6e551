"""The one description of a kernel build, and the build of the compiled Verilator harness from it.

Every build of ``rtl/pgs_kernel.sv`` takes its Verilator parameters, RTL sources, harness defines and compile
arguments from a :class:`KernelBuild`: the harness of ``make sim``, ``make sweep`` and the harness tests
(:func:`build_kernel`), the coverage builds (:func:`verilate_kernel` with the coverage hooks added) and the
cocotb benches (``sim.drive.cocotb_run.run_kernel_cocotb``). A description is frozen and hashable; its
:attr:`KernelBuild.name` names its build directory, so two descriptions that differ build apart. A process that
calls :func:`use_kernel_store` (the executor's points: ``sim/parallel/executor.py``) takes :func:`build_kernel`'s
executables from a store keyed by the hash of the description instead (``sim.compile.artefacts.KernelStore``).

    kb = KernelBuild.for_job(job, get_preset("zcu102"))
    exe, seconds = build_kernel(kb)  # build/verilator/pgs_kernel_e8m23_c512/pgs_kernel_e8m23_c512
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from models.kernel import stream_format as sf
from models.kernel.body_banks import check_banks
from models.kernel.delay_lines import check_block_min_depth
from models.timing.platforms import DmaPreset
from models.kernel.kernel_job import KernelJob
from models.timing.kernel_shape import KernelShape
from models.formats.number_format import NumberFormat
from rtl.gen import friction_sign_bug_sources
from rtl.gen.file_list import kernel_sources, rtl_files
from rtl.gen.xls_flow import XLS_FORMATS, xls_sources
from sim.compile.verilator_build import DEBUG_COMPILE_ARGS, QUICK_COMPILE_ARGS, REPO_ROOT, build, profile_guided_build

TOP = "pgs_kernel"
HARNESS_DIR = REPO_ROOT / "sim" / "harness"
HARNESS = HARNESS_DIR / "pgs_kernel_main.cpp"
# the signals the cocotb benches touch (everything else stays private: faster models of the large design)
PUBLIC_VLT = HARNESS_DIR / "pgs_kernel_public.vlt"
# waves builds of the compiled harness: the sequencer's phase readable (the harness notes each phase start)
WAVES_VLT = HARNESS_DIR / "pgs_kernel_waves.vlt"
# generated RTL variants for test builds (never under rtl/): the friction pipe with the injected sign bug
VARIANT_ROOT = REPO_ROOT / "build" / "rtl_variants"

# C++ optimization profiles (sim.compile.verilator_build): "quick" -O1 for kernel runs; "o0" for short runs (-O0 without
# -fno-inline, which would split the kernel into ~330 C++ files and take longer to build than -O1); "o2" (-O2 for
# the model's hot code) and "os" (-Os, Verilator's own default: smaller code for a model limited by the
# instruction cache; faster than "quick" on the thesis frame for several times its C++ compile time, measured in
# docs/results/cosim_speed.md), "o2native" (-O2 -march=native on every file: an
# executable for this CPU only, never for a shared kernel store) to be measured against "quick" with `make bench`
# (sim/bench.py) on an idle machine (their two unity-built translation units compile several times
# longer than at -O1)
COMPILE_PROFILES: dict[str, tuple[str, ...]] = {
    "quick": tuple(QUICK_COMPILE_ARGS),
    "o0": tuple(a for a in DEBUG_COMPILE_ARGS if a != "-fno-inline"),
    "o2": ("-MAKEFLAGS", "OPT_FAST=-O2 OPT_SLOW=-O0 OPT_GLOBAL=-O1"),
    "os": ("-MAKEFLAGS", "OPT_FAST=-Os OPT_SLOW=-O0 OPT_GLOBAL=-O1"),
    "o2native": ("-CFLAGS", "-march=native", "-MAKEFLAGS", "OPT_FAST=-O2 OPT_SLOW=-O0 OPT_GLOBAL=-O1"),
    # two Verilator threads: faster in wall time on an idle 2-core machine, slower in CPU time (make bench)
    "t2": ("--threads", "2", "-MAKEFLAGS", "OPT_FAST=-O1 OPT_SLOW=-O0 OPT_GLOBAL=-O1"),
    # "quick" with g++'s profile-guided optimization (sim.compile.verilator_build.profile_guided_build): built twice,
    # with a training run between (the caller's: build_kernel's ``train``)
    "pgo": tuple(QUICK_COMPILE_ARGS),
}
PROFILE_GUIDED = frozenset({"pgo"})  # the profiles built with a training run
DATAPATHS = ("rtl", "xls")  # whose pipes a build takes (KernelBuild.datapath)
# The build options the XLS datapath has no pipes for yet, by KernelBuild field: (the option as a user names it,
# whether a value needs it). The one table of check_datapath's refusals: a pipe variant XLS does not compile (or a
# datapath of another shape) adds its row here, and every caller refuses it with the same line.
XLS_UNCOVERED: dict[str, tuple[str, Callable[[Any], bool]]] = {
    "inertia_words": ("IINV_W = 1 or 6 (the scalar or full inverse inertia)", lambda v: v != sf.KERNEL_INERTIA_WORDS),
    "friction_words": ("MU_W = 1 (the friction coefficient per manifold)", bool),
    "tangents_on_chip": ("TANGENTS=chip (the tangents derived on chip)", bool),
    "soft_contact": ("SOFT_CONTACT (the soft contact pipe)", bool),
    "friction_sign_bug": ("the injected friction sign bug", bool),
    # XLS compiles the contact and the friction pipe; the lane's shared datapath is not emitted as DSLX yet
    "shared_datapath": ("SHARED_DATAPATH=1 (one datapath per lane; DATAPATH=xls takes SHARED_DATAPATH=0)", bool),
    # the XLS modules carry adders of their own; fp_add's DSP48E2 form is one of the generated pipes
    "add_dsp": ("ADD_DSP=1 (the DSP48E2 adders of the generated pipes; the XLS modules have their own)", bool),
}
WAVE_ARGS = ("--trace-fst", "--trace-structs")


@dataclass(frozen=True)
class KernelBuild:
    """One parameter set of the kernel (each gets its own build directory, :attr:`name`)."""

    fmt: NumberFormat
    cons_bits: int = 512
    body_in_bits: int = 128
    body_out_bits: int = 128
    max_bodies: int = 65536
    max_manifolds: int = 262144
    waves: bool = False
    window: int = 0  # WINDOW: 0 streams every pass; > 0 the window kernel with a ring of that many records
    window_ctx: int = 8
    lanes: int = 1  # LANES: manifolds issued per cycle (> 1: window kernel only)
    inertia_words: int = sf.KERNEL_INERTIA_WORDS  # IINV_W: inverse-inertia words per body (1, 3 or 6)
    impulses_in_records: bool = False  # IMPULSES_IN_RECORDS: no impulse RAM, impulses in the records and m_axis_imp
    friction_words: int = 0  # MU_W: friction-coefficient words per friction record (0 the constant, 1 a word)
    body_banks: int = 0  # BODY_BANKS: body velocities in that many true dual-port banks (0: multiport; one lane only)
    tangents_on_chip: bool = False  # TANGENTS_ON_CHIP: friction records without t0, t1 (pgs_friction_pipe_tb)
    soft_contact: bool = False  # SOFT_CONTACT: the soft contact pipe (lam * keep before the add; 3 inertia words)
    # DELAY_BLOCK_MIN_DEPTH: the pipes' delay lines at least this deep in block RAM (0: LUT RAM); a synthesis
    # attribute, the same simulation, but the parameter set of the design a run reports (models/kernel/delay_lines.py)
    delay_block_min_depth: int = 0
    friction_sign_bug: bool = False  # the friction pipe with the wrong sign (the scoreboard must catch it)
    # SHARED_DATAPATH: one datapath per lane for both passes (rtl/pgs_lane_datapath.sv), else a contact and a friction
    # pipe per lane (the streaming kernel drains the other pipe at a switch of kinds)
    shared_datapath: bool = True
    # ADD_SHIFT_DSP: every fp_add of the pipes in its DSP48E2 form (rtl/fp/fp_add.sv, SHIFT_DSP), else in the fabric;
    # the same results and latency, another design (the fit's figures, sim/fit/resource_model.py KernelConfig.adders)
    add_dsp: bool = False
    compile_profile: str = "quick"  # a key of COMPILE_PROFILES
    # whose pipes: "rtl" the hand-scheduled ones of rtl/generated/, "xls" those Google XLS compiled from their DSLX
    # (rtl/generated/xls/, rtl/gen/xls_flow.py: the same module names, ports and latencies)
    datapath: str = "rtl"

    def __post_init__(self) -> None:
        sf.body_in_word_count(self.inertia_words)  # 1, 3 or 6, else a ValueError
        if self.friction_words not in (0, 1):
            raise ValueError(f"a friction record carries 0 or 1 friction-coefficient words, got {self.friction_words}")
        check_banks(self.body_banks)
        if self.lanes < 1 or self.lanes & (self.lanes - 1) or (self.lanes > 1 and not self.window):
            raise ValueError(f"lanes must be a power of two, and above 1 only with the window kernel (window > 0), "
                             f"got {self.lanes}")
        if self.tangents_on_chip and (self.window or self.inertia_words != sf.KERNEL_INERTIA_WORDS
                                      or self.friction_words or self.friction_sign_bug):
            raise ValueError("the tangent basis derived on chip (tangents_on_chip) is a configuration of the streaming "
                             "kernel with the diagonal inverse inertia and the constant friction coefficient")
        if self.soft_contact and (self.window or self.lanes > 1):
            raise ValueError("the soft contact pipe (soft_contact) is a configuration of the streaming kernel")
        if self.soft_contact and self.inertia_words != sf.KERNEL_INERTIA_WORDS:
            raise ValueError(f"the soft contact pipe (soft_contact) is built for {sf.KERNEL_INERTIA_WORDS} "
                             f"inverse-inertia words per body, got {self.inertia_words}")
        check_block_min_depth(self.delay_block_min_depth)
        if self.compile_profile not in COMPILE_PROFILES:
            raise ValueError(f"compile profile {self.compile_profile!r}: expected one of {sorted(COMPILE_PROFILES)}")
        check_datapath(self.datapath, self.fmt, {field: getattr(self, field) for field in XLS_UNCOVERED})

    @staticmethod
    def for_job(job: KernelJob, preset: DmaPreset, waves: bool = False, body_bits: int = 128,
                datapath: str = "rtl") -> "KernelBuild":
        """The build that runs ``job``: the preset's constraint beat, the window plan's ring, contexts and lanes,
        body streams of ``body_bits``, the job's inverse-inertia and friction-coefficient words, its friction
        record layout (the tangents derived on chip), the soft contact pipe for a soft job
        (``SolverParams.soft_keep``), its lanes' datapath (``KernelJob.shared_datapath``) and adder form
        (``KernelJob.add_dsp``); ``datapath``: whose pipes (:data:`DATAPATHS`)."""
        plan = job.record_window
        return KernelBuild(job.fmt, cons_bits=preset.stream_bits, body_in_bits=body_bits, body_out_bits=body_bits,
                           waves=waves, window=0 if plan is None else plan.depth,
                           window_ctx=8 if plan is None else plan.ctx, lanes=1 if plan is None else plan.lanes,
                           inertia_words=job.inertia_words, impulses_in_records=job.impulses_in_records,
                           friction_words=job.friction_words, body_banks=job.body_banks,
                           tangents_on_chip=job.tangents_on_chip,
                           soft_contact=job.params.soft_keep is not None,
                           delay_block_min_depth=job.delay_block_min_depth, shared_datapath=job.shared_datapath,
                           add_dsp=job.add_dsp, datapath=datapath)

    @property
    def name(self) -> str:
        wide_bodies = (self.body_in_bits, self.body_out_bits) != (128, 128)
        return (f"{TOP}_e{self.fmt.exp_bits}m{self.fmt.man_bits}_c{self.cons_bits}"
                + (f"_b{self.body_in_bits}x{self.body_out_bits}" if wide_bodies else "")
                + (f"_w{self.window}x{self.window_ctx}" if self.window else "")
                + (f"_l{self.lanes}" if self.lanes > 1 else "")
                + (f"_i{self.inertia_words}" if self.inertia_words != sf.KERNEL_INERTIA_WORDS else "")
                + ("_ir" if self.impulses_in_records else "")
                + ("_mu" if self.friction_words else "")
                + (f"_bk{self.body_banks}" if self.body_banks else "")
                + ("_tb" if self.tangents_on_chip else "")
                + ("_soft" if self.soft_contact else "")
                + (f"_dl{self.delay_block_min_depth}" if self.delay_block_min_depth else "")
                + ("" if self.shared_datapath else "_split")
                + ("_dspadd" if self.add_dsp else "")
                + ("_friction_sign_bug" if self.friction_sign_bug else "")
                + (f"_{self.compile_profile}" if self.compile_profile != "quick" else "")
                + ("_xls" if self.datapath == "xls" else "")
                + ("_waves" if self.waves else ""))

    @property
    def trace_bytes(self) -> int:
        return sf.trace_record_bytes(self.fmt)

    @property
    def parameters(self) -> dict[str, int]:
        """The Verilator ``-G`` parameters of ``pgs_kernel``."""
        return {"EXP_BITS": self.fmt.exp_bits, "MAN_BITS": self.fmt.man_bits, "MAX_BODIES": self.max_bodies,
                "MAX_MANIFOLDS": self.max_manifolds, "BODY_IN_W": self.body_in_bits, "CONS_W": self.cons_bits,
                "BODY_OUT_W": self.body_out_bits} | (
                    {"WINDOW": self.window, "WINDOW_CTX": self.window_ctx} if self.window else {}) | (
                    {"LANES": self.lanes} if self.lanes > 1 else {}) | (
                    {"IINV_W": self.inertia_words} if self.inertia_words != sf.KERNEL_INERTIA_WORDS else {}) | (
                    {"IMPULSES_IN_RECORDS": 1} if self.impulses_in_records else {}) | (
                    {"MU_W": self.friction_words} if self.friction_words else {}) | (
                    {"BODY_BANKS": self.body_banks} if self.body_banks else {}) | (
                    {"TANGENTS_ON_CHIP": 1} if self.tangents_on_chip else {}) | (
                    {"SOFT_CONTACT": 1} if self.soft_contact else {}) | (
                    {"DELAY_BLOCK_MIN_DEPTH": self.delay_block_min_depth} if self.delay_block_min_depth else {}) | (
                    {} if self.shared_datapath else {"SHARED_DATAPATH": 0}) | (
                    {"ADD_SHIFT_DSP": 1} if self.add_dsp else {})

    @property
    def layout(self) -> sf.StreamLayout:
        return sf.StreamLayout(self.fmt, self.cons_bits, self.body_in_bits, self.inertia_words,
                               self.impulses_in_records, self.friction_words, self.tangents_on_chip)

    @property
    def defines(self) -> dict[str, int]:
        """The C++ defines of the compiled harness (its stream and trace byte widths, its lanes; with the impulses
        in the records their record layout and the impulse-out record's bytes)."""
        out = {"BODY_IN_BYTES": self.body_in_bits // 8, "CONS_BYTES": self.cons_bits // 8,
               "BODY_OUT_BYTES": self.body_out_bits // 8, "TRACE_BYTES": self.trace_bytes, "LANES": self.lanes}
        if self.impulses_in_records:
            w, lay = self.fmt.width, self.layout
            out |= {"IMPULSES_IN_RECORDS": 1, "WORD_BITS": w, "IMP_OUT_BYTES": sf.impulse_out_bytes(self.fmt, self.lanes),
                    "CONTACT_BEATS": lay.contact_beats, "FRICTION_BEATS": lay.friction_beats,
                    "CONTACT_LAM_BIT": sf.HEADER_BITS + sf.CONTACT_LAM_WORD * w,
                    "FRICTION_LAM_BIT": sf.HEADER_BITS + lay.friction_lam_word * w,
                    "FRICTION_LAMT_BIT": sf.HEADER_BITS + lay.friction_lamt_word * w}
        return out

    @property
    def cflags(self) -> list[str]:
        return [f"-D{k}={v}" for k, v in self.defines.items()]

    @property
    def compile_args(self) -> list[str]:
        """Verilator options and ``-MAKEFLAGS`` of the compile profile, with FST tracing when ``waves``."""
        return [*COMPILE_PROFILES[self.compile_profile], *(WAVE_ARGS if self.waves else ())]

    def sources(self) -> list[Path]:
        """The SystemVerilog files of the kernel (``rtl/pgs_kernel.f``), packages first; with ``friction_sign_bug``
        the friction pipe and the shared datapath are the variants ``rtl.gen`` generates into
        ``build/rtl_variants/friction_sign_bug/``; with the XLS datapath the pipes are those of ``rtl/generated/xls/``
        (``rtl.gen.xls_flow.xls_sources``)."""
        if self.friction_sign_bug:
            base = friction_sign_bug_sources(VARIANT_ROOT / "friction_sign_bug")
        elif self.datapath == "xls":
            base = xls_sources(kernel_sources())
        else:
            base = None
        packages, modules = rtl_files(base)
        return packages + modules


def kernel_build_args(kb: KernelBuild, build_dir: Path | None = None, extra_sources: Sequence[Path] = (),
                      extra_cpp_files: Sequence[Path] = (), extra_args: Sequence[str] = ()) -> dict[str, Any]:
    """The ``sim.compile.verilator_build.build`` keywords of ``kb``'s compiled harness (plus ``extra_*``): what every
    kernel build runs, and what ``sim.compile.artefacts.build_key`` hashes."""
    return {"sources": [*([WAVES_VLT] if kb.waves else []), *kb.sources(), *extra_sources], "top": TOP, "parameters": kb.parameters,
            "cpp_files": [HARNESS, *extra_cpp_files], "build_dir": build_dir, "name": kb.name, "cflags": kb.cflags,
            "extra_args": ["-Wno-fatal", *kb.compile_args, *extra_args]}


Trainer = Callable[[Path], None]  # runs a profile-guided build's instrumented harness (its argument) once


def verilate_kernel(kb: KernelBuild, build_dir: Path | None = None, extra_sources: Sequence[Path] = (),
                    extra_cpp_files: Sequence[Path] = (), extra_args: Sequence[str] = (), lock: bool = True,
                    train: Trainer | None = None) -> Path:
    """Build the compiled harness of ``kb`` (plus ``extra_*``, e.g. coverage hooks) into ``build_dir`` (default
    ``build/verilator/<kb.name>``); return the executable. Verilator skips an unchanged build. ``lock=False``: no
    lock file beside ``build_dir`` (a directory no other process uses). A profile-guided compile profile
    (:data:`PROFILE_GUIDED`) needs ``train`` (e.g. ``sim.drive.harness_run.training_run``): the harness it trains on."""
    args = kernel_build_args(kb, build_dir, extra_sources, extra_cpp_files, extra_args)
    if kb.compile_profile not in PROFILE_GUIDED:
        return build(**args, lock=lock)
    if train is None:
        raise ValueError(f"compile profile {kb.compile_profile!r} is profile-guided: its build needs a training run "
                         "(train=sim.drive.harness_run.training_run(...))")
    return profile_guided_build(args, train, lock=lock)


class KernelExecutables(Protocol):
    """Where :func:`build_kernel` takes executables from instead of ``build/verilator``
    (``sim.compile.artefacts.KernelStore``: keyed by the hash of the build description)."""

    def executable(self, kb: KernelBuild) -> tuple[Path, float]: ...


_built: dict[KernelBuild, tuple[Path, float]] = {}
_store: KernelExecutables | None = None


def use_kernel_store(store: KernelExecutables | None) -> None:
    """Take this process's kernel builds from ``store`` (``None``: build into ``build/verilator`` again)."""
    global _store
    _store = store


def build_kernel(kb: KernelBuild, train: Trainer | None = None) -> tuple[Path, float]:
    """The harness executable of ``kb`` (built once per process; Verilator skips unchanged builds, or from the
    store set by :func:`use_kernel_store`) and the seconds the build took. ``train``: the training run of a
    profile-guided compile profile (:func:`verilate_kernel`)."""
    if kb not in _built:
        t0 = time.monotonic()
        if _store is not None and kb.compile_profile in PROFILE_GUIDED:
            raise ValueError(f"compile profile {kb.compile_profile!r}: a profile-guided build is not taken from a "
                             "kernel store (its training run is the caller's)")
        exe = verilate_kernel(kb, train=train) if _store is None else _store.executable(kb)[0]
        _built[kb] = (exe, time.monotonic() - t0)
    return _built[kb]


def check_datapath(datapath: str, fmt: NumberFormat, options: Mapping[str, Any]) -> None:
    """Raise ValueError (one line) unless ``datapath`` (:data:`DATAPATHS`) has pipes for ``fmt`` and ``options``
    (KernelBuild fields and their values; a caller leaves out those it does not know yet): the XLS datapath covers
    the formats of ``rtl.gen.xls_flow.XLS_FORMATS`` and none of :data:`XLS_UNCOVERED`."""
    if datapath not in DATAPATHS:
        raise ValueError(f"datapath {datapath!r}: expected one of {', '.join(DATAPATHS)}")
    if datapath == "rtl":
        return
    uncovered = [] if any((f.exp_bits, f.man_bits) == (fmt.exp_bits, fmt.man_bits) for f in XLS_FORMATS) else [
        f"FORMAT={fmt.name} (E = {fmt.exp_bits}, M = {fmt.man_bits})"]
    uncovered += [name for field, (name, needs) in XLS_UNCOVERED.items() if field in options and needs(options[field])]
    if uncovered:
        raise ValueError(f"DATAPATH=xls does not cover {'; '.join(uncovered)} yet: XLS compiled the default pipes "
                         f"(diagonal inverse inertia, constant friction coefficient, tangents from the host) in "
                         f"{', '.join(f.name for f in XLS_FORMATS)}")


def default_window(fmt: NumberFormat, cons_bits: int, shared_datapath: bool = True, window_kernel: bool = False) -> int:
    """Issue slots a manifold must wait before its bodies come back, the hazard schedule's window: the deeper pipe's
    latency in records (latencies from the generated ``rtl/generated/pipe_latency.json``, through
    ``models.timing.kernel_shape``; the shared datapath's for both kinds, else each kind's pipe's).

    ``window_kernel``: the schedule of a window kernel's step, whose banded orders keep the two pipes' window whatever
    the datapath (a wider one widens the band and the passes' lag: on the thesis frame, fp32 one lane, the sweep order
    at W = 181 takes 1.3935 cycles per manifold-pass against 1.2175 at the two pipes' 112; the window kernel had both
    kinds at the contact pipe's latency already)."""
    shape = KernelShape.of(fmt, cons_bits, shared_datapath=shared_datapath and not window_kernel)
    return max(math.ceil(shape.contact_latency / shape.contact_beats),
               math.ceil(shape.friction_latency / shape.friction_beats)) + 2
