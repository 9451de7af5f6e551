"""Run reports: a terminal summary plus ``report.json`` and ``report.md`` in the run directory, and
:class:`StagedDirectory`, which makes an output directory appear only once it is complete."""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from pathlib import Path
from types import TracebackType
from typing import Any, Optional


class StagedDirectory:
    """An output directory written under a temporary name in ``parent`` (``path``) and renamed into place by
    :meth:`commit` (replacing an older directory of that name). Leaving the ``with`` block without a commit --
    an error, Ctrl-C -- removes it, and ``parent`` too when this created it and it is empty: a failed run
    leaves no half-written directory behind."""

    def __init__(self, parent: Path):
        self.parent = Path(parent)
        self.created_parent = False
        self.path = self.parent
        self.final: Optional[Path] = None

    def __enter__(self) -> "StagedDirectory":
        self.created_parent = not self.parent.exists()
        self.parent.mkdir(parents=True, exist_ok=True)
        self.path = Path(tempfile.mkdtemp(prefix=".partial-", dir=self.parent))
        umask = os.umask(0)
        os.umask(umask)
        self.path.chmod(0o777 & ~umask)  # mkdtemp makes it private; the finished directory is an ordinary one
        return self

    def commit(self, name: str) -> Path:
        """Move the finished directory to ``parent/name`` and return that path."""
        final = self.parent / name
        old = None
        if final.exists():
            old = Path(tempfile.mkdtemp(prefix=".old-", dir=self.parent))
            final.rename(old / "dir")
        self.path.rename(final)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
        self.final = final
        return final

    def __exit__(self, exc_type: Optional[type[BaseException]], exc: Optional[BaseException],
                 tb: Optional[TracebackType]) -> None:
        if self.final is None:
            shutil.rmtree(self.path, ignore_errors=True)
            if self.created_parent and not any(self.parent.iterdir()):
                self.parent.rmdir()


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
