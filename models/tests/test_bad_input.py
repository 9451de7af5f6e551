"""The bad-input catalogue (models/kernel/bad_input.py): one entry per case, each with the status word its error code
makes (models/kernel/register_map.py) and made by at least one of the two places that run bad input."""

from __future__ import annotations

from models.kernel.bad_input import CASES, CATALOGUE
from models.kernel.register_map import ErrorCode, first_error, status_codes


def test_cases_are_named_once_and_made_somewhere() -> None:
    assert len(CASES) == len(CATALOGUE)
    assert all(c.cosim or c.harness for c in CATALOGUE)
    assert all(c.edits and c.response for c in CATALOGUE)


def test_status_word_of_each_case() -> None:
    for case in CATALOGUE:
        if case.code is None:
            assert case.status == 0, case.name
        else:
            assert status_codes(case.status) == [int(case.code)] and first_error(case.status) == case.code
    assert CASES["unmapped_axi"].status == (1 << 24) | (9 << 8)
    assert CASES["nonfinite_body"].status == (1 << 4) | (5 << 8)
    assert {c.code for c in CATALOGUE} >= set(ErrorCode)  # every error code has a case
