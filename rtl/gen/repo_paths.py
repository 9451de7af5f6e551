"""Where the datapath generator reads and writes: the repository root and the fp operators' folder."""

from __future__ import annotations

from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parents[2]
FP_DIR = REPO_ROOT / "rtl" / "fp"
