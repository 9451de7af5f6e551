"""The seed of every randomised run and test: ``SEED`` from the environment, else :data:`DEFAULT_SEED`.

One default everywhere: ``make test`` and ``make sim`` (the Makefile's ``SEED``), a test run alone with pytest, the
commands. CI derives its seed from the commit (``.ci/run``) and prints it; ``SEED=<n>`` reruns any run or test with
that seed.
"""

from __future__ import annotations

import os

DEFAULT_SEED = 1


def run_seed() -> int:
    """``SEED`` from the environment (an integer), else :data:`DEFAULT_SEED`."""
    value = os.environ.get("SEED", "").strip()
    if not value:
        return DEFAULT_SEED
    try:
        return int(value)
    except ValueError:
        raise ValueError(f"SEED must be an integer, got {value!r}") from None
