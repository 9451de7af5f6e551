"""The kernel configurations ``make coverage`` measures, each on its own: every configuration the README reports
(the streaming kernel in fp32 and fp16, with its impulses on chip and in the records, the window kernel of its
headline rows, the tangent basis derived on chip, the soft contact pipe, the inverse-inertia modes, the friction
coefficient per manifold).

One row of :data:`CONFIGURATIONS` per configuration: its instrumented build (:meth:`Configuration.build`, built
once) and the window plan of its runs (:meth:`Configuration.job`). A configuration's coverage is the merge of its
own runs (``sim.coverage.cases``: each case names its configuration) and the runs that share its RTL parameters
(the fp-operator vectors of its format, the register file's test). A new kernel configuration is one more row
here (a field of ``KernelBuild`` this table has no column for goes in ``build_options``) and its regression
in ``sim.coverage.cases.CASES_OF`` (e.g. ``streaming_cases(name)``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

from models.kernel import stream_format as sf
from models.kernel.body_banks import default_body_banks
from models.kernel.delay_lines import default_delay_block_min_depth
from models.golden.contact_solver import SolverParams
from models.timing.platforms import get_preset
from models.formats.frame import Frame
from models.kernel.kernel_job import KernelJob
from models.formats.number_format import FP16, FP32, NumberFormat
from models.kernel.record_window import DEFAULT_CTX, DEFAULT_DEPTH
from models.golden.soft_contact import SoftContact
from sim.compile.kernel_build import KernelBuild, default_window

# the soft rows of the soft build's runs: Box2D's contact hertz and damping ratio of the soft closed loop, at a
# 120 Hz substep (the keep factors differ from 1 in both words, so the keep multiply's operand bits toggle)
SOFT_KEEP = SoftContact(hertz=15.0, damping_ratio=1.0).keep(1.0 / 120.0)


@dataclass(frozen=True)
class Configuration:
    """One kernel configuration: the ``make sim`` knobs of a README row (FORMAT, RECORD_WINDOW, LANES, FETCH_PASSES,
    BODY_BITS, IMPULSE_STORE), the inverse-inertia words of its body record and the friction-coefficient words of
    its friction record."""

    name: str
    fmt: NumberFormat
    record_window: int = 0  # RECORD_WINDOW: 0 the streaming kernel, else the window kernel's ring (records)
    lanes: int = 1  # LANES
    fetch_passes: int = 0  # FETCH_PASSES: 0 as many passes per fetch as the ring holds
    body_bits: int = 128  # BODY_BITS
    inertia_words: int = sf.KERNEL_INERTIA_WORDS  # IINV_W: 1, 3 or 6
    impulses_in_records: bool = False  # IMPULSE_STORE=records (IMPULSES_IN_RECORDS = 1)
    friction_words: int = 0  # MU_W: 1 a friction coefficient per manifold (the Bullet 2 worlds' build)
    tangents_on_chip: bool = False  # TANGENTS=chip (TANGENTS_ON_CHIP = 1): friction records without t0, t1
    soft_keep: tuple[float, float] | None = None  # SOFT_CONTACT = 1: the runs solve Box2D's soft rows with this keep
    add_dsp: bool = False  # ADD_DSP=1: the adders in DSP48E2s (ADD_SHIFT_DSP = 1)
    beat_preset: str = "zcu102"  # the DMA preset whose stream beat the constraint stream has
    readme: str = ""  # the README row (or feature) this configuration stands for
    build_options: tuple[tuple[str, Any], ...] = ()  # other KernelBuild fields of this configuration, by name

    def build(self) -> KernelBuild:
        """The kernel build of this configuration (what ``KernelBuild.for_job`` makes of its jobs: the fp32 records
        design on its banked body velocities, as ``make sim IMPULSE_STORE=records`` builds it)."""
        kb = KernelBuild(self.fmt, cons_bits=get_preset(self.beat_preset).stream_bits,
                         body_in_bits=self.body_bits, body_out_bits=self.body_bits, window=self.record_window,
                         window_ctx=DEFAULT_CTX, lanes=self.lanes, inertia_words=self.inertia_words,
                         impulses_in_records=self.impulses_in_records, friction_words=self.friction_words,
                         tangents_on_chip=self.tangents_on_chip, soft_contact=self.soft_keep is not None,
                         body_banks=default_body_banks(self.fmt, self.impulses_in_records, bool(self.record_window),
                                                       self.lanes),
                         delay_block_min_depth=default_delay_block_min_depth(self.fmt, self.impulses_in_records,
                                                                             bool(self.record_window), self.lanes),
                         add_dsp=self.add_dsp)
        return dataclasses.replace(kb, **dict(self.build_options))

    def job(self, frame: Frame, params: SolverParams, schedule: str, fetch_passes: int | None = None) -> KernelJob:
        """The step of ``frame`` in this configuration's format, ordered by ``schedule``, on its kernel (windowed
        as ``make sim RECORD_WINDOW=...`` does, with ``fetch_passes`` passes per fetch where given; with the
        impulses in the records starting from zeros, a cold start; with the tangents derived on chip in that record
        layout; on the soft build with the configuration's keep factors). A scene whose manifolds carry their own
        friction coefficient runs on a build without the coefficient word (MU_W = 0) with the kernel's one
        coefficient; a configuration with the word takes only such scenes."""
        hazard = default_window(self.fmt, get_preset(self.beat_preset).stream_bits, window_kernel=self.record_window > 0)
        if self.soft_keep is not None:
            params = dataclasses.replace(params, soft_keep=self.soft_keep)
        job = KernelJob.from_frame(frame, self.fmt, params, schedule, hazard).with_adders(self.add_dsp)
        job = job.with_inertia(self.inertia_words == 1)  # a scalar scene's 1-word job (INERTIA=scene)
        if job.friction_words != self.friction_words:
            if self.friction_words:
                raise ValueError(f"{self.name}: the scene has no friction coefficient per manifold "
                                 "(MU_W = 1 needs one)")
            job = dataclasses.replace(job, cons=dataclasses.replace(job.cons, friction=job.cons.friction[:, :0]))
        if self.impulses_in_records:
            job = job.impulses_travelling()
            if self.tangents_on_chip:
                return job.tangents_derived()
        if not self.record_window:
            return job
        return job.windowed(self.record_window, DEFAULT_CTX, fetch_passes or self.fetch_passes or None, self.lanes)


CONFIGURATIONS: tuple[Configuration, ...] = (
    Configuration("stream-fp16-records", FP16, impulses_in_records=True,
                  readme="streaming kernel, fp16, impulses in the records: the fitting headline "
                         "(`make sim FORMAT=fp16 IMPULSE_STORE=records`)"),
    Configuration("stream-fp16-records-b256", FP16, impulses_in_records=True, body_bits=256,
                  readme="the same with 256-bit body streams: the fastest fitting fp16 design "
                         "(`make sim FORMAT=fp16 IMPULSE_STORE=records BODY_BITS=256`)"),
    Configuration("stream-fp32-records", FP32, impulses_in_records=True,
                  readme="streaming kernel, fp32, impulses in the records, body velocities in 2 banks "
                         "(`make sim IMPULSE_STORE=records`)"),
    Configuration("stream-fp32", FP32, readme="streaming kernel, fp32 (`make sim`)"),
    Configuration("stream-fp16", FP16, readme="streaming kernel, fp16 (`make sim FORMAT=fp16`)"),
    Configuration("window-fp32-l2", FP32, record_window=DEFAULT_DEPTH, lanes=2, body_bits=512,
                  readme="window kernel, fp32, 2 lanes (`RECORD_WINDOW=16384 LANES=2 BODY_BITS=512`)"),
    Configuration("window-fp16-l4", FP16, record_window=DEFAULT_DEPTH, lanes=4, body_bits=512,
                  readme="window kernel, fp16, 4 lanes (`FORMAT=fp16 RECORD_WINDOW=16384 LANES=4 BODY_BITS=512`)"),
    Configuration("window-fp32-records", FP32, record_window=8192, impulses_in_records=True, body_bits=256,
                  add_dsp=True, inertia_words=1,
                  readme="window kernel, fp32, one lane, impulses in the records, body velocities in 8 banks, the "
                         "adders in DSP48E2s, the 1-word inverse inertia: the fitting fp32 headline (`make sim "
                         "SCENE=thesis SCHEDULE=sweep RECORD_WINDOW=8192 IMPULSE_STORE=records BODY_BITS=256 "
                         "ADD_DSP=1 INERTIA=scene`)"),
    Configuration("window-fp16-records-l2", FP16, record_window=8192, lanes=2, impulses_in_records=True,
                  body_bits=256, add_dsp=True, inertia_words=1,
                  readme="window kernel, fp16, two lanes, impulses in the records, body velocities in 16 banks, the "
                         "adders in DSP48E2s, the 1-word inverse inertia, delay lines from 129 deep in block RAM: the "
                         "fitting fp16 headline (`make sim SCENE=thesis SCHEDULE=sweep FORMAT=fp16 RECORD_WINDOW=8192 "
                         "LANES=2 IMPULSE_STORE=records BODY_BITS=256 ADD_DSP=1 INERTIA=scene`)"),
    Configuration("stream-fp32-records-tangents", FP32, impulses_in_records=True, tangents_on_chip=True,
                  readme="fp32 records design with the tangent basis derived on chip "
                         "(`make sim IMPULSE_STORE=records TANGENTS=chip`)"),
    Configuration("stream-fp32-records-tangents-b256", FP32, impulses_in_records=True, tangents_on_chip=True,
                  body_bits=256, readme="the same with 256-bit body streams: the fastest fitting fp32 design "
                                        "(`make sim IMPULSE_STORE=records TANGENTS=chip BODY_BITS=256`)"),
    Configuration("stream-fp32-soft", FP32, impulses_in_records=True, soft_keep=SOFT_KEEP,
                  readme="Box2D's soft step through the RTL (`SOFT_CONTACT = 1`, impulses in the records: the soft "
                         "closed loop's build, `python -m sim.remedies.soft_rtl_loop`)"),
    Configuration("stream-fp32-inertia1", FP32, inertia_words=1,
                  readme="scalar inverse inertia, 1 word per body (IINV_W=1)"),
    Configuration("stream-fp32-inertia6", FP32, inertia_words=6,
                  readme="full symmetric inverse inertia, 6 words per body (IINV_W=6)"),
    Configuration("stream-fp32-mu", FP32, inertia_words=6, friction_words=1,
                  readme="friction coefficient per manifold and full inverse inertia (MU_W=1, IINV_W=6): the "
                         "Bullet 2 worlds' build (`make sim SCENE=docs/rotated_boxes_world.py`)"),
)
"""The inverse-inertia mode of 3 words (the diagonal) is the default of every other row."""

BY_NAME: dict[str, Configuration] = {c.name: c for c in CONFIGURATIONS}
