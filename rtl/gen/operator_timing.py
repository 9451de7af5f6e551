"""Operator latencies as symbolic times: what the datapath generator schedules with.

The latencies are read from the operators' sources (``rtl/fp/*.sv``, ``localparam int LATENCY``) by
:func:`operator_latencies`, so the schedule follows the RTL. ``div`` and ``sqrt`` depend on
``MAN_BITS``; a node's ready time is therefore kept symbolically as :class:`Time`, the maximum of
terms ``c + k*MAN_BITS`` (Pareto-pruned), and the emitted SystemVerilog computes every delay for the
module's own ``MAN_BITS`` at elaboration: one source serves every format.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from rtl.gen.repo_paths import FP_DIR

MINMAX_LATENCY = 1  # the LATENCY parameter given to every fp_minmax instance


@dataclass(frozen=True)
class Time:
    """max_i (c_i + k_i * MAN_BITS) over a Pareto-pruned set of (c, k) terms (k >= 0)."""

    terms: frozenset[tuple[int, int]]

    @staticmethod
    def const(c: int, k: int = 0) -> "Time":
        return Time(frozenset({(c, k)}))

    @staticmethod
    def _prune(terms: set[tuple[int, int]]) -> frozenset[tuple[int, int]]:
        keep = {t for t in terms if not any(o != t and o[0] >= t[0] and o[1] >= t[1] for o in terms)}
        return frozenset(keep)

    def __add__(self, lat: "Time") -> "Time":
        assert len(lat.terms) == 1, "latencies are single terms"
        (dc, dk), = lat.terms
        return Time(frozenset((c + dc, k + dk) for c, k in self.terms))

    @staticmethod
    def max(times: Sequence["Time"]) -> "Time":
        allt: set[tuple[int, int]] = set()
        for t in times:
            allt |= t.terms
        return Time(Time._prune(allt))

    def eval(self, man_bits: int) -> int:
        return max(c + k * man_bits for c, k in self.terms)

    @property
    def is_const(self) -> bool:
        return all(k == 0 for _, k in self.terms)

    def sv(self) -> str:
        """SystemVerilog int expression (in MAN_BITS)."""
        if self.is_const:
            return str(self.eval(0))
        parts = []
        for c, k in sorted(self.terms, key=lambda t: (t[1], t[0])):
            mb = "MAN_BITS" if k == 1 else f"{k}*MAN_BITS"
            parts.append(mb if c == 0 and k else (f"{c}" if k == 0 else f"{mb} + {c}"))
        expr = parts[0]
        for p in parts[1:]:
            expr = f"pgs_fp_pkg::tmax({expr}, {p})"
        return expr


_LAT_RE = re.compile(r"\b(?:local)?param(?:eter)?\s+int\s+LATENCY\s*=\s*([^,;\n]+)")


def operator_latencies(fp_dir: Path = FP_DIR) -> dict[str, Time]:
    """LATENCY of each operator read from its RTL source (``4``, ``MAN_BITS + 5``, ...)."""
    out: dict[str, Time] = {}
    for mod in ("fp_add", "fp_mul", "fp_div", "fp_sqrt"):
        text = (fp_dir / f"{mod}.sv").read_text()
        m = _LAT_RE.search(text)
        if not m:
            raise RuntimeError(f"no LATENCY declaration in {mod}.sv")
        expr = m.group(1).strip()
        m2 = re.fullmatch(r"(\d+)", expr) or re.fullmatch(r"MAN_BITS\s*\+\s*(\d+)", expr)
        if not m2:
            raise RuntimeError(f"{mod}.sv: LATENCY = {expr!r} is not 'C' or 'MAN_BITS + C'")
        out[mod] = Time.const(int(m2.group(1)), 0 if expr[0].isdigit() else 1)
    out["fp_minmax"] = Time.const(MINMAX_LATENCY)
    return out
