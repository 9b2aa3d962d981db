"""Issue 41's sweep as a test (the cases: tests/sweep.py): each case of bad input or of a hostile
environment must end in its expected outcome (a clear error or refusal, a flag or warning, or the
right number), never a traceback, a hang, a partial output, a changed input or a silent wrong
number. `python benchmarks/bad_input_sweep.py` prints the same cases' outcomes and their counts.
"""

from __future__ import annotations

import pytest

from .sweep import CASES, FAILURES


@pytest.mark.slow
@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_case_ends_as_expected(case, clean, tmp_path):
    assert case.run(clean, tmp_path) == case.expected


def test_the_sweep_expects_no_failure_and_covers_every_outcome():
    expected = {c.expected for c in CASES}
    assert not expected & set(FAILURES)
    assert expected == {"error", "refused", "flag", "warning", "correct"}
