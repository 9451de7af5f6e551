"""The lane-floor study (sim/studies/lane_floor.py): its base is the headline build, each lever moves what it should,
and what it finds of the cycle targets on the ZCU102."""

from __future__ import annotations

import pytest

from models.formats.number_format import FP16, FP32, NumberFormat
from models.timing import platforms
from sim import claims as cl
from sim.fit import estimate_band as eb
from sim.fit import resource_model as rm
from sim.studies import lane_floor as lf

ZCU102 = platforms.get_platform("zcu102")


def _figure(name: str) -> float:
    return next(f.value for c in cl.load_claims().all for f in c.figures if f.name == name)


@pytest.mark.parametrize("fmt, lanes, lut, bram", [(FP32, 1, "lut32", "bram32"), (FP16, 2, "lut16", "bram16")])
def test_the_base_is_the_headline_build(fmt: NumberFormat, lanes: int, lut: str, bram: str) -> None:
    """With the headline's lanes the study's build has the shares the headline runs report (docs/claims.toml)."""
    shares = eb.band_verdict(lf.headline_config(fmt, lanes), ZCU102).shares
    assert round(shares["LUT"].yosys, 3) == _figure(lut)
    assert round(shares["BRAM36"].yosys, 3) == _figure(bram)


def test_each_lever_moves_block_ram_not_logic() -> None:
    found = lf.steps(lf.headline_config(FP32, 2), ZCU102, ring=4096)
    built, ring, poses, delay = found
    assert ring.config.window == 4096 and poses.config.body_words == "solve"
    bram = [s.band.shares["BRAM36"].yosys for s in found]
    assert bram[1] < bram[0] and bram[2] < bram[1]  # the ring and the poses free block RAM
    lut = [s.band.shares["LUT"].yosys for s in found]
    assert lut[0] == lut[1] == lut[2]  # neither touches a LUT
    # no shallower delay-line threshold keeps block RAM within the target: the next one is shown over it
    assert delay.config.delay_block_min_depth == 65 and bram[3] > lf.DESIGN_TARGET["BRAM36"] and lut[3] < lut[2]


def test_two_fp32_lanes_miss_the_lut_target_with_every_lever() -> None:
    """What the fit document reports: block RAM can be brought within the target, the LUTs cannot."""
    found = lf.steps(lf.headline_config(FP32, 2), ZCU102, ring=4096)
    poses = found[2]
    assert poses.band.shares["BRAM36"].yosys <= lf.DESIGN_TARGET["BRAM36"]
    assert all(s.band.shares["LUT"].vendor > lf.DESIGN_TARGET["LUT"] for s in found)
    assert all(not s.band.fits and any(m.startswith("LUT") for m in s.misses()) for s in found)


def test_the_shallowest_delay_depth_within_the_block_ram_target() -> None:
    """On a platform with block RAM to spare every delay line of 5 or more goes to block RAM; where none fits, the
    build's own threshold stays."""
    base = lf.headline_config(FP32, 2)
    data = rm.figures()
    assert lf.shallowest_delay_within_target(base, platforms.get_platform("u280"), data) == lf.DELAY_DEPTHS[-1]
    assert lf.shallowest_delay_within_target(base, ZCU102, data) == base.delay_block_min_depth


def test_operators_alone() -> None:
    cfg = lf.headline_config(FP32, 2)
    share, what = lf.operators_alone(cfg, ZCU102)
    shape = rm.pipe_shape(rm.lane_pipes(cfg)[0][0], FP32.man_bits)
    data = rm.figures()
    per_lane = sum(n * rm.operator_figure(rm.operator_figure_name(m, cfg), FP32, "vendor", data).resources.lut
                   for m, n in shape.operators.items())
    assert share == pytest.approx(2 * per_lane / ZCU102.capacity("LUT"))
    assert "fadd full_dsp" in what and "fmul max_dsp" in what


def test_main(capsys: pytest.CaptureFixture[str]) -> None:
    assert lf.main(["--format", "fp32", "--platform", "u280"]) == 0
    out = capsys.readouterr().out
    assert "fp32, 2 lane(s), the headline build" in out and "| met |" in out
    assert lf.main(["--format", "fp64"]) == 2
    assert lf.main(["--ring", "3000"]) == 2
    assert "--ring must be a power of two" in capsys.readouterr().err
