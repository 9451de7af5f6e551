"""`make lint` runs in `make test` too: every RTL top of the kernel's source list (rtl/pgs_kernel.f), and the XLS
datapath's pipe modules and the kernel with them (under rtl/xls/xls_lint.vlt), are `verilator --lint-only -Wall`
clean."""

import re
import subprocess
import sys
from pathlib import Path

from rtl.gen.file_list import rtl_files
from sim.lint import runs_for, xls_runs

REPO = Path(__file__).resolve().parents[1]


def test_rtl_lints_clean() -> None:
    proc = subprocess.run([sys.executable, "-m", "sim.lint"], cwd=REPO, capture_output=True, text=True, timeout=3600)
    print(proc.stdout[-4000:])
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-4000:]
    summary = re.search(r"lint: (\d+) runs over (\d+) tops, 0 with warnings/errors", proc.stdout)
    _, modules = rtl_files()
    assert summary and int(summary.group(2)) == len(modules), f"not every module of rtl/pgs_kernel.f linted: {summary}"
    packages, _ = rtl_files()
    hand = sum(len(runs_for(m)) for m in modules)
    assert int(summary.group(1)) == hand + len(xls_runs(packages, [])) == hand + 7, \
        "not every run of the XLS datapath's pipe modules (3 pipes x 2 formats) and kernel linted"


def test_sequencer_is_linted_through_the_kernel_with_every_parameter_set() -> None:
    """The sequencer's parameter-set runs are the kernel's (it passes them through), and so are its phase modules' and
    a lane's datapath's, through their parents; a parent that drops one, or holds the instance inside a generate
    block, makes the pruning an error instead of a silent gap."""
    from sim.lint import _PARAM_RE, ELABORATED_BY_PARENT, forwarded_params, param_sets, runs_for

    _, modules = rtl_files()
    by_name = {m.stem: m for m in modules}
    assert ELABORATED_BY_PARENT["pgs_sequencer"] == "pgs_kernel"
    for child, parent in ELABORATED_BY_PARENT.items():
        assert [r.label for r in runs_for(by_name[child])] == ["default"]
        varied = {name for pset in param_sets().values() for name in pset}
        declared = set(_PARAM_RE.findall(by_name[child].read_text()))
        assert varied & declared <= forwarded_params(by_name[parent], child)
        root = parent
        while root in ELABORATED_BY_PARENT:
            root = ELABORATED_BY_PARENT[root]
        root_runs = {r.label for r in runs_for(by_name[root])}
        assert {label for label, pset in param_sets().items() if set(pset) <= declared} <= root_runs, child
    assert len(runs_for(by_name["pgs_kernel"])) == 1 + sum(
        set(p) <= forwarded_params(by_name["pgs_kernel"], "pgs_sequencer") for p in param_sets().values())


def test_pruning_refuses_a_parent_that_does_not_pass_a_parameter(tmp_path: Path) -> None:
    import pytest

    from sim.lint import forwarded_params, runs_for

    (tmp_path / "pgs_kernel.sv").write_text(
        "module pgs_kernel #(parameter int EXP_BITS = 8) ();\n"
        "  pgs_sequencer #(.EXP_BITS(EXP_BITS), .MAN_BITS(10)) u_seq ();\nendmodule\n")
    (tmp_path / "pgs_sequencer.sv").write_text(
        "module pgs_sequencer #(parameter int EXP_BITS = 8, parameter int MAN_BITS = 23) ();\nendmodule\n")
    assert forwarded_params(tmp_path / "pgs_kernel.sv", "pgs_sequencer") == {"EXP_BITS"}
    with pytest.raises(ValueError, match="MAN_BITS"):
        runs_for(tmp_path / "pgs_sequencer.sv")
    (tmp_path / "pgs_kernel.sv").write_text(
        "module pgs_kernel #(parameter int EXP_BITS = 8, parameter int MAN_BITS = 23) ();\n  generate if (1) begin\n"
        "  pgs_sequencer #(.EXP_BITS(EXP_BITS), .MAN_BITS(MAN_BITS)) u_seq ();\n  end endgenerate\nendmodule\n")
    assert forwarded_params(tmp_path / "pgs_kernel.sv", "pgs_sequencer") == set()


def test_every_option_of_a_generated_pipe_meets_every_parameter_set() -> None:
    """A generated pipe variant not covered by another of its family is linted with every parameter set it takes;
    the others with their defaults; the covering variants hold every option of their family (diagonal, scalar and
    full inverse inertia among them: the options a name leaves out)."""
    from sim.lint import PIPE_FAMILIES, covering_pipes, param_sets, pipe_options

    _, modules = rtl_files()
    pipes = {m.stem: m for m in modules if pipe_options(m.stem) is not None}
    cover = covering_pipes()
    assert cover < set(pipes) and {pipe_options(m)[0] for m in pipes} == set(PIPE_FAMILIES)
    for name, path in pipes.items():
        labels = [r.label for r in runs_for(path)]
        assert labels[0] == "default"
        if name in cover:
            assert len(labels) > 1 and set(labels[1:]) <= set(param_sets())
        else:
            assert labels == ["default"]
    for family in PIPE_FAMILIES:
        every = {o for m in pipes if pipe_options(m)[0] == family for o in pipe_options(m)[1]}
        covered = {o for m in cover if pipe_options(m)[0] == family for o in pipe_options(m)[1]}
        assert covered == every, family
        modes = {frozenset(pipe_options(m)[1]) & {"scalar", "full"} for m in cover if pipe_options(m)[0] == family}
        if family in ("pgs_shared_pipe", "pgs_contact_pipe"):
            assert modes == {frozenset(), frozenset({"scalar"}), frozenset({"full"})}, family  # every inertia mode
