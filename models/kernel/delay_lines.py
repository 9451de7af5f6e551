"""Where the datapaths' long delay lines live on a board (``DELAY_BLOCK_MIN_DEPTH`` of ``rtl/pgs_kernel.sv``, passed
to every ``rtl/pgs_delay.sv`` of the generated pipes): which builds keep them in block RAM.

A delay line at least as deep as the threshold keeps its words in block RAM (``ram_style = "block"``: one simple
dual-port RAMB18/36 per read tap), a shallower one in LUT RAM (``"distributed"``). The choice moves LUTs into block
RAM and changes nothing a simulation sees (the same registered reads, the same cycles and bits), so the threshold
is chosen per build by the resource that binds it: ``sim/fit/resource_model.py`` counts it,
``sim/compile/kernel_build.py`` passes it to the build.
"""

from __future__ import annotations

from models.formats.number_format import NumberFormat

# lines longer than one 64-deep LUT RAM (RAM64M8: 8 LUTs per 7 bit-reads and 64 words, plus a depth multiplexer
# for each further 64 words) go to block RAM: the lines whose LUTs per bit grow with their depth
BLOCK_MIN_DEPTH = 65
# the window kernel with the impulses in the records and two pipes per lane, fp32 or two lanes, binds on LUTs and
# block RAM together (its ring and body banks take block RAM): its lines from 129 deep, the longest, in block RAM
# (thesis frame, ring 8,192: fp32 one lane LUT 84.2%, BRAM36 94.8%, fp16 two lanes 83.2% and 89.1%; from 65 deep the
# block RAM overflows). With the shared datapath (one per lane) one lane's LUTs leave room for every line in LUT RAM
# and the block RAM binds: fp32 one lane LUT 68.8%, BRAM36 91.1% (from 129 deep in block RAM: 64.4% and 96.3%, over
# the 95% usable). Two lanes bind on LUTs: fp16 with the DSP48E2 adders 71.1% (84.3% at the band's pessimistic end of
# 85% usable) and 82.9% block RAM with every line in LUT RAM; from 129 deep in block RAM 66.9% (79.7%) and 92.1%, with
# the scene's 1-word inverse inertia 83.8% (sim/fit/resource_model.py, sim/fit/estimate_band.py, 2026-12-06)
WINDOW_BLOCK_MIN_DEPTH = 129


def default_delay_block_min_depth(fmt: NumberFormat, impulses_in_records: bool, window: bool, lanes: int = 1,
                                  shared_datapath: bool = True) -> int:
    """The threshold of the build that runs a step: the streaming kernel with the impulses in the records in a format
    of 32 bits or more keeps its lines from :data:`BLOCK_MIN_DEPTH` deep in block RAM (its LUTs bind it: with the
    tangent basis derived on chip and two pipes per lane it needs 87.6% of the ZCU102's LUTs with every line in LUT
    RAM, against 85% usable, while a third of the block RAM is free; with the shared datapath 82.7%, and 71.8% from
    65 deep in block RAM), the window kernel with the impulses in the records from :data:`WINDOW_BLOCK_MIN_DEPTH` deep
    with lanes, and with one lane and two pipes per lane in fp32; every other build keeps them in LUT RAM (0), the
    one-lane window kernel with the shared datapath included."""
    if not impulses_in_records:
        return 0
    if window:
        return WINDOW_BLOCK_MIN_DEPTH if lanes > 1 or (not shared_datapath and fmt.width >= 32) else 0
    return BLOCK_MIN_DEPTH if fmt.width >= 32 else 0


def check_block_min_depth(depth: int) -> int:
    """``depth``, or a ValueError unless it is 0 (no line in block RAM) or at least pgs_delay's RAM form (4)."""
    if depth != 0 and depth < 4:
        raise ValueError(f"delay lines in block RAM from {depth} deep: expected 0 (none) or at least 4 (pgs_delay's "
                         "circular buffers; shorter lines are registers)")
    return depth
