"""The vocabulary of SUMMARY.md's claims: a :class:`Claim` (the paper's words, the rule that tests
them, the verdict and the numbers behind it), the verdicts, and how a rule reaches one. Each
paper's rules, as data: :mod:`aceval.report.kong_claims`, :mod:`aceval.report.ricci_claims`.

Every claim with subjects is judged on *cells* (:class:`Cells`): one value per subject and cell
(the subject is the independent unit), each cell with the side of the paper's number it must be
on. :mod:`aceval.evaluation.verdicts` reads the verdicts from the cells' t-intervals:

* **holds**: every cell's own 95 % interval is on the claim's side (an intersection-union test;
  for "mostly": more than half of the intervals simultaneous over the cells);
* **does not hold**: a cell's interval, simultaneous over the claim's cells (Bonferroni), is
  wholly on the other side (for "mostly": half of them or more);
* **no relevant difference**: a superiority claim whose cells' intervals lie within its smallest
  effect of interest (the others shown);
* **inconclusive**: none of these; it says which way the point estimates lean and how many
  subjects would decide it with 80 % probability;
* **not testable**: this dataset has nothing to judge it on, or no cell has two subjects.

"No difference" and "reproduces the paper's value" are equivalences (the interval within a margin
fixed in advance), never p >= 0.05. Every number a rule compares with is the paper's own (its
words, its tables' values at the precision they are reported with) or a cited smallest effect of
interest; the rule says which. A claim without subjects (one rigid box, the code checks) is
judged on its values.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from aceval.evaluation.verdicts import (
    FAILS,
    HOLDS,
    INCONCLUSIVE,
    MIN_SUBJECTS,
    NEGLIGIBLE,
    UNTESTABLE,
    VERDICTS,
    Judgement,
    Requirement,
    judge,
)

__all__ = [
    "CODE",
    "FAILS",
    "GROUND_TRUTH",
    "HOLDS",
    "INCONCLUSIVE",
    "LOWER",
    "NEGLIGIBLE",
    "PAPER",
    "UNTESTABLE",
    "UPPER",
    "VERDICTS",
    "Cells",
    "Claim",
    "Requirement",
    "Rule",
    "interval",
    "every_cell",
    "labelled",
    "one_cell",
    "subject_cells",
]

UPPER, LOWER = ["head", "chest", "waist"], ["thigh", "shank", "foot"]

#: where a check is reported: a claim of a paper, a check of aceval's code, or aceval's own
#: comparison with a ground truth (beyond the papers)
PAPER, CODE, GROUND_TRUTH = "paper", "code", "ground truth"


@dataclass
class Cells:
    """What a rule judges a claim on: ``cells`` (``cell``, ``subject``, ``value``: one value per
    subject and cell), each cell's :class:`Requirement` (in the order shown), how the cells
    combine ('all', or 'majority' for "mostly"), the values' unit and digits, and ``note``: what
    the numbers add after the interval (the paper's values, a sensitivity).
    """

    cells: pd.DataFrame
    requirements: dict
    combine: str = "all"
    unit: str = ""
    digits: int = 2
    note: str = ""
    subjects: str = "subjects"


@dataclass
class Claim:
    """One claim of a paper, the rule that tests it, the verdict and the numbers behind it; for a
    claim judged on cells, its :class:`~aceval.evaluation.verdicts.Judgement` and the cells.
    """

    objective: str
    claim: str
    rule: str
    verdict: str
    numbers: str
    section: str = PAPER
    key: str = ""
    judgement: Judgement | None = None
    cells: pd.DataFrame | None = field(default=None, repr=False)


@dataclass(frozen=True)
class Rule:
    """One claim as data: its objective, the paper's words, the rule (with the source of every
    number it compares with) and the judge that reads the evidence: ``judge(evidence)`` returns
    :class:`Cells`, or ``(verdict, numbers)`` for a claim without subjects or ``(UNTESTABLE,
    why)``. ``key``: a short stable name (the committed tables' ``claim`` column).
    """

    objective: str
    claim: str
    rule: str
    judge: Callable
    section: str = PAPER
    key: str = ""

    def apply(self, evidence) -> Claim:
        """The claim judged on ``evidence``."""
        found = self.judge(evidence)
        if not isinstance(found, Cells):
            verdict, numbers = found
            return Claim(
                self.objective, self.claim, self.rule, verdict, numbers, self.section, self.key
            )
        judgement = judge(found.cells, found.requirements, found.combine)
        return Claim(
            self.objective,
            self.claim,
            self.rule,
            judgement.verdict,
            described(judgement, found),
            self.section,
            self.key,
            judgement,
            found.cells[["cell", "subject", "value"]],
        )


# --- cells ------------------------------------------------------------------------------------


def subject_cells(frame: pd.DataFrame, keys: list[str], value: str) -> pd.DataFrame:
    """Each subject's mean ``value`` in each cell (``keys``): one row per subject and cell."""
    return frame.groupby(["subject", *keys], sort=True)[value].mean().reset_index()


def labelled(cells: pd.DataFrame, keys: list[str], value: str) -> pd.DataFrame:
    """Subject cells (:func:`subject_cells`) as :class:`Cells` reads them: ``cell`` the keys'
    values joined by spaces ('T2 waist 1'), ``subject``, ``value``.
    """
    if cells.empty:
        return pd.DataFrame(columns=["cell", "subject", "value"])
    label = cells[keys].astype(str).agg(" ".join, axis=1)
    return pd.DataFrame({"cell": label, "subject": cells["subject"], "value": cells[value]})


def one_cell(name: str, per_subject: pd.Series) -> pd.DataFrame:
    """One cell's long rows from a value per subject (the series' index)."""
    return pd.DataFrame({"cell": name, "subject": per_subject.index, "value": per_subject.values})


def every_cell(cells: pd.DataFrame, requirement: Requirement) -> dict:
    """The same requirement for every cell of ``cells``, in their order."""
    return {cell: requirement for cell in dict.fromkeys(cells["cell"])}


# --- numbers ----------------------------------------------------------------------------------


def interval(mean: float, low: float, high: float, digits: int = 2) -> str:
    """'2.49 [1.93, 3.05]' (the interval left out when there is none)."""
    if not np.isfinite(mean):
        return "n/a"
    if not (np.isfinite(low) and np.isfinite(high)):
        return f"{mean:.{digits}f} (no interval)"
    return f"{mean:.{digits}f} [{low:.{digits}f}, {high:.{digits}f}]"


def adjustment(m: int, combine: str = "all") -> str:
    """Which interval decides which verdict over a claim's ``m`` cells."""
    if m <= 1:
        return "95 % interval, one cell"
    simultaneous = f"{100 * (1 - 0.05 / m):.3g} %"
    if combine == "majority":
        return f"{simultaneous} intervals: simultaneous 95 % over {m} cells (Bonferroni), both verdicts"
    return (
        f"own 95 % intervals for 'holds', {simultaneous} simultaneous over {m} cells "
        "(Bonferroni) for 'does not hold'"
    )


def _subjects_text(table: pd.DataFrame, row: pd.Series, subjects: str) -> str:
    """'n 5 subjects', or 'n 2-5 subjects per cell (this cell 2)' and the cells without an
    interval.
    """
    low, high = int(table["n"].min()), int(table["n"].max())
    one = {"subjects": "subject", "children": "child"}.get(subjects, subjects)
    text = (
        f"n {high} {one if high == 1 else subjects}"
        if low == high
        else f"n {low}-{high} {subjects} per cell (this cell {int(row['n'])})"
    )
    alone = int((table["n"] < MIN_SUBJECTS).sum())
    if alone and low != high:
        text += (
            f"; {alone} cell{'s' if alone > 1 else ''} with fewer than {MIN_SUBJECTS}: no interval"
        )
    return text


def _deciding_interval(judgement: Judgement, row: pd.Series, digits: int, unit: str) -> str:
    """The deciding cell's interval that decided (or would decide) the verdict: the simultaneous
    one for 'does not hold' and for "mostly", else its own; both when they differ.
    """
    simultaneous = interval(row["mean"], row["low"], row["high"], digits)
    if judgement.m <= 1 or judgement.combine == "majority":
        return f"{simultaneous}{unit}"
    own = interval(row["mean"], row["low_each"], row["high_each"], digits)
    if not np.isfinite(row["low"]):
        return f"{own}{unit}"
    return f"{own}{unit}, simultaneous [{row['low']:.{digits}f}, {row['high']:.{digits}f}]"


def described(judgement: Judgement, found: Cells) -> str:
    """The numbers of a claim judged on cells: the deciding cell's intervals, which interval
    decides which verdict, the cells' states, the subjects and the note.
    """
    table = judgement.estimates
    if table.empty:
        return "no cell"
    row = judgement.deciding
    unit = f" {found.unit}" if found.unit else ""
    if judgement.verdict == UNTESTABLE:
        return (
            f"no cell has {MIN_SUBJECTS} {found.subjects}: no interval, so no verdict; "
            f"cell {row['cell']}: {interval(row['mean'], np.nan, np.nan, found.digits)}{unit} "
            f"({row['requirement']}{unit}); {_subjects_text(table, row, found.subjects)}"
        ) + (f"; {found.note}" if found.note else "")
    which = {
        HOLDS: "closest to its bound",
        FAILS: "farthest beyond its bound",
        NEGLIGIBLE: "with the smallest margin",
    }.get(judgement.verdict, "closest to failing")
    which = "at the majority" if found.combine == "majority" else which
    names = ["shown", "beyond", "undecided"]
    if np.isfinite(table["smallest_effect"]).any():
        names.insert(2, "negligible")
    states = " / ".join(str((table["state"] == s).sum()) for s in names)
    text = (
        f"cell {which}: {row['cell']} {_deciding_interval(judgement, row, found.digits, unit)} "
        f"({row['requirement']}{unit}); {adjustment(judgement.m, judgement.combine)}; cells "
        f"{' / '.join(names)}: {states}; {_subjects_text(table, row, found.subjects)}"
    )
    return text + (f"; {found.note}" if found.note else "")


def verdict_text(claim: Claim) -> str:
    """The verdict as SUMMARY.md shows it: an inconclusive one with its leaning and the subjects
    that would decide it.
    """
    j = claim.judgement
    if claim.verdict != INCONCLUSIVE or j is None:
        return claim.verdict
    if not j.leaning:
        return f"{claim.verdict} (the estimates lean neither way)"
    n = j.n_to_decide
    if np.isfinite(n):
        needed = f"about {int(n)} subjects would decide it (80 %)"
    elif not np.isfinite(j.estimates["sd"]).all():
        needed = "no SD: the subjects needed cannot be computed"
    else:
        needed = "not decidable with 100,000 subjects at these effects"
    return f"{claim.verdict} (leans '{j.leaning}'; {needed})"


def rule_sentences(found: list[Claim]) -> list[str]:
    """How each family of claims present in ``found`` is judged, one line each (SUMMARY.md)."""
    judged = [c.judgement for c in found if c.judgement is not None and c.judgement.m]
    cells = pd.concat([j.estimates for j in judged]) if judged else pd.DataFrame()
    two_bounds = (
        (np.isfinite(cells["above"]) & np.isfinite(cells["below"])).any() if len(cells) else False
    )
    families = [
        (
            any(j.combine == "all" for j in judged),
            "- a claim over every cell holds when each cell's own 95 % interval is on the claim's "
            "side (an intersection-union test: showing every cell needs no adjustment), does not "
            "hold when one cell's interval, made simultaneous over the claim's cells (Bonferroni), "
            "is wholly on the other side;",
        ),
        (
            any(j.combine == "majority" for j in judged),
            '- a "mostly" claim holds when more than half of its cells\' simultaneous intervals '
            "are on the claim's side, does not hold when half of them or more are wholly on the "
            "other side;",
        ),
        (
            two_bounds,
            '- an equivalence ("no difference", "reproduces the paper\'s value", "about" a '
            "number) holds when the interval lies inside its margin and does not hold when it "
            "lies wholly outside it (two one-sided tests at 2.5 % each, as every side here);",
        ),
        (
            len(cells) > 0 and np.isfinite(cells["smallest_effect"]).any(),
            "- a superiority claim has a smallest effect of interest: a cell whose own interval "
            "lies within it of the bound is negligible, and a claim whose cells are all shown or "
            "negligible, one at least negligible, has no relevant difference;",
        ),
        (
            any(c.judgement is None and c.verdict != UNTESTABLE for c in found),
            "- a claim without subjects (one rigid box, one set of random starts) is judged on "
            "its values, and says so;",
        ),
        (
            any(c.verdict == UNTESTABLE for c in found),
            f"- not testable: the dataset has nothing to judge the claim on, or no cell has "
            f"{MIN_SUBJECTS} subjects (no interval).",
        ),
    ]
    return [text for present, text in families if present]


def claims_table(found: list[Claim]) -> pd.DataFrame:
    """One row per claim: its verdict, leaning, subjects that would decide it, the adjustment
    and the deciding cell's interval (``claims.csv``).
    """
    rows = []
    for c in found:
        j = c.judgement
        row = j.deciding if j is not None and len(j.estimates) else None
        rows.append(
            {
                "claim": c.key,
                "section": c.section,
                "objective": c.objective,
                "verdict": c.verdict,
                "leaning": j.leaning if j is not None else "",
                "n_to_decide": j.n_to_decide if j is not None else np.nan,
                "cells": j.m if j is not None else 0,
                "combine": j.combine if j is not None else "",
                "level": j.level if j is not None and j.m else np.nan,
                "shown_level": j.shown_level if j is not None and j.m else np.nan,
                "deciding_cell": row["cell"] if row is not None else "",
                "n": row["n"] if row is not None else np.nan,
                "mean": row["mean"] if row is not None else np.nan,
                "low": row["low"] if row is not None else np.nan,
                "high": row["high"] if row is not None else np.nan,
                "low_each": row["low_each"] if row is not None else np.nan,
                "high_each": row["high_each"] if row is not None else np.nan,
                "requirement": row["requirement"] if row is not None else "",
            }
        )
    return pd.DataFrame(rows)


def estimates_table(found: list[Claim]) -> pd.DataFrame:
    """Every cell of every claim judged on cells, with its interval and state
    (``claim_estimates.csv``).
    """
    parts = [c.judgement.estimates.assign(claim=c.key) for c in found if c.judgement is not None]
    parts = [p for p in parts if len(p)]
    if not parts:
        return pd.DataFrame(columns=["claim", "cell"])
    table = pd.concat(parts, ignore_index=True)
    return table[["claim", *[c for c in table.columns if c != "claim"]]]


def cells_table(found: list[Claim]) -> pd.DataFrame:
    """The per-subject cells behind every verdict (``claim_cells.csv``)."""
    parts = [c.cells.assign(claim=c.key) for c in found if c.cells is not None and len(c.cells)]
    if not parts:
        return pd.DataFrame(columns=["claim", "cell", "subject", "value"])
    return pd.concat(parts, ignore_index=True)[["claim", "cell", "subject", "value"]]


def present(table: pd.DataFrame | None) -> pd.DataFrame:
    """Rows of a reproduced table that this run has values for."""
    if table is None or not len(table):
        return pd.DataFrame()
    return table[table["n"] > 0]
