"""The vocabulary of SUMMARY.md's claims: a :class:`Claim` (the paper's words, the rule that tests
them, the verdict and the numbers behind it), the four verdicts, and how a rule reaches one from
estimates with their uncertainty. Each paper's rules, as data: :mod:`aceval.report.kong_claims`,
:mod:`aceval.report.ricci_claims`.

Every claim is judged on the subject as the independent unit: a table cell's value is the mean of
the subjects' own means for that cell, with its 95 % t-interval over the subjects (a statistic of
several cells, such as a share, by resampling the subjects). A rule compares that interval with
the claim's number:

* **holds**: the whole interval is on the claim's side;
* **does not hold**: the whole interval is on the other side;
* **inconclusive**: the interval includes both (one subject gives no interval at all);
* **not testable**: this dataset has nothing to judge it on.

"No difference" is an equivalence (two one-sided tests, the 90 % interval inside a stated margin).
Every number a rule compares with is the paper's own (its words, its tables' values and SDs) or a
cited convention; the rule says which.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

HOLDS, FAILS, INCONCLUSIVE = "holds", "does not hold", "inconclusive"
UNTESTABLE = "not testable on this dataset"
VERDICTS = (HOLDS, FAILS, INCONCLUSIVE, UNTESTABLE)
UPPER, LOWER = ["head", "chest", "waist"], ["thigh", "shank", "foot"]
#: the resamples of the subjects behind a statistic of several cells (its 2.5th and 97.5th
#: percentiles are the 25th smallest and largest)
N_RESAMPLES = 1000

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


@dataclass(frozen=True)
class Rule:
    """One claim as data: its objective, the paper's words, the rule (with the source of every
    number it compares with) and the judge that reads the evidence: ``judge(evidence) ->
    (verdict, numbers)``, or ``(UNTESTABLE, why)``.
    """

    objective: str
    claim: str
    rule: str
    judge: Callable
    section: str = PAPER

    def apply(self, evidence) -> Claim:
        """The claim judged on ``evidence``."""
        verdict, numbers = self.judge(evidence)
        return Claim(self.objective, self.claim, self.rule, verdict, numbers, self.section)


# --- estimates: a cell's value over the subjects ----------------------------------------------


def subject_cells(frame: pd.DataFrame, keys: list[str], value: str) -> pd.DataFrame:
    """Each subject's mean ``value`` in each cell (``keys``): one row per subject and cell."""
    return frame.groupby(["subject", *keys], sort=True)[value].mean().reset_index()


def cell_estimates(cells: pd.DataFrame, keys: list[str], value: str) -> pd.DataFrame:
    """Per cell: ``mean`` over the subjects of their means, its 95 % and 90 % t-intervals
    (``low``, ``high``, ``low90``, ``high90``) and ``n`` subjects.
    """
    from aceval.evaluation.stats import mean_ci

    rows = []
    for key, group in cells.groupby(keys, sort=True):
        mean, low, high, n = mean_ci(group[value])
        _, low90, high90, _ = mean_ci(group[value], 0.90)
        key = key if isinstance(key, tuple) else (key,)
        rows.append((*key, mean, low, high, low90, high90, n))
    return pd.DataFrame(rows, columns=[*keys, "mean", "low", "high", "low90", "high90", "n"])


def resampled(wide: pd.DataFrame, statistic: Callable, seed: int = 0) -> tuple[float, float, float]:
    """``(value, low, high)``: ``statistic`` of the subjects' table ``wide`` (one row per subject,
    one column per cell) and its 95 % percentile interval over :data:`N_RESAMPLES` resamples of
    the subjects with replacement (NaN interval with fewer than 2 subjects).
    """
    values = wide.to_numpy(float)
    value = float(statistic(values))
    if len(values) < 2:
        return value, float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    draws = rng.integers(0, len(values), size=(N_RESAMPLES, len(values)))
    stats = np.array([statistic(values[rows]) for rows in draws], dtype=float)
    low, high = np.nanpercentile(stats, [2.5, 97.5])
    return value, float(low), float(high)


# --- verdicts ---------------------------------------------------------------------------------


def beyond(low: float, high: float, limit: float, side: str) -> str:
    """The verdict of "the value is ``side`` ('<', '<=', '>', '>=') ``limit``" from its interval."""
    if not (np.isfinite(low) and np.isfinite(high)):
        return INCONCLUSIVE
    holds, fails = {
        "<": (high < limit, low >= limit),
        "<=": (high <= limit, low > limit),
        ">": (low > limit, high <= limit),
        ">=": (low >= limit, high < limit),
    }[side]
    return HOLDS if holds else FAILS if fails else INCONCLUSIVE


def equivalent(low90: float, high90: float, low: float, high: float, margin: float) -> str:
    """Two one-sided tests of a difference against ``+-margin``: holds when the 90 % interval is
    inside it, does not hold when the 95 % interval is wholly outside it, else inconclusive.
    """
    if not all(np.isfinite([low90, high90, low, high])):
        return INCONCLUSIVE
    if -margin < low90 and high90 < margin:
        return HOLDS
    return FAILS if low > margin or high < -margin else INCONCLUSIVE


def equivalent_to(estimate, target: float, margin: float) -> str:
    """:func:`equivalent` of an estimate's mean (its ``low90``, ``high90``, ``low``, ``high``)
    and ``target``: the two agree within ``margin``.
    """
    return equivalent(
        estimate["low90"] - target,
        estimate["high90"] - target,
        estimate["low"] - target,
        estimate["high"] - target,
        margin,
    )


def every(verdicts) -> str:
    """All of several verdicts: does not hold if one does not, holds if all do, else
    inconclusive; nothing to judge: not testable.
    """
    verdicts = list(verdicts)
    if not verdicts:
        return UNTESTABLE
    if FAILS in verdicts:
        return FAILS
    return HOLDS if all(v == HOLDS for v in verdicts) else INCONCLUSIVE


def tally(verdicts: list[str]) -> str:
    """'holds / fails / undecided' counts of several cells' verdicts, e.g. '62 / 0 / 10'."""
    return " / ".join(str(verdicts.count(v)) for v in (HOLDS, FAILS, INCONCLUSIVE))


def interval(mean: float, low: float, high: float, digits: int = 2) -> str:
    """'2.49 [1.93, 3.05]' (the interval left out when there is none)."""
    if not np.isfinite(mean):
        return "n/a"
    if not (np.isfinite(low) and np.isfinite(high)):
        return f"{mean:.{digits}f} (no interval)"
    return f"{mean:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"


def _cells(table: pd.DataFrame | None) -> pd.DataFrame:
    """Rows of a reproduced table that this run has values for."""
    if table is None:
        return pd.DataFrame()
    return table[table["n"] > 0]
