"""The Python sources (product code, tests, cocotb benches) are pyflakes-clean: no unused import or local, no
placeholder-less f-string, no redefinition; and the check does find a planted fault."""

from __future__ import annotations

import io
from pathlib import Path

from pyflakes.api import checkRecursive  # requirements.txt's pyflakes
from pyflakes.reporter import Reporter

REPO = Path(__file__).resolve().parents[2]
TREES = ("models", "rtl", "sim", "hls_export", "cocotb_tests")


def _pyflakes(paths: list[str]) -> tuple[int, str]:
    out = io.StringIO()
    found = checkRecursive(paths, Reporter(out, out))
    return found, out.getvalue()


def test_the_sources_are_pyflakes_clean() -> None:
    found, text = _pyflakes([str(REPO / t) for t in TREES])
    assert found == 0, text


def test_pyflakes_finds_a_planted_fault(tmp_path: Path) -> None:
    (tmp_path / "m.py").write_text("import time\n\n\ndef f() -> str:\n    cpu0 = 1\n    return f'x'\n")
    found, text = _pyflakes([str(tmp_path)])
    assert found == 3 and "'time' imported but unused" in text and "'cpu0'" in text and "placeholders" in text, text
