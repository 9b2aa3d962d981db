"""The vocabulary of SUMMARY.md's claims: a :class:`Claim` (the paper's words, the rule that tests
them, the verdict and the numbers behind it) and the helpers every paper's rules share. Each
paper's rules: :mod:`aceval.report.kong_claims`, :mod:`aceval.report.ricci_claims`.
"""

from __future__ import annotations

from dataclasses import dataclass

import pandas as pd

HOLDS, FAILS, UNTESTABLE = "holds", "does not hold", "not testable on this dataset"
UPPER, LOWER = ["head", "chest", "waist"], ["thigh", "shank", "foot"]


#: where a check is reported: a claim of a paper, a check of aceval's code, or aceval's own
#: comparison with a ground truth (beyond the papers)
PAPER, CODE, GROUND_TRUTH = "paper", "code", "ground truth"


@dataclass
class Claim:
    """One claim of a paper, the rule that tests it, the verdict and the numbers behind it."""

    objective: str
    claim: str
    rule: str
    verdict: str
    numbers: str
    section: str = PAPER


def _verdict(ok: bool) -> str:
    return HOLDS if ok else FAILS


def _untestable(objective, claim, rule, why) -> Claim:
    return Claim(objective, claim, rule, UNTESTABLE, why)


def _cells(table: pd.DataFrame | None) -> pd.DataFrame:
    """Rows of a reproduced table that this run has values for."""
    if table is None:
        return pd.DataFrame()
    return table[table["n"] > 0]


def _where(row, *keys) -> str:
    return " ".join(str(row[k]) for k in keys)
