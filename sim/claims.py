"""``make claims``: rerun every figure of the README's headline results and compare each with the figure it states.

The claims are data (``docs/claims.toml``): the runs (each a ``make sim`` command), and per row of the README's table
"Headline results" (and per line under it) the text with its figures, each figure's value, how the README writes it,
what it is read from and which runs must give it. The README's table is rendered from that file
(:func:`readme_lines`; ``sim/tests/test_claims.py`` holds README.md equal to it), so a figure changes in one place.

This command runs each run (``sim.run``, the same run as its ``make sim`` command, its report in ``build/claims/``),
then prints one line per figure and run: PASS or FAIL, the figure as measured and as stated, and the command that
gives it. A figure passes when the measured value, written as the README writes it (its format: the digits it
states), is the stated one. Any FAIL, or a run that could not finish, makes the exit status 1. The thesis-frame runs
take minutes each (the frames and the exact reference are cached in ``build/frames``); ``--runs`` picks some.

    python -m sim.claims                    # every run, every claim (make claims)
    python -m sim.claims --runs jenga,duck-lego
    python -m sim.claims --list             # the runs and their commands, nothing run
"""

from __future__ import annotations

import argparse
import re
import sys
import time
import tomllib
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional, Sequence

from models.published import thesis
from sim.compile.verilator_build import REPO_ROOT
from sim.fit.estimate_band import BandVerdict
from sim.fit.timing_estimate import TimingVerdict
from sim.report.run_result import AnyRunResult, RunResult
from sim.run import make_sim_argv, parse_args as sim_args, run_and_report

CLAIMS_FILE = REPO_ROOT / "docs" / "claims.toml"
README = REPO_ROOT / "README.md"
TABLE_HEADER = ("| claim | figure | command |", "|---|---|---|")


@dataclass(frozen=True)
class Figure:
    """One figure of a claim: its value, how the README writes it, what it is read from, the runs that give it."""

    name: str
    value: Any
    format: str
    measure: str
    runs: tuple[str, ...]

    def written(self, value: Any) -> str:
        """``value`` as the README writes this figure."""
        return format(value, self.format)


@dataclass(frozen=True)
class Claim:
    """A row of the headline table (``claim``, ``command`` set) or a line under it (both empty)."""

    text: str
    figures: tuple[Figure, ...]
    claim: str = ""
    command: str = ""

    def rendered(self) -> str:
        """The text with each figure as stated."""
        return self.text.format(**{f.name: f.written(f.value) for f in self.figures})

    def row(self) -> str:
        return f"| {self.claim} | {self.rendered()} | {self.command} |"


@dataclass(frozen=True)
class Claims:
    runs: dict[str, str]  # name -> make sim command
    rows: tuple[Claim, ...]
    notes: tuple[Claim, ...]

    @property
    def all(self) -> tuple[Claim, ...]:
        return self.rows + self.notes


# --- what a figure is read from ----------------------------------------------------------------------------------
def _rtl(result: Optional[AnyRunResult]) -> RunResult:
    if not isinstance(result, RunResult) or result.bits is None:
        raise ValueError("the run has no RTL kernel result")
    return result


def _speed(result: Optional[AnyRunResult]) -> Any:
    speed = _rtl(result).speed
    if speed is None:
        raise ValueError("the kernel did not reach ap_done")
    return speed


def _fit(result: Optional[AnyRunResult]) -> Any:
    fit = _rtl(result).fit
    if fit is None or not hasattr(fit, "shares"):
        raise ValueError(f"the run has no fit estimate ({fit})")
    return fit


def _band(result: Optional[AnyRunResult]) -> BandVerdict:
    """The run's verdict with the estimate's band (``sim.fit.estimate_band``): what "fits" means in every report."""
    band = _rtl(result).band
    if not isinstance(band, BandVerdict):
        raise ValueError(f"the run has no fit verdict with the estimate's band ({band})")
    return band


def _max_dv(result: Optional[AnyRunResult]) -> float:
    exact = _rtl(result).errors.vs_exact
    if not hasattr(exact, "ours"):
        raise ValueError(f"no exact reference: {exact}")
    return exact.ours.max_dv


def _thesis_speedup(result: Optional[AnyRunResult]) -> float:
    speed = _speed(result)
    return thesis.THESIS_FPGA[speed.fmt].cycles_per_manifold_pass / (speed.cycles / speed.manifold_passes)


def _timing_mhz(result: Optional[AnyRunResult]) -> int:
    """The clock the run's timing estimate supports, in whole MHz (the platform's where it meets it)."""
    t = _rtl(result).timing
    if not isinstance(t, TimingVerdict):
        raise ValueError(f"the run has no timing estimate ({t})")
    return round(t.clock_hz / 1e6)


def _binding(result: Optional[AnyRunResult]) -> str:
    fit = _fit(result)
    return max(fit.limits, key=lambda k: fit.shares[k] / fit.limits[k])


MEASURES: dict[str, Callable[[Optional[AnyRunResult]], Any]] = {
    "bits_differing": lambda r: _rtl(r).bits.differing_bits if _rtl(r).bits.ok else
    max(_rtl(r).bits.differing_bits, 1),  # a mismatch that differs in no bit (a short trace) counts
    "trace_records_compared": lambda r: _rtl(r).bits.records,
    "cycle_model_agrees": lambda r: _rtl(r).model_agrees,
    "cycles": lambda r: _speed(r).cycles,
    "cycles_per_manifold_pass": lambda r: _speed(r).cycles / _speed(r).manifold_passes,
    "thesis_speedup": _thesis_speedup,
    "max_dv_vs_exact": _max_dv,
    # fits: the band verdict's (every resource's pessimistic end within its usable share), as make sim prints it;
    # the shares are the Yosys estimate's, the margin the binding resource's at the pessimistic end, in points
    "fits": lambda r: _band(r).fits,
    "fit_margin_points": lambda r: _band(r).binding.margin_points,
    "fit_margin_resource": lambda r: _band(r).binding.resource,
    "lut_share": lambda r: _fit(r).shares["LUT"],
    "bram_share": lambda r: _fit(r).shares["BRAM36"],
    "binding_resource": _binding,
    "timing_mhz": _timing_mhz,
    "manifolds": lambda r: _rtl(r).scene.manifolds,
    # published figures (no run): the thesis's cycles per manifold-pass
    "thesis_fp32_cycles_per_manifold_pass": lambda r: thesis.THESIS_FPGA["fp32"].cycles_per_manifold_pass,
    "thesis_fp16_cycles_per_manifold_pass": lambda r: thesis.THESIS_FPGA["fp16"].cycles_per_manifold_pass,
}


# --- the data file ---------------------------------------------------------------------------------------------
def _claim(entry: dict[str, Any], runs: dict[str, str], where: str) -> Claim:
    figures = []
    for name, f in entry.get("figures", {}).items():
        unknown = set(f) - {"value", "format", "measure", "runs"}
        if unknown or not {"value", "measure", "runs"} <= set(f):
            raise ValueError(f"{where}: figure {name!r} needs value, measure, runs (and format), got {sorted(f)}")
        if f["measure"] not in MEASURES:
            raise ValueError(f"{where}: figure {name!r}: unknown measure {f['measure']!r} ({', '.join(MEASURES)})")
        missing = [r for r in f["runs"] if r not in runs]
        if missing:
            raise ValueError(f"{where}: figure {name!r}: no run named {', '.join(missing)}")
        figures.append(Figure(name, f["value"], f.get("format", ""), f["measure"], tuple(f["runs"])))
    claim = Claim(entry["text"], tuple(figures), entry.get("claim", ""), entry.get("command", ""))
    named = set(re.findall(r"{(\w+)}", claim.text))
    if named - {f.name for f in figures}:
        raise ValueError(f"{where}: the text names {sorted(named - {f.name for f in figures})}, which no figure is")
    return claim


def load_claims(path: Path = CLAIMS_FILE) -> Claims:
    """The claims of ``path``, checked: every figure's measure and runs exist, every {name} of a text is a figure."""
    data = tomllib.loads(Path(path).read_text())
    runs = dict(data.get("runs", {}))
    for command in runs.values():
        make_sim_argv(command)  # a command make sim takes
    rows = tuple(_claim(c, runs, f"claim {k + 1}") for k, c in enumerate(data.get("claim", [])))
    notes = tuple(_claim(c, runs, f"note {k + 1}") for k, c in enumerate(data.get("note", [])))
    if any(not (c.claim and c.command) for c in rows):
        raise ValueError(f"{path}: every [[claim]] needs claim, text and command")
    return Claims(runs, rows, notes)


def readme_lines(claims: Claims) -> list[str]:
    """The headline table and the lines under it, as README.md has them."""
    return [*TABLE_HEADER, *(c.row() for c in claims.rows), "",
            *(line for c in claims.notes for line in c.rendered().split("\n"))]


# --- running --------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Check:
    claim: str
    figure: Figure
    run: str  # "" for a published figure
    command: str
    measured: str  # as the README writes it, or why there is no value
    passed: bool

    def line(self) -> str:
        verdict = "PASS" if self.passed else "FAIL"
        where = f"{self.run}: " if self.run else "published: "
        return (f"{verdict}  {self.claim} / {self.figure.name}: {where}measured {self.measured}, stated "
                f"{self.figure.written(self.figure.value)}" + (f"   [{self.command}]" if self.command else ""))


RunSource = Callable[[str, str], AnyRunResult]  # (run name, make command) -> its result


def run_sim(out: Path) -> RunSource:
    """Each run through ``sim.run`` (the same run as its make command), its report under ``out``."""
    def source(name: str, command: str) -> AnyRunResult:
        args = sim_args([*make_sim_argv(command), "--out", str(out / name)])
        result, _, run_dir = run_and_report(args)
        print(f"{name}: report {run_dir / 'report.md'}", flush=True)
        return result

    return source


def check(claims: Claims, results: dict[str, AnyRunResult | Exception]) -> list[Check]:
    """Every figure against every run of it that is in ``results`` (a run that failed: its exception), and every
    published figure."""
    out: list[Check] = []
    for c in claims.all:
        label = c.claim or re.split(r"[(:,{]", c.text)[0].strip()
        for f in c.figures:
            for run in f.runs or ("",):
                if run and run not in results:
                    continue
                got = results.get(run) if run else None
                try:
                    if isinstance(got, Exception):
                        raise ValueError(f"the run failed: {got}")
                    value = MEASURES[f.measure](got)
                    measured, passed = f.written(value), f.written(value) == f.written(f.value)
                except (ValueError, KeyError, AttributeError) as exc:
                    measured, passed = f"none ({exc})", False
                out.append(Check(label, f, run, claims.runs.get(run, ""), measured, passed))
    return out


def parse_args(argv: Sequence[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="python -m sim.claims", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--claims", default=str(CLAIMS_FILE), help="the claims file (default docs/claims.toml)")
    ap.add_argument("--runs", default="", help="comma-separated run names (default: all)")
    ap.add_argument("--out", default="build/claims", help="parent directory of the runs' reports")
    ap.add_argument("--list", action="store_true", help="print the runs and their commands; run nothing")
    return ap.parse_args(argv)


def main(argv: Sequence[str] | None = None, source: RunSource | None = None) -> int:
    args = parse_args(argv)
    try:
        claims = load_claims(Path(args.claims))
        names = [r.strip() for r in args.runs.split(",") if r.strip()] or list(claims.runs)
        unknown = [r for r in names if r not in claims.runs]
        if unknown:
            raise ValueError(f"--runs: no run named {', '.join(unknown)} (runs: {', '.join(claims.runs)})")
    except (ValueError, OSError, tomllib.TOMLDecodeError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    if args.list:
        for name in names:
            print(f"{name}: {claims.runs[name]}")
        return 0
    source = source or run_sim(Path(args.out))
    results: dict[str, AnyRunResult | Exception] = {}
    seconds: dict[str, float] = {}
    for name in names:
        print(f"\n=== {name}: {claims.runs[name]}", flush=True)
        t0 = time.perf_counter()
        try:
            results[name] = source(name, claims.runs[name])
        except Exception as exc:  # noqa: BLE001 - a run that breaks is a failed claim, reported, not a crash
            traceback.print_exc()
            results[name] = exc
        seconds[name] = time.perf_counter() - t0
    checks = check(claims, results)
    print("\n=== claims (docs/claims.toml) against the runs")
    for c in checks:
        print(c.line())
    failed = [c for c in checks if not c.passed]
    print(f"\n{len(checks) - len(failed)} of {len(checks)} figures PASS"
          + (f", {len(failed)} FAIL" if failed else "") + "; run times: "
          + ", ".join(f"{n} {s:.0f} s" for n, s in seconds.items()))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
