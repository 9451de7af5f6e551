"""Run reports: a terminal summary plus ``report.json`` and ``report.md`` in the run directory."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any


def write_report(run_dir: Path, title: str, sections: dict[str, dict[str, Any]]) -> tuple[Path, Path]:
    """Write ``report.json`` (machine-readable) and ``report.md`` (one table per section)."""
    run_dir.mkdir(parents=True, exist_ok=True)
    json_path = run_dir / "report.json"
    md_path = run_dir / "report.md"
    json_path.write_text(json.dumps(sections, indent=2, sort_keys=False, default=_jsonable) + "\n")
    lines = [f"# {title}", ""]
    for name, rows in sections.items():
        lines += [f"## {name}", "", "| quantity | value |", "|---|---|"]
        lines += [f"| {key} | {format_value(value)} |" for key, value in rows.items()]
        lines.append("")
    md_path.write_text("\n".join(lines))
    return json_path, md_path


def format_value(value: Any) -> str:
    if isinstance(value, float):
        if value == 0.0:
            return "0"
        if abs(value) >= 1e5 or abs(value) < 1e-3:
            return f"{value:.3e}"
        return f"{value:,.4f}".rstrip("0").rstrip(".")
    if isinstance(value, int):
        return f"{value:,}"
    return str(value)


def print_summary(title: str, sections: dict[str, dict[str, Any]]) -> None:
    print(f"\n=== {title} ===")
    for name, rows in sections.items():
        print(f"-- {name}")
        width = max((len(k) for k in rows), default=0)
        for key, value in rows.items():
            print(f"  {key:<{width}}  {format_value(value)}")


def _jsonable(value: Any) -> Any:
    try:
        import numpy as np

        if isinstance(value, np.generic):
            return value.item()
        if isinstance(value, np.ndarray):
            return value.tolist()
    except ImportError:  # pragma: no cover
        pass
    return str(value)
