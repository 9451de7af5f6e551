"""The delay line of the generated datapaths (rtl/pgs_delay.sv): both forms keep every valid word.

``cocotb_tests/delay/pgs_delay_tb.sv`` instantiates both forms (circular buffer, shift register) of nine lines (1
to 95 bits wide, 2 to 160 deep, powers of two and not, taps at 0, 1, 2, DEPTH / 2, DEPTH - 1 and DEPTH), feeds
each pair the same random words with the same random valid bits (runs of valid and idle cycles), and checks every
tap whose word was valid, in every cycle once the lines are full, against the word it must show (a history kept by
the bench); ``cocotb_tests/delay/pgs_delay_main.cpp`` clocks it. The kernel tests check the lines inside the
datapaths bit for bit against the golden model.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:
    sys.path.insert(0, str(REPO))

from sim.compile.verilator_build import DEBUG_COMPILE_ARGS, build  # noqa: E402

HERE = Path(__file__).resolve().parent / "delay"


def test_both_forms_keep_every_valid_word() -> None:
    exe = build([REPO / "rtl" / "pgs_delay.sv", HERE / "pgs_delay_tb.sv"], "pgs_delay_tb",
                cpp_files=[HERE / "pgs_delay_main.cpp"], extra_args=DEBUG_COMPILE_ARGS)
    proc = subprocess.run([str(exe)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "pgs_delay_tb: PASS 9 lines x 6 taps, 700 cycles" in proc.stdout, proc.stdout
