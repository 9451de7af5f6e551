"""The kernel's catalogue of bad input, defined once (the world files' is ``models/scenes/bad_worlds.py``): each
case's name, what it makes bad, the error code it raises (``models.kernel.register_map.ErrorCode``) and the kernel's
documented response (``rtl/README.md``, "Error codes" and "Bad input").

Two places make these cases and check them: the bad-input co-simulation (``cocotb_tests/test_kernel_bad_input.py``:
one scenario per case with :attr:`BadInputCase.cosim`, bit for bit against the golden model's prediction of the
response) and the coverage regression (``sim/coverage``: edits of the compiled harness's input files, one run
per edit, each edit naming the cases it makes; :attr:`BadInputCase.harness`). The harness has no reset pin and
no AXI4-Lite response channel, so the mid-run reset is co-simulation only; ``iterations = 0`` and
``num_bodies = 0`` are harness runs only.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from models.kernel.register_map import ErrorCode, status_flag


@dataclass(frozen=True)
class BadInputCase:
    """One kind of bad input and what the kernel must do with it."""

    name: str
    edits: str  # what is made bad
    code: Optional[ErrorCode]  # the error it raises (None: not an error)
    response: str  # what the kernel does
    cosim: bool = True  # a scenario of the bad-input co-simulation
    harness: bool = True  # made by an edit of the harness's input files (coverage)

    @property
    def status(self) -> int:
        """The status register after this case alone: its flag and, as the first error, its code (0: none)."""
        return 0 if self.code is None else status_flag(self.code) | (int(self.code) << 8)

    def describe(self) -> str:
        return f"{self.edits}: {self.response}" + ("" if self.code is None else f" ({int(self.code)})")


CATALOGUE: tuple[BadInputCase, ...] = (
    BadInputCase("nonfinite_constraint", "NaN in a normal (both record kinds), +inf in a contact bias",
                 ErrorCode.NON_FINITE, "records rejected"),
    BadInputCase("nonfinite_body", "NaN in a position, -inf in an angular velocity", ErrorCode.NON_FINITE,
                 "bodies frozen, their manifolds rejected"),
    BadInputCase("body_index", "a body index >= num_bodies and a manifold naming one body twice",
                 ErrorCode.BODY_INDEX, "rejected"),
    BadInputCase("zero_inverse_mass", "inverse mass 0 makes a body static", ErrorCode.STATIC_PAIR,
                 "the manifold to the ground is static-static: rejected"),
    BadInputCase("negative_inverse_mass", "negative inverse mass / inertia", ErrorCode.NEGATIVE_MASS,
                 "bodies frozen, their manifolds rejected"),
    BadInputCase("tlast_early", "a pass shorter than num_manifolds, a record cut short", ErrorCode.CONS_TLAST,
                 "missing slots rejected"),
    BadInputCase("tlast_late", "passes longer than num_manifolds (also the last pass)", ErrorCode.CONS_TLAST,
                 "extra beats discarded"),
    BadInputCase("body_tlast_early", "body stream short by bodies, cut inside a record", ErrorCode.BODY_TLAST,
                 "missing bodies loaded as zero records, the cut one too: all frozen"),
    BadInputCase("body_tlast_late", "body stream long by a record", ErrorCode.BODY_TLAST, "extra beats discarded"),
    BadInputCase("zero_manifolds", "num_manifolds = 0", None, "the bodies are integrated, no constraint stream read"),
    BadInputCase("zero_iterations", "iterations = 0", None, "the bodies are integrated, no constraint stream read",
                 cosim=False),
    BadInputCase("zero_bodies", "num_bodies = 0", None, "nothing loaded, solved or integrated", cosim=False),
    BadInputCase("bad_argument", "num_bodies > MAX_BODIES", ErrorCode.BAD_ARGS,
                 "the step ends at once, streams untouched"),
    BadInputCase("start_busy", "ap_start written during a run", ErrorCode.START_WHILE_BUSY,
                 "ignored; no second run"),
    BadInputCase("reset_mid_run", "ap_rst_n (and a DMA reset) in the middle of a run", None, "idle at once, status 0",
                 harness=False),
    BadInputCase("unmapped_axi", "AXI4-Lite read / write of unmapped addresses", ErrorCode.UNMAPPED,
                 "SLVERR, read 0, write ignored"),
)
CASES: dict[str, BadInputCase] = {c.name: c for c in CATALOGUE}
