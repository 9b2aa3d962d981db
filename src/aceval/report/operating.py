"""How often each claim's rule says what (issue 42): its operating characteristics, and the power
analysis that fixed the powered design's number of subjects.

Both read only committed files: every dataset's ``tables/claim_cells.csv`` (one value per subject
and cell of every claim), ``claim_estimates.csv`` (each cell's requirement) and ``claims.csv``.

* **Power analysis** (:func:`power_table`, on the paper's design, kong_sim's 5 subjects): per
  claim, the number of subjects at which it would reach the verdict its estimates lean to with 80 %
  probability, its cells' means and SDs taken as the truth
  (:func:`aceval.evaluation.verdicts.n_to_decide`). The powered design's n (:func:`powered_n`) is
  the largest of those that is at most :data:`AFFORDABLE_N`: every claim decidable at an
  affordable n gets its 80 %; the others are listed with the n they would need.
* **Operating characteristics** (:func:`operating_table`): the subjects of the powered design
  (Ricci's: its 40 children) are the population. Each claim's cells are shifted so that the cell
  that decides it lies :data:`SHIFT_SD` of its subjects' SD on the claim's side of its bound (the
  claim true), on the bound, or as far on the other side (false), every other cell moved by the
  same number of its own SDs; then :data:`DRAWS` samples of n subjects are drawn with replacement
  (the subject brings all its cells) and judged by the very rule of SUMMARY.md
  (:func:`aceval.evaluation.verdicts.verdict_codes`), at the paper's n and the powered n. Beside
  it, how often the cells' own 95 % intervals and the simultaneous ones cover the population's
  means. Resampling the committed cells costs seconds; a workflow run per sample would cost
  minutes each.

``python -m aceval.report.operating RESULTS`` writes both into RESULTS/operating_characteristics/.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.evaluation.verdicts import (
    CODES,
    FAILS,
    HOLDS,
    POWER,
    REQUIREMENT_COLUMNS,
    cell_states,
    combined,
    half_width,
    margins,
    n_to_decide,
    verdict_codes,
)

#: the paper's design (Kong's 5 subjects), the powered one, and Ricci's (the paper's 40 children)
PAPER_DESIGN, POWERED_DESIGN, RICCI_DESIGN = "kong_sim", "kong_powered", "ricci_sim"
#: the most subjects a simulated design may cost here (issue 43: 60-100 subjects, about two
#: minutes of workflow each run on 2 cores)
AFFORDABLE_N = 100
#: samples of subjects per claim, design and scenario (Monte Carlo SE of a share at most 1.1 %)
DRAWS = 2000
#: how far the claim is true or false in the scenarios: half of the deciding cell's SD over the
#: subjects (Cohen's medium standardised effect)
SHIFT_SD = 0.5
SCENARIOS = {
    f"true by {SHIFT_SD:g} SD": SHIFT_SD,
    "on the bound": 0.0,
    f"false by {SHIFT_SD:g} SD": -SHIFT_SD,
    "as simulated": None,
}
#: a verdict a rule returns less often than this where it should is "almost never" returned
RARELY = 0.05
SEED = 42


def claim_specs(folder: Path) -> dict:
    """Per claim judged on cells: ``(wide, req, combine)``: the subjects x cells table of its
    values (cells in the claim's order), the cells' requirements as arrays and how they combine.
    """
    tables = folder / "tables"
    claims = pd.read_csv(tables / "claims.csv", keep_default_na=False, na_values=[""])
    estimates = pd.read_csv(tables / "claim_estimates.csv")
    cells = pd.read_csv(tables / "claim_cells.csv")
    specs = {}
    for _, claim in claims[claims["cells"] > 0].iterrows():
        own = estimates[estimates["claim"] == claim["claim"]]
        values = cells[cells["claim"] == claim["claim"]]
        wide = values.pivot_table(index="subject", columns="cell", values="value", sort=False)
        wide = wide.reindex(columns=list(own["cell"]))
        req = {
            c: own[c].to_numpy(bool if c.endswith("inclusive") else float)
            for c in REQUIREMENT_COLUMNS
        }
        specs[claim["claim"]] = (wide, req, claim["combine"], claim)
    return specs


def _leaning(mean: np.ndarray, req: dict, combine: str) -> str:
    """The verdict the point estimates would give (intervals of zero width)."""
    code = int(combined(*cell_states(mean, mean, req), combine))
    return CODES[code] if code != 2 else ""


def power_table(folder: Path) -> pd.DataFrame:
    """Per claim of the paper's design: its verdict, the way its estimates lean, the subjects
    that would decide it that way with :data:`POWER` and whether that is affordable.
    """
    rows = []
    for key, (wide, req, combine, claim) in claim_specs(folder).items():
        mean, sd = wide.mean().to_numpy(), wide.std().to_numpy()
        leaning = _leaning(mean, req, combine)
        n = n_to_decide(mean, sd, req, combine, leaning) if leaning else np.nan
        rows.append(
            {
                "claim": key,
                "objective": claim["objective"],
                "n": len(wide),
                "verdict": claim["verdict"],
                "estimates_lean": leaning,
                "n_to_decide": n,
                "affordable": bool(np.isfinite(n) and n <= AFFORDABLE_N),
            }
        )
    return pd.DataFrame(rows)


def powered_n(power: pd.DataFrame) -> int:
    """The subjects a powered design needs: the most any affordable claim needs
    (:func:`power_table`).
    """
    return int(power.loc[power["affordable"], "n_to_decide"].max())


#: the powered design's subjects (config/powered.yaml), fixed in advance by :func:`powered_n` on
#: the paper's design as committed on 2026-11-27 (issue 42): 93. Not recomputed with every later
#: run of the paper's design: a design is fixed before its data are seen, and the table beside it
#: (power.csv) says what the analysis gives on the cells committed now.
POWERED_N = 93


# --- operating characteristics ------------------------------------------------------------------


def shifted(wide: pd.DataFrame, req: dict, combine: str, target: float | None) -> pd.DataFrame:
    """The population with every cell moved so that the deciding cell lies ``target`` of its SDs
    on the claim's side of its nearest bound (negative: beyond it), each other cell by the same
    number of its own SDs (a range's cell no farther in than its middle); None: as it is.
    """
    if target is None:
        return wide
    mean, sd = wide.mean().to_numpy(), wide.std().to_numpy()
    z = margins(mean, sd, req)
    finite = np.isfinite(z)
    if not finite.any():
        return wide
    order = np.argsort(np.where(finite, z, np.inf), kind="stable")
    deciding = order[0] if combine == "all" else order[finite.sum() - (finite.sum() // 2 + 1)]
    wanted = z + (target - z[deciding])
    above, below = req["above"], req["below"]
    lower_nearer = np.isfinite(above) & ~(np.isfinite(below) & (below - mean < mean - above))
    middle = np.where(np.isfinite(above) & np.isfinite(below), (below - above) / (2 * sd), np.inf)
    wanted = np.minimum(wanted, middle)
    new_mean = np.where(lower_nearer, above + wanted * sd, below - wanted * sd)
    return wide + np.where(finite, new_mean - mean, 0.0)


def sampled(wide: pd.DataFrame, req: dict, combine: str, n: int, rng) -> dict:
    """The rule on :data:`DRAWS` samples of ``n`` subjects drawn with replacement from ``wide``:
    the share of each verdict, and how often the cells' 95 % intervals (median and smallest
    over the cells) and their simultaneous intervals (all at once) cover the population means.
    """
    values = wide.to_numpy(float)
    truth = np.nanmean(values, axis=0)
    m = values.shape[1]
    codes, covered, all_covered = [], [], []
    for start in range(0, DRAWS, 250):
        draws = values[rng.integers(0, len(values), size=(min(250, DRAWS - start), n))]
        count = np.isfinite(draws).sum(axis=1)
        with np.errstate(invalid="ignore", divide="ignore"), _quiet():
            mean = np.nanmean(draws, axis=1)
            sd = np.nanstd(draws, axis=1, ddof=1)
        codes.append(verdict_codes(mean, sd, count, req, combine))
        one = half_width(sd, count, 1)
        covered.append(np.abs(mean - truth) <= one)
        all_covered.append((np.abs(mean - truth) <= half_width(sd, count, m)).all(axis=1))
    codes, covered = np.concatenate(codes), np.concatenate(covered)
    per_cell = covered.mean(axis=0)
    return {
        **{
            f"p_{name}": float(np.mean(codes == k))
            for name, k in (("holds", 0), ("fails", 1), ("inconclusive", 2))
        },
        "coverage_median": float(np.median(per_cell)),
        "coverage_min": float(per_cell.min()),
        "simultaneous_coverage": float(np.concatenate(all_covered).mean()),
    }


class _quiet:
    """No 'mean of empty slice' warnings for a cell a sample has no value in."""

    def __enter__(self):
        import warnings

        self._catch = warnings.catch_warnings()
        self._catch.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc):
        return self._catch.__exit__(*exc)


def operating_table(results: Path) -> pd.DataFrame:
    """Every claim's rule at the paper's n and the powered n (Ricci: its 40 children), in each
    scenario (:data:`SCENARIOS`), with a note where it almost never returns a verdict it should.
    """
    designs = [
        (POWERED_DESIGN, [("the paper's design", 5), ("the powered design", POWERED_N)]),
        (RICCI_DESIGN, [("the paper's design", 40)]),
    ]
    rows = []
    rng = np.random.default_rng(SEED)
    for dataset, sizes in designs:
        for key, (wide, req, combine, claim) in claim_specs(results / dataset).items():
            for design, n in sizes:
                for scenario, target in SCENARIOS.items():
                    population = shifted(wide, req, combine, target)
                    rows.append(
                        {
                            "claim": key,
                            "objective": claim["objective"],
                            "population": f"{dataset} ({len(wide)} subjects)",
                            "design": design,
                            "n": n,
                            "scenario": scenario,
                            **sampled(population, req, combine, n, rng),
                        }
                    )
    return _with_notes(pd.DataFrame(rows))


def _with_notes(table: pd.DataFrame) -> pd.DataFrame:
    """A note beside each claim and design whose rule almost never (:data:`RARELY`) says 'holds'
    when the claim is true, or 'does not hold' when it is false.
    """
    notes = []
    for _, row in table.iterrows():
        note = ""
        if row["scenario"].startswith("true") and row["p_holds"] < RARELY:
            note = f"almost never says '{HOLDS}' when the claim is true"
        if row["scenario"].startswith("false") and row["p_fails"] < RARELY:
            note = f"almost never says '{FAILS}' when the claim is false"
        notes.append(note)
    return table.assign(note=notes)


def verdicts_by_design(results: Path) -> pd.DataFrame:
    """Every Kong claim's committed verdict at the paper's n and at the powered n, side by side
    (an inconclusive one with the way it leans and the subjects that would decide it).
    """

    def shown(dataset: str) -> pd.Series:
        claims = pd.read_csv(results / dataset / "tables" / "claims.csv", keep_default_na=False)
        text = [
            v if v != "inconclusive" or not lean else f"{v} (leans '{lean}', n {n or '> 100000'})"
            for v, lean, n in zip(claims["verdict"], claims["leaning"], claims["n_to_decide"])
        ]
        return pd.Series(text, index=claims["claim"])

    paper, powered = shown(PAPER_DESIGN), shown(POWERED_DESIGN)
    return pd.DataFrame(
        {
            "claim": paper.index,
            f"{PAPER_DESIGN} (5 subjects)": paper.values,
            f"{POWERED_DESIGN} ({POWERED_N} subjects)": powered.reindex(paper.index).values,
        }
    )


def _markdown(power: pd.DataFrame, table: pd.DataFrame, n: int, verdicts: pd.DataFrame) -> str:
    shown = table.copy()
    for column in (
        "p_holds",
        "p_fails",
        "p_inconclusive",
        "coverage_median",
        "coverage_min",
        "simultaneous_coverage",
    ):
        shown[column] = shown[column].map(lambda v: f"{100 * v:.0f} %")
    return "\n".join(
        [
            "# Operating characteristics of the claims' rules (SIMULATED)",
            "",
            "Made by `python -m aceval.report.operating results` from the committed "
            "`results/*/tables/claim_*.csv` (aceval.report.operating explains how).",
            "",
            "## Power analysis on the paper's design (kong_sim, 5 subjects)",
            "",
            f"Subjects at which each claim reaches the verdict its estimates lean to with "
            f"{POWER:.0%} probability, its cells' means and SDs taken as the truth. The powered "
            f"design's n is the largest of those at most {AFFORDABLE_N}: fixed in advance at "
            f"**{POWERED_N}** (config/powered.yaml); on the cells committed now the analysis "
            f"gives {n}.",
            "",
            power.to_markdown(index=False),
            "",
            "## The committed verdicts at both n",
            "",
            verdicts.to_markdown(index=False),
            "",
            "## How often each rule says what",
            "",
            f"Population: the subjects of the committed powered design (Ricci: its children), each "
            f"claim's cells shifted so that the deciding cell lies {SHIFT_SD:g} SD on the claim's side "
            f"of its bound (true), on it, or {SHIFT_SD:g} SD beyond it (false), or as simulated; "
            f"{DRAWS} samples of n subjects with replacement per row. coverage: the cells' 95 % "
            "intervals (median and smallest over the cells) and the simultaneous ones (every cell "
            "at once) around the population means.",
            "",
            shown.to_markdown(index=False),
            "",
        ]
    )


def main(argv: list[str] | None = None) -> int:
    """``python -m aceval.report.operating RESULTS``: the power analysis and the operating
    characteristics into RESULTS/operating_characteristics/; ``--power``: print the power
    analysis only (what fixes the powered design's n, before that design exists).
    """
    import argparse

    parser = argparse.ArgumentParser(prog="python -m aceval.report.operating")
    parser.add_argument("results", type=Path)
    parser.add_argument("--power", action="store_true", help="the power analysis only")
    args = parser.parse_args(argv)
    results = args.results
    power = power_table(results / PAPER_DESIGN)
    if args.power:
        print(power.to_string(index=False))
        print(f"powered design: {powered_n(power)} subjects")
        return 0
    table = operating_table(results)
    out = results / "operating_characteristics"
    out.mkdir(parents=True, exist_ok=True)
    power.to_csv(out / "power.csv", index=False, float_format="%.4f")
    table.to_csv(out / "operating_characteristics.csv", index=False, float_format="%.4f")
    verdicts = verdicts_by_design(results)
    verdicts.to_csv(out / "verdicts_by_design.csv", index=False)
    markdown = _markdown(power, table, powered_n(power), verdicts)
    (out / "operating_characteristics.md").write_text(markdown)
    print(f"powered design: {powered_n(power)} subjects", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
