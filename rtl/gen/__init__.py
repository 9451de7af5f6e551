"""Generator of the kernel's pipelined datapath modules and of the contracts' generated copies (``python -m rtl.gen``).

``rtl/gen/dataflow.py`` is the dataflow DSL, ``rtl/gen/operator_schedule.py`` its ASAP scheduler (operator latencies:
``rtl/gen/operator_timing.py``), ``rtl/gen/sv_emit.py`` the SystemVerilog emitter;
``rtl/gen/kernel_graphs.py`` holds the contact, friction and integration graphs. :func:`generate` writes, into
``rtl/generated/`` (never edited by hand; ``python -m rtl.gen --check`` and the test suite check that the committed
copies are current):

* ``pgs_contact_pipe.sv``, ``pgs_friction_pipe.sv``, ``pgs_integrate_pipe.sv``: the datapaths, and the contact and
  friction pipes of the other inverse-inertia modes (``pgs_contact_pipe_scalar.sv``, ``pgs_contact_pipe_full.sv``,
  ``pgs_friction_pipe_scalar.sv``, ``pgs_friction_pipe_full.sv``: the kernel's ``IINV_W`` = 1 or 6), and the friction
  pipes of every mode taking the manifold's friction coefficient as a word (``pgs_friction_pipe_mu.sv``,
  ``pgs_friction_pipe_scalar_mu.sv``, ``pgs_friction_pipe_full_mu.sv``: the kernel's ``MU_W`` = 1);
* ``pgs_shared_pipe.sv`` and its variants of the same options (:data:`rtl.gen.kernel_graphs.SHARED_GRAPHS`): a lane's
  contact and friction passes on one datapath (``rtl/gen/shared_datapath.py`` binds the two graphs,
  ``rtl/gen/shared_emit.py`` writes the module), what the kernel's lanes take with ``SHARED_DATAPATH = 1``;
* ``pgs_pipe_latency_pkg.sv`` and ``pipe_latency.json``: each module's LATENCY as a function of MAN_BITS, for the
  sequencer and for the cycle model (``rtl/gen/pipe_latency.py``);
* ``pgs_regs_pkg.sv``: the register map of ``models/kernel/register_map.py`` (``rtl/gen/register_map_emit.py``),
* ``pgs_stream_layout_pkg.sv``: the constraint records' layout of ``models/kernel/stream_format.py`` for the sequencer
  (``rtl/gen/stream_layout_emit.py``),

and ``hls_export/generated/pgs_regs.h``, the same register map for the HLS kernel,
``hls_export/generated/pgs_stream_layout.h``, the record sizes of ``models/kernel/stream_format.py``
(``rtl/gen/stream_layout_emit.py``), and ``hls_export/generated/pgs_shared_datapath.h``, the shared datapaths as C++
(``rtl/gen/shared_hls_emit.py``).

The HLS back end (Google XLS) writes the same graphs as DSLX (``rtl/gen/dslx_emit.py``, one function per point update),
compiles them into pipelined Verilog of the hand pipes' depths and wraps them in the hand pipes' module names and
ports (``rtl/gen/xls_wrap_emit.py``, ``rtl/gen/xls_flow.py``: ``python -m rtl.gen.xls_flow``, ``make xls``), into
``rtl/generated/xls/``; a kernel build with ``datapath="xls"`` takes them in place of the hand pipes.

The co-simulation test's injected bug is a variant of the friction pipe (and of the shared datapath with that friction
pass) that only :func:`generate_friction_sign_bug` writes, into a build directory; :func:`friction_sign_bug_sources` is
the kernel's source list with them swapped in.
"""

from __future__ import annotations

from pathlib import Path

from models.timing.kernel_shape import PIPE_LATENCY_FILE

from rtl.gen.file_list import RTL_DIR, kernel_sources, swap_sources
from rtl.gen.kernel_graphs import GRAPHS, MAN_BITS_OF, MODE_GRAPHS, SHARED_GRAPHS, friction_graph, shared_graph
from rtl.gen.pipe_latency import LATENCY_PKG, emit_latency_json, emit_latency_pkg
from rtl.gen.register_map_emit import REGS_HEADER, REGS_PKG, emit_regs_header, emit_regs_pkg
from rtl.gen.repo_paths import REPO_ROOT
from rtl.gen.stream_layout_emit import (STREAM_LAYOUT_HEADER, STREAM_LAYOUT_PKG, emit_stream_layout_header,
                                        emit_stream_layout_pkg)
from rtl.gen.sv_emit import emit_sv
from rtl.gen.shared_emit import emit_shared_sv
from rtl.gen.shared_hls_emit import HEADER_FILE as SHARED_HEADER, emit_shared_header
from rtl.gen.operator_schedule import schedule
from rtl.gen.operator_timing import Time

GENERATED_DIR = RTL_DIR / "generated"
HLS_GENERATED_DIR = REPO_ROOT / "hls_export" / "generated"

__all__ = ["GENERATED_DIR", "HLS_GENERATED_DIR", "LATENCY_PKG", "REGS_PKG", "SHARED_PIPE", "friction_sign_bug_sources",
           "generate", "generate_friction_sign_bug", "latencies", "pipe_latencies", "render"]


SHARED_PIPE = "pgs_shared_pipe"  # the shared datapath whose latency the package and the JSON give (every variant's)


def pipe_latencies(shared_latency: Time | None = None) -> dict[str, Time]:
    """The LATENCY of each pipe the latency package and JSON give: the default pipes, the shared datapath."""
    out = {name: schedule(make()).latency for name, make in GRAPHS.items()}
    out[SHARED_PIPE] = shared_latency or SHARED_GRAPHS[SHARED_PIPE]().latency
    return out


def render() -> dict[Path, str]:
    """The text of every generated file, by path."""
    files = {GENERATED_DIR / f"{name}.sv": emit_sv(make()) for name, make in {**GRAPHS, **MODE_GRAPHS}.items()}
    shared = {name: make() for name, make in SHARED_GRAPHS.items()}
    files |= {GENERATED_DIR / f"{name}.sv": emit_shared_sv(dp) for name, dp in shared.items()}
    files[HLS_GENERATED_DIR / SHARED_HEADER] = emit_shared_header(list(shared.values()))
    lats = pipe_latencies(shared[SHARED_PIPE].latency)
    files[GENERATED_DIR / f"{LATENCY_PKG}.sv"] = emit_latency_pkg(lats)
    files[PIPE_LATENCY_FILE] = emit_latency_json(lats)
    files[GENERATED_DIR / f"{REGS_PKG}.sv"] = emit_regs_pkg()
    files[GENERATED_DIR / f"{STREAM_LAYOUT_PKG}.sv"] = emit_stream_layout_pkg()
    files[HLS_GENERATED_DIR / REGS_HEADER] = emit_regs_header()
    files[HLS_GENERATED_DIR / STREAM_LAYOUT_HEADER] = emit_stream_layout_header()
    return files


def generate(check: bool = False) -> list[Path]:
    """Write the generated files (or, with ``check``, return the ones that are out of date)."""
    stale = []
    for path, text in render().items():
        if not path.exists() or path.read_text() != text:
            stale.append(path)
            if not check:
                path.parent.mkdir(parents=True, exist_ok=True)
                path.write_text(text)
    return stale


def latencies() -> dict[str, dict[str, int]]:
    """LATENCY of each generated module of the latency package for each kernel format."""
    return {name: {fmt: lat.eval(mb) for fmt, mb in MAN_BITS_OF.items()} for name, lat in pipe_latencies().items()}


def generate_friction_sign_bug(out_dir: Path) -> list[Path]:
    """Write the friction pipe with the injected sign bug (``friction_graph(sign_bug=True)``: each tangent row's
    velocity update applied with +delta) as ``out_dir/pgs_friction_pipe.sv``, and the shared datapath with that
    friction pass as ``out_dir/pgs_shared_pipe.sv``; return their paths. The modules have the product modules' names
    and ports, for a test build only: ``out_dir`` must lie outside ``rtl/``."""
    out_dir = Path(out_dir).resolve()
    if out_dir == RTL_DIR or RTL_DIR in out_dir.parents:
        raise ValueError(f"the injected-bug variant goes to a build directory, not into {out_dir}")
    out_dir.mkdir(parents=True, exist_ok=True)
    texts = {"pgs_friction_pipe.sv": emit_sv(friction_graph(sign_bug=True)),
             f"{SHARED_PIPE}.sv": emit_shared_sv(shared_graph(sign_bug=True))}
    paths = []
    for name, text in texts.items():
        path = out_dir / name
        if not path.is_file() or path.read_text() != text:  # unchanged: Verilator's dependency check skips the rebuild
            path.write_text(text)
        paths.append(path)
    return paths


def friction_sign_bug_sources(out_dir: Path) -> list[Path]:
    """The kernel's sources (``rtl/pgs_kernel.f``) with the friction pipe and the shared datapath replaced by the
    injected-bug variants, generated into ``out_dir`` (:func:`generate_friction_sign_bug`)."""
    return swap_sources(kernel_sources(), generate_friction_sign_bug(out_dir))
