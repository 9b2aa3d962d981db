"""Verdicts from subject-level cells (issue 42): simultaneous intervals over a claim's cells, which
way an undecided claim leans, and how many subjects would decide it.

A claim is judged on *cells*: one value per subject and cell (a table cell's subject mean, a
subject's difference between two sensor sets, a subject's share of variance...), the subject being
the independent unit. Each cell has a :class:`Requirement` (the claim's side of one bound, or of
two: a range or an equivalence margin). The cells' 95 % t-intervals are made simultaneous over the
claim's ``m`` cells by Bonferroni (each cell's interval at level 1 - 0.05 / m), and the same
intervals decide both ways:

* a cell is **shown** when its interval is wholly on the claim's side of every bound, **beyond**
  when it is wholly on the other side of one bound, else undecided;
* a claim over every cell (``'all'``) **holds** when every cell is shown, **does not hold** when a
  cell is beyond (after adjustment), else it is **inconclusive**; ``'majority'`` ("mostly")
  holds when more than half the cells are shown, does not hold when at least half are beyond.

An inconclusive claim *leans* the way its point estimates (intervals of zero width) would decide;
:func:`n_to_decide` is the number of subjects at which the claim would reach that verdict with
80 % probability if its cells' means and SDs were the truth (noncentral t, cells independent).
Everything is vectorised over resamples (:func:`verdict_codes`), so the operating
characteristics (:mod:`aceval.report.operating`) run the very same rule.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

HOLDS, FAILS, INCONCLUSIVE = "holds", "does not hold", "inconclusive"
UNTESTABLE = "not testable on this dataset"
VERDICTS = (HOLDS, FAILS, INCONCLUSIVE, UNTESTABLE)
#: the verdicts as codes, in :func:`verdict_codes`' output
CODES = (HOLDS, FAILS, INCONCLUSIVE)
#: the family-wise error rate of a claim (two-sided: each side 2.5 %, as a 95 % interval)
ALPHA = 0.05
#: the probability of deciding at which :func:`n_to_decide` stops
POWER = 0.8
#: the largest number of subjects :func:`n_to_decide` looks at
MAX_N = 100_000
COMBINES = ("all", "majority")


@dataclass(frozen=True)
class Requirement:
    """What a cell must be for the claim: above ``above`` and/or below ``below`` (NaN: no such
    bound); ``*_inclusive``: the bound itself is on the claim's side ('>=', '<=').
    """

    above: float = np.nan
    above_inclusive: bool = False
    below: float = np.nan
    below_inclusive: bool = False

    @classmethod
    def of(cls, side: str, bound: float) -> Requirement:
        """'<', '<=', '>' or '>=' ``bound``."""
        if side not in ("<", "<=", ">", ">="):
            raise ValueError(f"side {side!r} is not one of <, <=, >, >=")
        if side.startswith(">"):
            return cls(above=float(bound), above_inclusive=side == ">=")
        return cls(below=float(bound), below_inclusive=side == "<=")

    @classmethod
    def within(cls, target: float, margin: float) -> Requirement:
        """Equivalence: strictly within ``target`` +- ``margin`` (two one-sided tests)."""
        return cls(above=target - margin, below=target + margin)

    def text(self, digits: int = 3) -> str:
        """'< 2.5', '>= 0.14', '> -0.004 and < 0.004'."""
        parts = []
        if np.isfinite(self.above):
            parts.append(f"{'>=' if self.above_inclusive else '>'} {self.above:.{digits}g}")
        if np.isfinite(self.below):
            parts.append(f"{'<=' if self.below_inclusive else '<'} {self.below:.{digits}g}")
        return " and ".join(parts)


REQUIREMENT_COLUMNS = ["above", "above_inclusive", "below", "below_inclusive"]


def requirement_arrays(requirements) -> dict[str, np.ndarray]:
    """The cells' requirements as arrays (C,) by :data:`REQUIREMENT_COLUMNS`."""
    return {
        "above": np.array([r.above for r in requirements], float),
        "above_inclusive": np.array([r.above_inclusive for r in requirements], bool),
        "below": np.array([r.below for r in requirements], float),
        "below_inclusive": np.array([r.below_inclusive for r in requirements], bool),
    }


def level(m: int) -> float:
    """The confidence level of each cell's interval, simultaneous 95 % over ``m`` cells."""
    return 1.0 - ALPHA / max(int(m), 1)


def half_width(sd, count, m: int) -> np.ndarray:
    """The Bonferroni-adjusted t-interval's half width (NaN with fewer than 2 subjects)."""
    from scipy import stats

    sd, count = np.asarray(sd, float), np.asarray(count, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = stats.t.ppf(1.0 - ALPHA / (2 * max(int(m), 1)), np.where(count > 1, count - 1, np.nan))
        return t * sd / np.sqrt(count)


def cell_states(low, high, req: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(shown, beyond)`` of cells (arrays (..., C)) from their intervals ``low``, ``high``:
    shown when the interval is on the claim's side of every bound, beyond when it is wholly on
    the other side of one. No interval (NaN): neither.
    """
    above, below = req["above"], req["below"]
    has_above, has_below = np.isfinite(above), np.isfinite(below)
    with np.errstate(invalid="ignore"):
        above_shown = np.where(req["above_inclusive"], low >= above, low > above)
        above_beyond = np.where(req["above_inclusive"], high < above, high <= above)
        below_shown = np.where(req["below_inclusive"], high <= below, high < below)
        below_beyond = np.where(req["below_inclusive"], low > below, low >= below)
    shown = np.where(has_above, above_shown, True) & np.where(has_below, below_shown, True)
    shown &= np.isfinite(low) & np.isfinite(high)
    beyond = (has_above & above_beyond) | (has_below & below_beyond)
    return shown, beyond


def combined(shown: np.ndarray, beyond: np.ndarray, combine: str = "all") -> np.ndarray:
    """The claim's verdict codes (index into :data:`CODES`) from its cells' states (..., C)."""
    m = shown.shape[-1]
    if combine == "all":
        holds, fails = shown.all(axis=-1), beyond.any(axis=-1)
    elif combine == "majority":
        holds, fails = shown.sum(axis=-1) > m / 2, beyond.sum(axis=-1) >= m / 2
    else:
        raise ValueError(f"combine {combine!r} is not one of {', '.join(COMBINES)}")
    return np.where(holds, 0, np.where(fails, 1, 2))


def verdict_codes(mean, sd, count, req: dict, combine: str = "all") -> np.ndarray:
    """The verdict codes of claims whose cells (last axis) have these means, SDs and subject
    counts: the rule of this module, vectorised over any leading axes (resamples).
    """
    m = np.shape(mean)[-1]
    half = half_width(sd, count, m)
    shown, beyond = cell_states(mean - half, mean + half, req)
    return combined(shown, beyond, combine)


def margins(mean, sd, req: dict) -> np.ndarray:
    """Each cell's distance from its nearest bound in SDs of the subjects' values, positive on the
    claim's side (the cell closest to failing has the smallest); +-inf with no spread.
    """
    mean, sd = np.asarray(mean, float), np.asarray(sd, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        to_above = np.where(np.isfinite(req["above"]), (mean - req["above"]) / sd, np.inf)
        to_below = np.where(np.isfinite(req["below"]), (req["below"] - mean) / sd, np.inf)
        distance = np.minimum(to_above, to_below)
        signed_zero = np.where(np.fmin(mean - req["above"], req["below"] - mean) > 0, 1, -1)
        return np.where(sd == 0, signed_zero * np.inf, distance)


# --- one claim ----------------------------------------------------------------------------------


@dataclass
class Judgement:
    """A claim judged on its cells: the verdict, the cells' estimates (``cell``, ``n``, ``mean``,
    ``sd``, ``low``, ``high`` at :attr:`level`, the requirement and the cell's state), the
    deciding cell (the closest to failing, or for "mostly" the one at the majority), the way an
    inconclusive claim leans and the subjects that would decide it (NaN: beyond :data:`MAX_N`).
    """

    verdict: str
    estimates: pd.DataFrame
    combine: str = "all"
    leaning: str = ""
    n_to_decide: float = np.nan

    @property
    def m(self) -> int:
        """The cells the interval is simultaneous over."""
        return len(self.estimates)

    @property
    def level(self) -> float:
        """Each cell's confidence level (:func:`level`)."""
        return level(self.m)

    @property
    def deciding(self) -> pd.Series:
        """The estimates' row of the cell that decides the claim."""
        order = self.estimates.sort_values("margin", kind="stable")
        if self.combine == "majority":
            return order.iloc[len(order) - (len(order) // 2 + 1)]
        return order.iloc[0]


def estimates(cells: pd.DataFrame, requirements: dict) -> pd.DataFrame:
    """Per cell of ``cells`` (``cell``, ``subject``, ``value``; one value per subject and cell),
    in the order of ``requirements`` (cell -> :class:`Requirement`): n, mean, SD, the interval
    simultaneous over the cells, the requirement, ``state`` ('shown', 'beyond', 'undecided') and
    ``margin`` (:func:`margins`).
    """
    names = list(requirements)
    if cells.empty:
        cells = pd.DataFrame(columns=["cell", "subject", "value"])
    grouped = cells.dropna(subset=["value"]).groupby("cell", sort=False)["value"]
    stats = grouped.agg(n="count", mean="mean", sd="std").reindex(names)
    stats["n"] = stats["n"].fillna(0).astype(int)
    stats[["mean", "sd"]] = stats[["mean", "sd"]].astype(float)  # no subjects: NaN, not objects
    req = requirement_arrays(requirements.values())
    half = half_width(stats["sd"], stats["n"], len(names))
    low, high = stats["mean"].to_numpy() - half, stats["mean"].to_numpy() + half
    shown, beyond = cell_states(low, high, req)
    out = pd.DataFrame(
        {
            "cell": names,
            "n": stats["n"].to_numpy(),
            "mean": stats["mean"].to_numpy(),
            "sd": stats["sd"].to_numpy(),
            "low": low,
            "high": high,
            "requirement": [r.text() for r in requirements.values()],
            **req,
            "state": np.where(shown, "shown", np.where(beyond, "beyond", "undecided")),
            "margin": margins(stats["mean"], stats["sd"], req),
        }
    )
    return out


def judge(cells: pd.DataFrame, requirements: dict, combine: str = "all") -> Judgement:
    """The claim on its ``cells`` (:func:`estimates`); with no cell: not testable."""
    if not requirements:
        columns = ["cell", "n", "mean", "sd", "low", "high", "requirement", *REQUIREMENT_COLUMNS]
        return Judgement(UNTESTABLE, pd.DataFrame(columns=[*columns, "state", "margin"]), combine)
    table = estimates(cells, requirements)
    req = {k: table[k].to_numpy() for k in REQUIREMENT_COLUMNS}
    code = int(
        combined(
            table["state"].eq("shown").to_numpy(), table["state"].eq("beyond").to_numpy(), combine
        )
    )
    verdict = CODES[code]
    if verdict != INCONCLUSIVE:
        return Judgement(verdict, table, combine)
    mean = table["mean"].to_numpy()
    point = int(combined(*cell_states(mean, mean, req), combine))
    leaning = CODES[point] if point != 2 else ""
    n = n_to_decide(mean, table["sd"].to_numpy(), req, combine, leaning) if leaning else np.nan
    return Judgement(verdict, table, combine, leaning, n)


# --- how many subjects would decide -------------------------------------------------------------


def _one_sided(distance, n, m: int):
    """P(the simultaneous interval is wholly on one side of a bound) for cells whose mean lies
    ``distance`` SDs on that side, at ``n`` subjects (noncentral t; exact for normal values).
    """
    from scipy import stats

    df = n - 1.0
    t = stats.t.ppf(1.0 - ALPHA / (2 * m), df)
    noncentrality = np.clip(distance * np.sqrt(n), -60.0, 60.0)
    return np.where(
        np.isinf(distance), (distance > 0).astype(float), stats.nct.sf(t, df, noncentrality)
    )


def cell_probabilities(mean, sd, req: dict, n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(P(shown), P(beyond))`` of each cell at ``n`` subjects, its mean and SD taken as the
    truth (bounds of one cell treated as independent).
    """
    m = len(mean)
    with np.errstate(invalid="ignore", divide="ignore"):
        to = {
            "above": np.where(
                sd > 0, (mean - req["above"]) / sd, np.sign(mean - req["above"]) * np.inf
            ),
            "below": np.where(
                sd > 0, (req["below"] - mean) / sd, np.sign(req["below"] - mean) * np.inf
            ),
        }
    shown, not_beyond = np.ones(m), np.ones(m)
    for side in ("above", "below"):
        has = np.isfinite(req[side])
        distance = np.where(has, to[side], 0.0)
        shown *= np.where(has, _one_sided(distance, n, m), 1.0)
        not_beyond *= np.where(has, 1.0 - _one_sided(-distance, n, m), 1.0)
    return shown, 1.0 - not_beyond


def at_least(probabilities: np.ndarray, k: float) -> float:
    """P(at least ``k`` of independent events with these probabilities) (Poisson binomial)."""
    distribution = np.zeros(len(probabilities) + 1)
    distribution[0] = 1.0
    for p in probabilities:
        distribution[1:] = distribution[1:] * (1 - p) + distribution[:-1] * p
        distribution[0] *= 1 - p
    return float(distribution[int(np.ceil(k)) :].sum())


def decide_probability(mean, sd, req: dict, combine: str, verdict: str, n: int) -> float:
    """P(the claim returns ``verdict`` at ``n`` subjects), its cells' means and SDs the truth."""
    shown, beyond = cell_probabilities(mean, sd, req, n)
    m = len(mean)
    if verdict == HOLDS:
        return at_least(shown, m if combine == "all" else np.floor(m / 2) + 1)
    return at_least(beyond, 1 if combine == "all" else m / 2)


def n_to_decide(mean, sd, req: dict, combine: str, verdict: str) -> float:
    """The fewest subjects at which the claim returns ``verdict`` with :data:`POWER`, its cells'
    observed means and SDs taken as the truth; NaN when no cell has a spread or beyond
    :data:`MAX_N`.
    """
    mean, sd = np.asarray(mean, float), np.asarray(sd, float)
    if not np.isfinite(mean).all() or not np.isfinite(sd).all():
        return np.nan

    def enough(n: int) -> bool:
        return decide_probability(mean, sd, req, combine, verdict, n) >= POWER

    grid = np.unique(np.geomspace(2, MAX_N, 60).astype(int))
    passing = [n for n in grid if enough(int(n))]
    if not passing:
        return np.nan
    high = int(passing[0])
    low = int(grid[grid < high].max()) if (grid < high).any() else 1
    while high - low > 1:  # the smallest n between the last failing and the first passing
        middle = (low + high) // 2
        low, high = (low, middle) if enough(middle) else (middle, high)
    return float(high)
