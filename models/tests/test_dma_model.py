"""DMA/platform presets: bandwidth arithmetic."""

import pytest

from models.timing.platforms import PRESETS, get_preset


def test_zcu102_is_ddr_bound() -> None:
    p = get_preset("zcu102")
    assert p.stream_bits == 512
    assert p.ddr_bytes_per_cycle == pytest.approx(16e9 / 275e6)
    assert p.bytes_per_cycle == pytest.approx(58.18, abs=0.01)  # below the 64 B/cycle of 4 x 128-bit ports
    assert p.beats_per_cycle == pytest.approx(0.909, abs=0.001)
    # the thesis fp32 step: 127,000 manifolds x 8 passes x 112 B at 16 GB/s = 1.956 M cycles at 275 MHz
    assert p.transfer_cycles(127_000 * 8 * 112) == pytest.approx(1.956e6, rel=1e-3)


def test_single_channel_is_port_bound() -> None:
    p = get_preset("zcu102_1")
    assert p.bytes_per_cycle == 16.0 and p.beats_per_cycle == 1.0


def test_presets_and_errors() -> None:
    assert {"zcu102", "ideal", "u280"} <= set(PRESETS)
    assert get_preset("ideal").transfer_cycles(6400) == 100
    with pytest.raises(ValueError, match="unknown DMA preset"):
        get_preset("zcu999")
