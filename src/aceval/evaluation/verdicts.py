"""Verdicts from subject-level cells: intervals over a claim's cells, which way an undecided claim
leans, and how many subjects would decide it.

A claim is judged on *cells*: one value per subject and cell (a table cell's subject mean, a
subject's difference between two sensor sets, a subject's share of variance...), the subject being
the independent unit. Each cell has a :class:`Requirement` (the claim's side of one bound, or of
two: a range or an equivalence margin; a superiority bound may carry a smallest effect of
interest). Each cell has two t-intervals over its subjects:

* its own 95 % interval (``low_each``, ``high_each``): a claim over every cell ('all') *holds*
  when every cell's own interval is on the claim's side. That is an intersection-union test
  (Berger 1982): the claim is the intersection of its cells' claims and each is tested at 5 %
  (2.5 % a side), which keeps the claim's error at 5 % without an adjustment;
* the interval simultaneous over the claim's ``m`` cells (``low``, ``high``: Bonferroni, each at
  1 - 0.05 / m): a claim *does not hold* when one cell's simultaneous interval is wholly on the
  other side (the union of the cells' failures needs the adjustment); a "mostly" claim
  ('majority') reads both verdicts from these (more than half shown: holds; half or more beyond:
  does not hold), since "more than half" is a union over the subsets of cells.

A cell is **shown**, **beyond** or, where its requirement has a smallest effect of interest
``smallest_effect`` around its bound, **negligible** when its own interval lies within that
effect of the bound (Lakens et al. 2018's "trivial" effect: significant or not, too small to
matter; it takes precedence over shown and beyond). A claim over every cell whose cells are all
shown or negligible, one at least negligible, has **no relevant difference**.

An inconclusive claim *leans* the way its point estimates (intervals of zero width) would decide;
:func:`n_to_decide` is the number of subjects at which the claim would reach that verdict with
80 % probability if its cells' means and SDs were the truth (noncentral t, cells independent).
A claim none of whose cells has two subjects has no interval: not testable. Everything is
vectorised over resamples (:func:`verdict_codes`), so the operating characteristics
(:mod:`aceval.report.operating`) run the very same rule.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

HOLDS, FAILS, INCONCLUSIVE = "holds", "does not hold", "inconclusive"
NEGLIGIBLE = "no relevant difference"
UNTESTABLE = "not testable on this dataset"
VERDICTS = (HOLDS, FAILS, INCONCLUSIVE, NEGLIGIBLE, UNTESTABLE)
#: the verdicts as codes, in :func:`verdict_codes`' output
CODES = (HOLDS, FAILS, INCONCLUSIVE, NEGLIGIBLE)
#: the error rate of a claim's verdict (two-sided: each side 2.5 %, as a 95 % interval)
ALPHA = 0.05
#: the probability of deciding at which :func:`n_to_decide` stops
POWER = 0.8
#: the largest number of subjects :func:`n_to_decide` looks at
MAX_N = 100_000
#: the fewest subjects a cell's interval needs
MIN_SUBJECTS = 2
COMBINES = ("all", "majority")
#: a cell's states, in :func:`estimates`' ``state`` column
STATES = ("shown", "beyond", "negligible", "undecided")


@dataclass(frozen=True)
class Requirement:
    """What a cell must be for the claim: above ``above`` and/or below ``below`` (NaN: no such
    bound); ``*_inclusive``: the bound itself is on the claim's side ('>=', '<=').
    ``smallest_effect`` (a requirement of one bound only): the smallest difference from the bound
    that matters; a cell whose interval lies within it of the bound is negligible.
    """

    above: float = np.nan
    above_inclusive: bool = False
    below: float = np.nan
    below_inclusive: bool = False
    smallest_effect: float = np.nan

    @classmethod
    def of(cls, side: str, bound: float, smallest_effect: float = np.nan) -> Requirement:
        """'<', '<=', '>' or '>=' ``bound`` (with a smallest effect of interest around it)."""
        if side not in ("<", "<=", ">", ">="):
            raise ValueError(f"side {side!r} is not one of <, <=, >, >=")
        if side.startswith(">"):
            return cls(
                above=float(bound), above_inclusive=side == ">=", smallest_effect=smallest_effect
            )
        return cls(
            below=float(bound), below_inclusive=side == "<=", smallest_effect=smallest_effect
        )

    @classmethod
    def within(cls, target: float, margin: float) -> Requirement:
        """Equivalence: strictly within ``target`` +- ``margin`` (two one-sided tests)."""
        return cls(above=target - margin, below=target + margin)

    def text(self, digits: int = 4) -> str:
        """'< 2.5', '>= 0.14', '> -0.004 and < 0.004', '> 0; no relevant difference within +-1'."""
        parts = []
        if np.isfinite(self.above):
            parts.append(f"{'>=' if self.above_inclusive else '>'} {self.above:.{digits}g}")
        if np.isfinite(self.below):
            parts.append(f"{'<=' if self.below_inclusive else '<'} {self.below:.{digits}g}")
        text = " and ".join(parts)
        if np.isfinite(self.smallest_effect):
            text += f"; no relevant difference within +-{self.smallest_effect:.{digits}g}"
        return text


REQUIREMENT_COLUMNS = ["above", "above_inclusive", "below", "below_inclusive", "smallest_effect"]


def requirement_arrays(requirements) -> dict[str, np.ndarray]:
    """The cells' requirements as arrays (C,) by :data:`REQUIREMENT_COLUMNS`."""
    requirements = list(requirements)
    return {
        column: np.array(
            [getattr(r, column) for r in requirements],
            bool if column.endswith("inclusive") else float,
        )
        for column in REQUIREMENT_COLUMNS
    }


def level(m: int) -> float:
    """The confidence level of each cell's interval, simultaneous 95 % over ``m`` cells."""
    return 1.0 - ALPHA / max(int(m), 1)


def shown_level(m: int, combine: str = "all") -> float:
    """The level of the interval a cell is shown (or negligible) on: its own 95 % for a claim over
    every cell (an intersection-union test), the simultaneous one for "mostly".
    """
    return 1.0 - ALPHA if combine == "all" else level(m)


def half_width(sd, count, confidence: float) -> np.ndarray:
    """The t-interval's half width at two-sided ``confidence`` (NaN with fewer than 2 subjects)."""
    from scipy import stats

    sd, count = np.asarray(sd, float), np.asarray(count, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        df = np.where(count >= MIN_SUBJECTS, count - 1, np.nan)
        return stats.t.ppf(0.5 + confidence / 2, df) * sd / np.sqrt(count)


def _sides(low, high, req: dict) -> tuple[np.ndarray, np.ndarray]:
    """``(on the claim's side of every bound, wholly on the other side of one)`` of intervals."""
    above, below = req["above"], req["below"]
    has_above, has_below = np.isfinite(above), np.isfinite(below)
    with np.errstate(invalid="ignore"):
        above_shown = np.where(req["above_inclusive"], low >= above, low > above)
        above_beyond = np.where(req["above_inclusive"], high < above, high <= above)
        below_shown = np.where(req["below_inclusive"], high <= below, high < below)
        below_beyond = np.where(req["below_inclusive"], low > below, low >= below)
    side = np.where(has_above, above_shown, True) & np.where(has_below, below_shown, True)
    side &= np.isfinite(low) & np.isfinite(high)
    other = (has_above & above_beyond) | (has_below & below_beyond)
    return side, other


def _bound(req: dict) -> np.ndarray:
    """The single bound a smallest effect of interest is measured from."""
    return np.where(np.isfinite(req["above"]), req["above"], req["below"])


def cell_states(low, high, req: dict, low_each=None, high_each=None):
    """``(shown, beyond, negligible)`` of cells (arrays (..., C)): negligible when the cell's own
    interval (``low_each``, ``high_each``; default the simultaneous one) lies within its smallest
    effect of its bound; shown when that interval is on the claim's side of every bound, beyond
    when the simultaneous interval (``low``, ``high``) is wholly on the other side of one; a
    negligible cell is neither. No interval (NaN): none.
    """
    low_each = low if low_each is None else low_each
    high_each = high if high_each is None else high_each
    delta, bound = req["smallest_effect"], _bound(req)
    with np.errstate(invalid="ignore"):
        negligible = np.isfinite(delta) & (low_each > bound - delta) & (high_each < bound + delta)
    side, _ = _sides(low_each, high_each, req)
    _, other = _sides(low, high, req)
    return side & ~negligible, other & ~negligible, negligible


def combined(shown, beyond, negligible=None, combine: str = "all") -> np.ndarray:
    """The claim's verdict codes (index into :data:`CODES`) from its cells' states (..., C)."""
    negligible = np.zeros_like(shown) if negligible is None else negligible
    m = shown.shape[-1]
    if combine == "all":
        holds, fails = shown.all(axis=-1), beyond.any(axis=-1)
        trivial = (shown | negligible).all(axis=-1) & negligible.any(axis=-1)
    elif combine == "majority":
        holds, fails = shown.sum(axis=-1) > m / 2, beyond.sum(axis=-1) >= m / 2
        trivial = np.zeros_like(holds)
    else:
        raise ValueError(f"combine {combine!r} is not one of {', '.join(COMBINES)}")
    return np.where(holds, 0, np.where(fails, 1, np.where(trivial, 3, 2)))


def verdict_codes(mean, sd, count, req: dict, combine: str = "all") -> np.ndarray:
    """The verdict codes of claims whose cells (last axis) have these means, SDs and subject
    counts: the rule of this module, vectorised over any leading axes (resamples).
    """
    m = np.shape(mean)[-1]
    half = half_width(sd, count, level(m))
    each = half_width(sd, count, shown_level(m, combine))
    states = cell_states(mean - half, mean + half, req, mean - each, mean + each)
    return combined(*states, combine=combine)


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
    ``sd``, ``low``, ``high`` at :attr:`level`, ``low_each``, ``high_each`` at
    :attr:`shown_level`, the requirement and the cell's state), the deciding cell (the closest to
    failing, or for "mostly" the one at the majority), the way an inconclusive claim leans and
    the subjects that would decide it (NaN: beyond :data:`MAX_N`, or a cell without an SD).
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
        """Each cell's simultaneous confidence level (:func:`level`)."""
        return level(self.m)

    @property
    def shown_level(self) -> float:
        """The level a cell is shown on (:func:`shown_level`)."""
        return shown_level(self.m, self.combine)

    @property
    def deciding(self) -> pd.Series:
        """The estimates' row of the cell that decides the claim."""
        order = self.estimates.sort_values("margin", kind="stable")
        if self.combine == "majority":
            return order.iloc[len(order) - (len(order) // 2 + 1)]
        return order.iloc[0]


ESTIMATE_COLUMNS = [
    "cell",
    "n",
    "mean",
    "sd",
    "low",
    "high",
    "low_each",
    "high_each",
    "requirement",
    *REQUIREMENT_COLUMNS,
    "state",
    "margin",
]


def estimates(cells: pd.DataFrame, requirements: dict, combine: str = "all") -> pd.DataFrame:
    """Per cell of ``cells`` (``cell``, ``subject``, ``value``; one value per subject and cell),
    in the order of ``requirements`` (cell -> :class:`Requirement`): n, mean, SD, the interval
    simultaneous over the cells (``low``, ``high``) and the one a cell is shown on
    (``low_each``, ``high_each``), the requirement, ``state`` (:data:`STATES`) and ``margin``
    (:func:`margins`).
    """
    names = list(requirements)
    if cells.empty:
        cells = pd.DataFrame(columns=["cell", "subject", "value"])
    grouped = cells.dropna(subset=["value"]).groupby("cell", sort=False)["value"]
    stats = grouped.agg(n="count", mean="mean", sd="std").reindex(names)
    stats["n"] = stats["n"].fillna(0).astype(int)
    stats[["mean", "sd"]] = stats[["mean", "sd"]].astype(float)  # no subjects: NaN, not objects
    req = requirement_arrays(requirements.values())
    mean = stats["mean"].to_numpy()
    half = half_width(stats["sd"], stats["n"], level(len(names)))
    each = half_width(stats["sd"], stats["n"], shown_level(len(names), combine))
    shown, beyond, negligible = cell_states(mean - half, mean + half, req, mean - each, mean + each)
    state = np.select([shown, beyond, negligible], list(STATES[:3]), STATES[3])
    return pd.DataFrame(
        {
            "cell": names,
            "n": stats["n"].to_numpy(),
            "mean": mean,
            "sd": stats["sd"].to_numpy(),
            "low": mean - half,
            "high": mean + half,
            "low_each": mean - each,
            "high_each": mean + each,
            "requirement": [r.text() for r in requirements.values()],
            **req,
            "state": state,
            "margin": margins(stats["mean"], stats["sd"], req),
        },
        columns=ESTIMATE_COLUMNS,
    )


def arrays_of(table: pd.DataFrame) -> dict:
    """The requirements of an estimates table as :func:`requirement_arrays` gives them."""
    return {
        c: table[c].to_numpy(bool if c.endswith("inclusive") else float)
        for c in REQUIREMENT_COLUMNS
    }


def judge(cells: pd.DataFrame, requirements: dict, combine: str = "all") -> Judgement:
    """The claim on its ``cells`` (:func:`estimates`); with no cell, or no cell with
    :data:`MIN_SUBJECTS` subjects (no interval): not testable.
    """
    if not requirements:
        return Judgement(UNTESTABLE, pd.DataFrame(columns=ESTIMATE_COLUMNS), combine)
    table = estimates(cells, requirements, combine)
    if not (table["n"] >= MIN_SUBJECTS).any():
        return Judgement(UNTESTABLE, table, combine)
    states = [table["state"].eq(s).to_numpy() for s in STATES[:3]]
    verdict = CODES[int(combined(*states, combine=combine))]
    if verdict != INCONCLUSIVE:
        return Judgement(verdict, table, combine)
    mean, req = table["mean"].to_numpy(), arrays_of(table)
    leaning = point_leaning(mean, req, combine)
    n = n_to_decide(mean, table["sd"].to_numpy(), req, combine, leaning) if leaning else np.nan
    return Judgement(verdict, table, combine, leaning, n)


def point_leaning(mean, req: dict, combine: str) -> str:
    """The verdict the point estimates would give (intervals of zero width); '' for none."""
    code = int(combined(*cell_states(mean, mean, req), combine=combine))
    return CODES[code] if code != 2 else ""


# --- how many subjects would decide -------------------------------------------------------------


def _one_sided(distance, n, confidence: float):
    """P(the interval at two-sided ``confidence`` is wholly on one side of a point) for cells
    whose mean lies ``distance`` SDs on that side, at ``n`` subjects (noncentral t; exact for
    normal values).
    """
    from scipy import stats

    df = n - 1.0
    t = stats.t.ppf(0.5 + confidence / 2, df)
    with np.errstate(over="ignore", invalid="ignore"):
        noncentrality = np.clip(distance * np.sqrt(n), -60.0, 60.0)
    return np.where(
        np.isinf(distance), (distance > 0).astype(float), stats.nct.sf(t, df, noncentrality)
    )


def cell_probabilities(mean, sd, req: dict, n: int, combine: str = "all"):
    """``(P(shown), P(beyond), P(negligible))`` of each cell at ``n`` subjects, its mean and SD
    taken as the truth (the bounds of one cell treated as independent).
    """
    mean, sd = np.asarray(mean, float), np.asarray(sd, float)
    m = len(mean)
    each, simultaneous = shown_level(m, combine), level(m)

    def over(x, confidence):  # P(low > x)
        with np.errstate(invalid="ignore", divide="ignore"):
            z = np.where(sd > 0, (mean - x) / sd, np.sign(mean - x) * np.inf)
        return np.where(np.isfinite(x), _one_sided(np.nan_to_num(z, nan=0.0), n, confidence), 1.0)

    def under(x, confidence):  # P(high < x)
        with np.errstate(invalid="ignore", divide="ignore"):
            z = np.where(sd > 0, (x - mean) / sd, np.sign(x - mean) * np.inf)
        return np.where(np.isfinite(x), _one_sided(np.nan_to_num(z, nan=0.0), n, confidence), 1.0)

    above, below = req["above"], req["below"]
    has_above, has_below = np.isfinite(above), np.isfinite(below)
    side = over(above, each) * under(below, each)
    not_other = np.where(has_above, 1 - under(above, simultaneous), 1.0) * np.where(
        has_below, 1 - over(below, simultaneous), 1.0
    )
    delta, bound = req["smallest_effect"], _bound(req)
    sesoi = np.isfinite(delta)
    band_low = np.where(sesoi, over(bound - delta, each), 0.0)  # low above the band's floor
    band_high = np.where(sesoi, under(bound + delta, each), 0.0)  # high below its ceiling
    negligible = band_low * band_high
    # shown and not negligible: on the claim's side, past the band's far edge
    shown = side * np.where(has_above, 1 - band_high, 1 - band_low)
    beyond = (1 - not_other) * np.where(has_above, 1 - band_low, 1 - band_high)
    return shown, beyond, negligible


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
    shown, beyond, negligible = cell_probabilities(mean, sd, req, n, combine)
    m = len(mean)
    if verdict == HOLDS:
        return at_least(shown, m if combine == "all" else np.floor(m / 2) + 1)
    if verdict == NEGLIGIBLE:
        return float(np.prod(shown + negligible) - np.prod(shown)) if combine == "all" else 0.0
    return at_least(beyond, 1 if combine == "all" else m / 2)


def n_to_decide(mean, sd, req: dict, combine: str, verdict: str) -> float:
    """The fewest subjects at which the claim returns ``verdict`` with :data:`POWER`, its cells'
    observed means and SDs taken as the truth; NaN when a cell has no SD or beyond
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
