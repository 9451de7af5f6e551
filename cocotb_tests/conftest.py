"""Make the shared testbench helpers (``cocotb_runner``, ``tb``) importable from the pytest runner functions."""

import sys
from pathlib import Path

HERE = str(Path(__file__).resolve().parent)
if HERE not in sys.path:
    sys.path.insert(0, HERE)
