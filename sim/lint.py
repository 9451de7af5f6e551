"""Lint every RTL top of the kernel with ``verilator --lint-only -Wall`` (``make lint``).

Each file of the kernel's source list (``rtl/pgs_kernel.f``) that is not a package holds one module named after
the file; every one of them is linted as a top from its own file plus the packages, the modules it instantiates
being found by file name in the list's folders (``-y``), two runs at a time. A module with the
``EXP_BITS`` / ``MAN_BITS`` parameters is linted with its default parameters and again with the
binary16 and bfloat16 parameter sets; one with a ``WINDOW`` parameter also as a window kernel; one with an
``IINV_W`` parameter also with the 1- and 6-word inverse inertia; one with ``IMPULSES_IN_RECORDS`` also with the
impulses in the records; one with a ``MU_W`` parameter also with the per-manifold friction word (and both together); one
with ``BODY_BANKS`` also with banked body velocities; one with ``TANGENTS_ON_CHIP`` also with the tangent basis derived
on chip; one with ``SOFT_CONTACT`` also with the soft contact pipe; one with ``SHARED_DATAPATH`` also with two pipes per
lane; one with ``ADD_SHIFT_DSP`` also with the adders' DSP48E2 form. A module that its parent instantiates unconditionally with every one of its parameters passed through
(``ELABORATED_BY_PARENT``: the sequencer inside the kernel top, the sequencer's phase modules inside it, a lane's datapath
inside the lane) is linted as a top with its defaults only: the parent's runs elaborate it with each parameter set.
The generated pipes (``rtl/generated/``: one emitter's output per option set of a family, ``pgs_shared_pipe``,
``pgs_contact_pipe``, ...) are each linted with their defaults; the other parameter sets go to the *covering* variants
only, those whose options no other variant of the family holds all of (``pgs_shared_pipe_full_mu`` covers
``pgs_shared_pipe``, ``_full`` and ``_mu``), so that every option of a family meets every parameter set in at least
one run (:func:`covering_pipes`).
The XLS datapath (``rtl/generated/xls/``, ``rtl/gen/xls_flow.py``) is linted too: each of its pipe modules as a top in
every format XLS built it for, and the kernel with those pipes (two pipes per lane) in binary32, under
``rtl/xls/xls_lint.vlt`` (the waivers of XLS's own Verilog: the bits of its internal values it does not read). Any
warning or error makes the exit status non-zero.

Usage: ``python -m sim.lint [-v] [TOP ...]`` (default: every top).
"""

from __future__ import annotations

import argparse
import re
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from models.formats.number_format import FP16, KERNEL_FORMATS, NumberFormat
from rtl.gen.file_list import rtl_files
from rtl.gen.kernel_graphs import GRAPHS, MODE_GRAPHS, SHARED_GRAPHS
from rtl.gen.xls_flow import LINT_WAIVERS, XLS_DIR, XLS_FORMATS, XLS_PIPES, wrapper_path
from sim.compile.verilator_build import REPO_ROOT, ensure_verilator_env, param_args

RTL_ROOT = REPO_ROOT / "rtl"


def format_params(fmt: NumberFormat) -> dict[str, int]:
    """The RTL parameters of a number format."""
    return {"EXP_BITS": fmt.exp_bits, "MAN_BITS": fmt.man_bits}


# Extra parameter sets for modules parameterized by the number format: every kernel format but the first, the
# modules' default parameters.
FORMAT_PARAM_SETS: dict[str, dict[str, int]] = {name: format_params(fmt)
                                                for name, fmt in list(KERNEL_FORMATS.items())[1:]}

# The window kernel: modules with a WINDOW parameter are also linted with a record window, in fp32 and fp16 (the
# window record is 3 and 2 stream beats), and with two and four issue lanes.
WINDOW_PARAM_SETS: dict[str, dict[str, int]] = {
    "window": {"WINDOW": 1024},
    "window-fp16": {"WINDOW": 1024, **format_params(FP16)},
    "window-2lanes": {"WINDOW": 1024, "LANES": 2},
    "window-4lanes-fp16": {"WINDOW": 1024, "LANES": 4, **format_params(FP16)},
}

# The inverse-inertia modes: modules with an IINV_W parameter are also linted with the scalar and the symmetric
# 3x3 body record (1 and 6 words; the default is the diagonal's 3), the full one in fp16 too.
INERTIA_PARAM_SETS: dict[str, dict[str, int]] = {
    "iinv-scalar": {"IINV_W": 1},
    "iinv-full": {"IINV_W": 6},
    "iinv-full-fp16": {"IINV_W": 6, **format_params(FP16)},
}

# The impulses travelling with the records (the streaming kernel without the impulse RAM): modules with an
# IMPULSES_IN_RECORDS parameter are also linted with it, in fp32 and fp16 (the friction record 2 and 1 beats).
IMPULSE_PARAM_SETS: dict[str, dict[str, int]] = {
    "impulses-in-records": {"IMPULSES_IN_RECORDS": 1},
    "impulses-in-records-fp16": {"IMPULSES_IN_RECORDS": 1, **format_params(FP16)},
    # the window kernel whose impulses travel with the records (its impulse ring): one lane banked, fp16 two lanes
    "window-records-banked": {"IMPULSES_IN_RECORDS": 1, "WINDOW": 1024, "BODY_BANKS": 2},
    "window-records-2lanes-fp16": {"IMPULSES_IN_RECORDS": 1, "WINDOW": 1024, "LANES": 2, "BODY_BANKS": 8,
                                   **format_params(FP16)},
}

# The banked body velocities (one copy in true dual-port banks): modules with a BODY_BANKS parameter are also linted
# with 4 banks and with 1, and with the impulses in the records in fp32 (the design that uses them).
BANK_PARAM_SETS: dict[str, dict[str, int]] = {
    "body-banks": {"BODY_BANKS": 4},
    "body-banks-1": {"BODY_BANKS": 1},
    "body-banks-impulses-in-records": {"BODY_BANKS": 4, "IMPULSES_IN_RECORDS": 1},
}

# The per-manifold friction word: modules with a MU_W parameter are also linted with it, in the full inverse-inertia
# mode (the build that runs Bullet 2 worlds), on the window kernel (the friction words of the combined record) and
# with the impulses in the records (the coefficient word before the impulses).
FRICTION_PARAM_SETS: dict[str, dict[str, int]] = {
    "mu-iinv-full": {"MU_W": 1, "IINV_W": 6},
    "mu-window": {"MU_W": 1, "WINDOW": 1024},
    "mu-impulses-in-records-fp16": {"MU_W": 1, "IMPULSES_IN_RECORDS": 1, **format_params(FP16)},
}

# The tangent basis derived on chip (the friction record without t0, t1): modules with a TANGENTS_ON_CHIP parameter are
# also linted with it, on the fp32 records design with its two body banks (the design that uses it), in fp16 with the
# impulses in the records, and with the on-chip impulse RAM.
TANGENT_PARAM_SETS: dict[str, dict[str, int]] = {
    "tangents-records-banked": {"TANGENTS_ON_CHIP": 1, "IMPULSES_IN_RECORDS": 1, "BODY_BANKS": 2},
    "tangents-records-fp16": {"TANGENTS_ON_CHIP": 1, "IMPULSES_IN_RECORDS": 1, **format_params(FP16)},
    "tangents-onchip-impulses": {"TANGENTS_ON_CHIP": 1},
}
# The soft contact pipe (Box2D's soft step, models/golden/soft_contact.py): modules with a SOFT_CONTACT parameter are
# also linted with it, alone, in fp16 and with the impulses in the records (the build the soft closed loop runs on).
SOFT_PARAM_SETS: dict[str, dict[str, int]] = {
    "soft-contact": {"SOFT_CONTACT": 1},
    "soft-contact-impulses-in-records-fp16": {"SOFT_CONTACT": 1, "IMPULSES_IN_RECORDS": 1, **format_params(FP16)},
}
# The delay lines' block RAM mapping (a synthesis attribute, the same simulation): the modules with a
# DELAY_BLOCK_MIN_DEPTH parameter (the generated pipes, the sequencer, the kernel) are also linted with lines from 65
# deep in block RAM, the kernel also on the fp32 records design that uses it; pgs_delay with a block RAM line.
DELAY_PARAM_SETS: dict[str, dict[str, int]] = {
    "delay-lines-block": {"DELAY_BLOCK_MIN_DEPTH": 65},
    "delay-lines-block-tangents-records-banked": {"DELAY_BLOCK_MIN_DEPTH": 65, "TANGENTS_ON_CHIP": 1,
                                                  "IMPULSES_IN_RECORDS": 1, "BODY_BANKS": 2},
    "delay-line-block-ram": {"DEPTH": 100, "BLOCK_MIN_DEPTH": 64},
}

# The lanes' datapath: modules with a SHARED_DATAPATH parameter are also linted with a contact and a friction pipe per
# lane (0), on the streaming kernel (the drain at a switch) and on the window kernel in fp16 (the friction results
# aligned to the contact pipe's latency).
DATAPATH_PARAM_SETS: dict[str, dict[str, int]] = {
    "two-pipes": {"SHARED_DATAPATH": 0},
    "two-pipes-window-fp16": {"SHARED_DATAPATH": 0, "WINDOW": 1024, **format_params(FP16)},
}

# The adders' DSP48E2 form (fp_add's SHIFT_DSP): modules with an ADD_SHIFT_DSP parameter (the generated pipes, the
# sequencer, the kernel) are also linted with it, and the kernel also with two pipes per lane on the window kernel in
# fp16.
ADDER_PARAM_SETS: dict[str, dict[str, int]] = {
    "dsp-adders": {"ADD_SHIFT_DSP": 1},
    "dsp-adders-two-pipes-window-fp16": {"ADD_SHIFT_DSP": 1, "SHARED_DATAPATH": 0, "WINDOW": 1024,
                                         **format_params(FP16)},
}

# Modules linted as tops with their default parameters only, because the parent named here instantiates them
# outside any generate block and passes every parameter the sets vary through (``.P(P)``; checked by
# :func:`forwarded_params`), so each of the parent's parameter-set runs elaborates them with that set.
ELABORATED_BY_PARENT: dict[str, str] = {
    "pgs_sequencer": "pgs_kernel",
    # (pgs_seq_lane: in the sequencer's loop over the lanes, which always builds lane 0)
    **{m: "pgs_sequencer" for m in ("pgs_seq_load", "pgs_seq_records", "pgs_seq_issue", "pgs_seq_hazards",
                                   "pgs_seq_lane", "pgs_seq_retire", "pgs_seq_integrate")},
    "pgs_lane_datapath": "pgs_seq_lane",
}

# the generated pipes' families: a variant's name is its family's followed by its options (``_full_mu``: full, mu)
PIPE_FAMILIES = ("pgs_shared_pipe", "pgs_contact_pipe", "pgs_friction_pipe", "pgs_integrate_pipe")


def pipe_options(module: str) -> tuple[str, frozenset[str]] | None:
    """A generated pipe's family and options (None: not a generated pipe)."""
    if module not in {*GRAPHS, *MODE_GRAPHS, *SHARED_GRAPHS}:
        return None
    family = next(f for f in PIPE_FAMILIES if module == f or module.startswith(f + "_"))
    return family, frozenset(module[len(family):].split("_")) - {""}


def covering_pipes() -> set[str]:
    """The generated pipes whose options are not a strict subset of another variant's of their family."""
    variants = {m: pipe_options(m) for m in {*GRAPHS, *MODE_GRAPHS, *SHARED_GRAPHS}}
    return {m for m, (fam, opts) in variants.items()
            if not any(f == fam and opts < o for f, o in variants.values())}


_PARAM_RE = re.compile(r"\bparameter\s+(?:(?:int|integer|logic|bit)\b[^=;,)]*?\s)?\s*(\w+)\s*=")


@dataclass(frozen=True)
class LintRun:
    top: str
    label: str
    params: dict[str, int]


@dataclass(frozen=True)
class LintResult:
    run: LintRun
    ok: bool
    output: str
    seconds: float


def forwarded_params(parent_file: Path, child: str) -> set[str]:
    """The parameters ``parent_file`` passes through by name (``.P(P)``) to its instance of ``child``; none when
    that instance lies inside a generate block."""
    text = re.sub(r"//[^\n]*", "", parent_file.read_text())
    inst = re.search(rf"\b{child}\s*#\s*\((.*?)\)\s*\w+\s*\(", text, re.DOTALL)
    before = text[:inst.start()] if inst else ""
    if inst is None or len(re.findall(r"\bgenerate\b", before)) != len(re.findall(r"\bendgenerate\b", before)):
        return set()  # no instance, or one inside a generate block (it may not be elaborated)
    return {a for a, b in re.findall(r"\.(\w+)\s*\(\s*(\w+)\s*\)", inst.group(1)) if a == b}


def param_sets() -> dict[str, dict[str, int]]:
    """Every extra parameter set, by label."""
    return (FORMAT_PARAM_SETS | WINDOW_PARAM_SETS | INERTIA_PARAM_SETS | IMPULSE_PARAM_SETS | FRICTION_PARAM_SETS
            | BANK_PARAM_SETS | TANGENT_PARAM_SETS | SOFT_PARAM_SETS | DELAY_PARAM_SETS | DATAPATH_PARAM_SETS
            | ADDER_PARAM_SETS)


def runs_for(module_file: Path) -> list[LintRun]:
    top = module_file.stem
    params = set(_PARAM_RE.findall(module_file.read_text()))
    out = [LintRun(top, "default", {})]
    if top in ELABORATED_BY_PARENT:
        parent = module_file.with_name(ELABORATED_BY_PARENT[top] + module_file.suffix)
        varied = params & {name for pset in param_sets().values() for name in pset}
        missing = varied - forwarded_params(parent, top)
        if missing:
            raise ValueError(f"{parent.name} does not pass {', '.join(sorted(missing))} through to {top}: "
                             f"lint {top} with every parameter set (remove it from ELABORATED_BY_PARENT)")
        return out
    if pipe_options(top) is not None and top not in covering_pipes():
        return out
    for label, pset in param_sets().items():
        if set(pset) <= params:
            out.append(LintRun(top, label, dict(pset)))
    return out


def xls_runs(packages: Sequence[Path], include_dirs: Sequence[Path]) -> list[tuple[LintRun, list[Path], list[Path]]]:
    """The XLS datapath's runs (label ``xls-<format>``), under the waiver file: each pipe module of
    ``rtl/generated/xls/`` in every XLS format, and the kernel with them in the first (every format's pipe module has
    the ports the kernel connects; Verilator reads about 20 MB of XLS Verilog per pipe and format, a minute a run);
    (run, sources, include folders) each."""
    dirs = [*include_dirs, XLS_DIR]
    pipes = [wrapper_path(p) for p in XLS_PIPES]
    kernel = RTL_ROOT / "pgs_kernel.sv"
    out = []
    for k, fmt in enumerate(XLS_FORMATS):
        tops = [*((p.stem, [p]) for p in pipes)] + ([("pgs_kernel", [*pipes, kernel])] if k == 0 else [])
        for top, files in tops:
            # the kernel takes XLS's contact and friction pipes with two pipes per lane (SHARED_DATAPATH = 0)
            params = format_params(fmt) | ({"SHARED_DATAPATH": 0} if top == "pgs_kernel" else {})
            out.append((LintRun(top, f"xls-{fmt.name}", params), [LINT_WAIVERS, *packages, *files], dirs))
    return out


def lint_one(run: LintRun, sources: Sequence[Path], include_dirs: Sequence[Path]) -> LintResult:
    """One lint run: the packages and the top's file; other modules are found by name in the -y folders."""
    verilator = ensure_verilator_env()
    cmd = [str(verilator), "--lint-only", "-Wall", "--top-module", run.top]
    for d in include_dirs:
        cmd += ["-y", str(d)]
    cmd += param_args(run.params)
    cmd += [str(s) for s in sources]
    t0 = time.monotonic()
    proc = subprocess.run(cmd, cwd=REPO_ROOT, capture_output=True, text=True)
    text = (proc.stdout + proc.stderr).strip()
    ok = proc.returncode == 0 and "%Warning" not in text and "%Error" not in text
    return LintResult(run, ok, text, time.monotonic() - t0)


def main(argv: Sequence[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m sim.lint", description=__doc__.splitlines()[0])
    ap.add_argument("tops", nargs="*", help="module names to lint (default: every module of rtl/pgs_kernel.f)")
    ap.add_argument("-v", "--verbose", action="store_true", help="print every run")
    args = ap.parse_args(argv)

    packages, modules = rtl_files()
    include_dirs = sorted({f.parent for f in packages + modules})
    if not modules:
        print("lint: no module in rtl/pgs_kernel.f", file=sys.stderr)
        return 1
    if args.tops:
        unknown = set(args.tops) - {m.stem for m in modules}
        if unknown:
            print(f"lint: unknown top(s): {', '.join(sorted(unknown))}", file=sys.stderr)
            return 1
        modules = [m for m in modules if m.stem in args.tops]
    runs = [(r, packages + [m], include_dirs) for m in modules for r in runs_for(m)]
    runs += [job for job in xls_runs(packages, include_dirs) if job[0].top in {m.stem for m in modules}]
    with ThreadPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(lambda job: lint_one(*job), runs))
    failed = [r for r in results if not r.ok]
    for r in results:
        if args.verbose or not r.ok:
            params = " ".join(f"{k}={v}" for k, v in r.run.params.items()) or "defaults"
            print(f"{'ok  ' if r.ok else 'FAIL'} {r.run.top} [{r.run.label}: {params}] {r.seconds:.2f} s")
        if not r.ok:
            print("\n".join("    " + line for line in r.output.splitlines()))
    tops = len({r.run.top for r in results})
    print(f"lint: {len(results)} runs over {tops} tops, {len(failed)} with warnings/errors")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
