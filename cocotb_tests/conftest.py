"""Put ``cocotb_tests/`` on the path so that the test benches import as ``tb`` from pytest too: the cocotb test
modules run inside the simulator under that short name (``sim.drive.cocotb_run`` puts this folder on its PYTHONPATH),
and the pytest-side helpers of ``test_kernel_bad_input.py`` share their code with it. Modules that import the
benches as ``cocotb_tests.tb`` do not need this."""

import sys
from pathlib import Path

HERE = str(Path(__file__).resolve().parent)
if HERE not in sys.path:
    sys.path.insert(0, HERE)
