"""Generator of the kernel's pipelined datapath modules (``python -m rtl.gen``).

``rtl/gen/dataflow.py`` is the dataflow DSL, ASAP scheduler and SystemVerilog emitter;
``rtl/gen/kernel_graphs.py`` holds the contact, friction and integration graphs. :func:`generate`
writes ``rtl/pgs_contact_pipe.sv``, ``rtl/pgs_friction_pipe.sv`` and ``rtl/pgs_integrate_pipe.sv``
(committed; ``python -m rtl.gen --check`` and the test suite check they are up to date).
"""

from __future__ import annotations

from pathlib import Path

from .dataflow import REPO_ROOT, emit_sv
from .kernel_graphs import GRAPHS, MAN_BITS_OF

RTL_DIR = REPO_ROOT / "rtl"


def render() -> dict[Path, str]:
    """The text of every generated file, by path."""
    return {RTL_DIR / f"{name}.sv": emit_sv(make()) for name, make in GRAPHS.items()}


def generate(check: bool = False) -> list[Path]:
    """Write the generated files (or, with ``check``, return the ones that are out of date)."""
    stale = []
    for path, text in render().items():
        if not path.exists() or path.read_text() != text:
            stale.append(path)
            if not check:
                path.write_text(text)
    return stale


def latencies() -> dict[str, dict[str, int]]:
    """LATENCY of each generated module for fp32 / fp16 / bf16."""
    out = {}
    for name, make in GRAPHS.items():
        sch = make().schedule()
        out[name] = {fmt: sch.latency_for(mb) for fmt, mb in MAN_BITS_OF.items()}
    return out
