"""The kernel's cycle model (models/timing/cycle_model.py, its timing structure models/timing/kernel_shape.py) on
hand-derived timelines; the RTL comparison is in cocotb_tests/test_pgs_kernel.py (test_kernel_cycles_match_model)."""

from __future__ import annotations


import numpy as np
import pytest

from models.timing import kernel_shape as ks
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.formats.number_format import BF16, FP16, FP32, NumberFormat
from models.timing import prediction
from models.timing import stream_cycle_model
from sim.compare import retire_cycles
from rtl.gen.operator_schedule import schedule

FP32_C512 = ks.KernelShape.of(FP32, 512)  # one shared datapath per lane (the default build)
FP32_C512_TWO_PIPES = ks.KernelShape.of(FP32, 512, shared_datapath=False)  # a contact and a friction pipe
IDEAL, ZCU102 = ks.DmaTiming.of(get_preset("ideal")), ks.DmaTiming.of(get_preset("zcu102"))


def step_of(pairs: list[tuple[int, int]], num_bodies: int, static: tuple[int, ...] = (0,), iterations: int = 1,
            interleaved: bool = False, fmt: NumberFormat = FP32) -> ks.StepShape:
    inv_mass = np.ones(num_bodies)
    inv_mass[list(static)] = 0.0
    a, b = (np.array(x, dtype=np.int64) for x in zip(*pairs)) if pairs else (np.zeros(0, np.int64),) * 2
    return ks.StepShape.of(fmt, inv_mass, a, b, SolverParams(iterations, interleaved=interleaved))


@pytest.mark.parametrize("fmt,latencies", [(FP32, (179, 110, 186)), (FP16, (179, 110, 134)),
                                           (BF16, (179, 110, 122))])
def test_latencies_read_from_rtl(fmt: NumberFormat, latencies: tuple[int, int, int]) -> None:
    """The LATENCY localparams of the generated datapaths (rtl/README.md's table), as the generator schedules them."""
    from rtl.gen.kernel_graphs import GRAPHS

    got = tuple(ks.rtl_latency(m, fmt) for m in ("pgs_contact_pipe", "pgs_friction_pipe", "pgs_integrate_pipe"))
    assert got == latencies
    gen = tuple(schedule(GRAPHS[m]()).latency_for(fmt.man_bits)
                for m in ("pgs_contact_pipe", "pgs_friction_pipe", "pgs_integrate_pipe"))
    assert got == gen


def test_shape_of_formats_and_presets() -> None:
    s = ks.KernelShape.of(FP32, 512)
    assert (s.contact_beats, s.friction_beats, s.body_in_beats, s.body_out_beats) == (2, 1, 5, 4)
    s = ks.KernelShape.of(FP16, 512)
    assert (s.contact_beats, s.friction_beats, s.body_in_beats, s.body_out_beats) == (1, 1, 3, 2)
    s = ks.KernelShape.of(FP32, 128)  # zcu102_1: one 128-bit channel
    assert (s.contact_beats, s.friction_beats, s.cons_beat_bytes) == (7, 4, 16)
    assert ks.DmaTiming.of(get_preset("zcu102")).rate == 58.182  # the harness's 1/1000-byte rounding
    # the body-in record's beats per inverse-inertia mode (1, 3, 6 words: 15, 17, 20 words of 32 / 16 bits)
    assert [ks.KernelShape.of(FP32, 512, inertia_words=w).body_in_beats for w in (1, 3, 6)] == [4, 5, 5]
    assert [ks.KernelShape.of(FP16, 512, inertia_words=w).body_in_beats for w in (1, 3, 6)] == [2, 3, 3]
    assert ks.DmaTiming.of(get_preset("ideal")) == ks.DmaTiming(0.0, 0)


def test_one_manifold_ideal_timeline() -> None:
    """Ground + one cube, one manifold, one iteration, no DDR cap and no start-up latency, by hand from the RTL:
    body-in beats 0..9 (2 x 5), SOLVE from 12; the contact record's beats at 0, 1, assembled at 3, issued at 12,
    retires at 12 + 1 + 179; the friction record (same bodies: a hazard) issues one cycle after that retire (193) and
    retires 1 + 179 (the shared datapath's latency, both kinds) later, at 373;
    INTEG from 375: bodies issue at 375, 376, their 4 body-out beats at 563..566 and 567..570; DONE 571;
    cycles register = DONE + 2."""
    p = stream_cycle_model.predict(FP32_C512, IDEAL, step_of([(0, 1)], 2))
    assert p.retire.tolist() == [192, 373] and p.issue.tolist() == [12, 193] and p.ready.tolist() == [3, 13]
    assert p.cause.tolist() == [prediction.SOLVE_START, prediction.HAZARD] and p.blocker.tolist() == [-1, 0]
    assert p.phases == {"LOAD": 0, "SOLVE": 12, "DRAIN": 194, "INTEG": 375, "DONE": 571} and p.cycles == 573
    assert (p.stalls, p.bubbles) == (180, 0)  # SOLVE 12..193: 2 issues, the friction record stalls from 13
    assert p.stall_cycles_by_cause() == {"hazard": 180, "contact/friction pipe switch": 0, "hazard CAM full": 0}


def test_one_manifold_ideal_timeline_two_pipes() -> None:
    """The same step with a contact and a friction pipe per lane: the friction record issues at 193 too (a hazard,
    and a pipe switch), and retires 1 + 110 later (304); INTEG from 306, body-out beats at 494..501, DONE 502."""
    p = stream_cycle_model.predict(FP32_C512_TWO_PIPES, IDEAL, step_of([(0, 1)], 2))
    assert p.retire.tolist() == [192, 304] and p.issue.tolist() == [12, 193] and p.ready.tolist() == [3, 13]
    assert p.cause.tolist() == [prediction.SOLVE_START, prediction.HAZARD] and p.blocker.tolist() == [-1, 0]
    assert p.phases == {"LOAD": 0, "SOLVE": 12, "DRAIN": 194, "INTEG": 306, "DONE": 502} and p.cycles == 504
    assert (p.stalls, p.bubbles) == (180, 0)


def test_load_counts_the_body_record_beats() -> None:
    """The same step with a scalar body record (4 beats at fp32): LOAD ends 2 beats earlier, everything after it
    shifts by 2 cycles."""
    base = stream_cycle_model.predict(FP32_C512, IDEAL, step_of([(0, 1)], 2))
    scalar = stream_cycle_model.predict(ks.KernelShape.of(FP32, 512, inertia_words=1), IDEAL, step_of([(0, 1)], 2))
    assert scalar.phases["SOLVE"] == base.phases["SOLVE"] - 2 and scalar.cycles == base.cycles - 2


def test_one_manifold_zcu102_timeline() -> None:
    """The same step through the zcu102 model: start-up latency 40 (first beats at 39), the DDR bucket (capped
    at 128 B, 58.182 B per cycle, the body-in beat spends first), the friction pass's transfer 40 cycles after
    the contact pass's last beat (taken at 40)."""
    p = stream_cycle_model.predict(FP32_C512, ZCU102, step_of([(0, 1)], 2))
    assert p.first_offer.tolist() == [39, 80] and p.last_beat.tolist() == [40, 80]
    assert p.issue.tolist() == [51, 232] and p.retire.tolist() == [231, 412]
    assert p.phases["INTEG"] == 414 and p.cycles == 612
    two = stream_cycle_model.predict(FP32_C512_TWO_PIPES, ZCU102, step_of([(0, 1)], 2))
    assert two.retire.tolist() == [231, 343] and two.phases["INTEG"] == 345 and two.cycles == 543


def test_hazard_waits_for_retire() -> None:
    """Two manifolds on body 2: the second may issue one cycle after the first retires (CAM entry live through
    its retire cycle); the explanation names the body and the blocking record."""
    p = stream_cycle_model.predict(FP32_C512, IDEAL, step_of([(1, 2), (0, 2)], 3))
    assert p.issue[1] == p.retire[0] + 1 and p.cause[1] == prediction.HAZARD and p.blocker[1] == 0
    text = p.explain(1)
    assert "hazard on body 2 with retire #0" in text and f"cycle {p.retire[0]:,}" in text
    assert "no stall: no hazard" in p.explain(0) or "waited for SOLVE" in p.explain(0)


def test_static_bodies_never_conflict_and_rejected_slots() -> None:
    """Manifolds sharing only the static ground issue without stalls: the two records assembled during LOAD (record
    and accumulation registers) at once, then one 2-beat contact record every other cycle. A manifold between two
    static bodies (0, 5) is consumed without issuing, in every pass (its beats still take their two cycles)."""
    pairs = [(0, 1), (0, 2), (0, 5), (0, 3), (5, 0), (0, 4)]
    p = stream_cycle_model.predict(FP32_C512, IDEAL, step_of(pairs, 6, static=(0, 5), iterations=2))
    assert p.rejected == 2 * 2 * 2 and p.manifold_passes == 4 * 2 * 2
    first = (p.kind == 0) & (p.iteration == 0)
    assert (p.issue[first] - p.solve_start).tolist() == [0, 1, 5, 9]
    assert set(p.slot.tolist()) == {0, 1, 3, 5} and set(p.cause[first].tolist()) <= {prediction.READY, prediction.SOLVE_START}


def test_cam_full_throttles_issue() -> None:
    """With HAZARD_DEPTH = 4 the fifth independent manifold waits for the first to retire."""
    shape = ks.KernelShape(**{**FP32_C512.__dict__, "hazard_depth": 4})
    p = stream_cycle_model.predict(shape, IDEAL, step_of([(0, k) for k in range(1, 7)], 7))
    assert p.issue[4] == p.retire[0] + 1 and p.cause[4] == prediction.CAM_FULL and p.blocker[4] == 0
    assert "hazard CAM full (4 in flight)" in p.explain(4)


def test_interleaved_passes_drain_at_every_switch() -> None:
    """Two pipes per lane drain at every switch of kinds; the shared datapath never: its first record of a pass waits
    for its hazards only (here: the body the pass before updated first), every record retiring 1 + 179 cycles after
    its issue."""
    step = step_of([(0, 1), (0, 2)], 3, iterations=3, interleaved=True)
    p = stream_cycle_model.predict(FP32_C512_TWO_PIPES, IDEAL, step)
    assert p.kind.tolist() == [0, 0, 1, 1] * 3
    firsts = np.flatnonzero(np.diff(p.kind) != 0) + 1
    assert all(p.issue[k] == p.retire[k - 1] + 1 and p.cause[k] == prediction.SWITCH for k in firsts)
    shared = stream_cycle_model.predict(FP32_C512, IDEAL, step)
    assert prediction.SWITCH not in shared.cause.tolist()
    assert all(shared.cause[k] == prediction.HAZARD and shared.issue[k] == shared.retire[k - 2] + 1 for k in firsts)
    assert np.all(shared.retire - shared.issue == FP32_C512.contact_latency + 1)


def test_ddr_bound_streaming_rate() -> None:
    """Independent manifolds through zcu102: a friction record (64 B) every 64 / 58.182 cycles, a contact record
    (128 B) every 128 / 58.182: the DDR bucket sets the pace (the kernel would take one beat per cycle)."""
    n = 4000
    p = stream_cycle_model.predict(FP32_C512, ZCU102, step_of([(0, k) for k in range(1, n + 1)], n + 1))
    for kind, nbytes in ((0, 128), (1, 64)):
        sel = p.issue[(p.kind == kind) & (p.iteration == 0)]
        slope = (sel[-1] - sel[n // 4]) / (len(sel) - 1 - n // 4)
        assert slope == pytest.approx(nbytes / 58.182, rel=2e-3)
    assert p.ddr_wait.sum() > 0 and p.bubbles > 0


def test_prefetched_is_a_lower_bound() -> None:
    step = step_of([(k % 7 + 1, (k * 3) % 7 + 1) for k in range(60) if k % 7 != (k * 3) % 7], 8, iterations=2)
    normal = stream_cycle_model.predict(FP32_C512, ZCU102, step)
    early = stream_cycle_model.predict(FP32_C512, ks.DmaTiming.of(get_preset("zcu102"), prefetched=True), step)
    assert early.cycles < normal.cycles and np.all(early.retire <= normal.retire)


def test_compare_trace_names_the_unexpected_stall() -> None:
    p = stream_cycle_model.predict(FP32_C512, IDEAL, step_of([(0, 1), (0, 2), (1, 2)], 3))
    counters = {"stalls": p.stalls, "bubbles": p.bubbles}
    ok = retire_cycles.compare_retire_cycles(p, p.retire, p.kind, p.iteration, p.slot, p.cycles, counters=counters)
    assert ok.ok and ok.exact == p.manifold_passes and "+0" in ok.describe()
    late = p.retire.copy()
    late[1:] += 1
    bad = retire_cycles.compare_retire_cycles(p, late, p.kind, p.iteration, p.slot, p.cycles + 1, manifolds=[10, 11, 12])
    assert not bad.ok and bad.exact == 1 and bad.max_abs_diff == 1
    assert bad.first_mismatch is not None
    assert bad.first_mismatch.startswith(f"manifold 11 (contact pass, iteration 0, slot 1; retire #1) retired at "
                                         f"cycle {late[1]:,}, model {p.retire[1]:,}: unexpected 1-cycle stall or "
                                         "bubble; the model: issue at cycle")
    assert "no stall: no hazard, no pipe switch" in bad.first_mismatch
    early = p.retire.copy()
    early[2] -= 3
    msg = retire_cycles.compare_retire_cycles(p, early, p.kind, p.iteration, p.slot, p.cycles).first_mismatch
    assert msg is not None and "3 cycles earlier than the model" in msg and "hazard on body" in msg
    swapped = retire_cycles.compare_retire_cycles(p, p.retire, p.kind, p.iteration, p.slot[::-1], p.cycles).first_mismatch
    assert swapped is not None and "the model expects" in swapped
    total = retire_cycles.compare_retire_cycles(p, p.retire, p.kind, p.iteration, p.slot, p.cycles + 2).first_mismatch
    assert total is not None and "every retire cycle matched" in total
    stalls = retire_cycles.compare_retire_cycles(p, p.retire, p.kind, p.iteration, p.slot, p.cycles,
                              counters={"stalls": p.stalls + 1, "bubbles": p.bubbles}).first_mismatch
    assert stalls == f"stalls counter {p.stalls + 1:,}, model {p.stalls:,}"


def test_empty_steps() -> None:
    assert stream_cycle_model.predict(FP32_C512, IDEAL, step_of([], 0, static=())).cycles == 3  # IDLE -> INTEG -> DONE
    p = stream_cycle_model.predict(FP32_C512, IDEAL, step_of([], 2))  # LOAD -> INTEG: no manifold
    assert p.manifold_passes == 0 and p.phases["INTEG"] == p.solve_start == 12
