"""Issues 42, 51: every committed verdict is recomputed from committed files, without the code
that made it: each cell's two intervals from the per-subject cells (scipy's t-intervals: its own
at 95 % for an all-cells claim's 'holds', at the level simultaneous over the claim's cells for
'does not hold' and for "mostly"), each cell's state from its requirement and smallest effect of
interest, each claim's verdict from its cells, and SUMMARY.md's counts and verdicts from the
claims. The claims without subjects are recomputed from the committed tables they read. Quick:
it reads the committed results, it does not regenerate them (the slow tests do)."""

import re

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from .runner import REPO

RESULTS = REPO / "results"
FOLDERS = sorted(p.parent.parent for p in RESULTS.glob("*/tables/claims.csv"))


def _read(folder, name):
    return pd.read_csv(folder / "tables" / f"{name}.csv", keep_default_na=False, na_values=[""])


def _sides(low, high, r) -> tuple[bool, bool]:
    """(on the claim's side of every bound, wholly on the other side of one) of one interval."""
    if not (np.isfinite(low) and np.isfinite(high)):
        return False, False
    side, other = True, False
    if np.isfinite(r["above"]):
        side &= low >= r["above"] if r["above_inclusive"] else low > r["above"]
        other |= high < r["above"] if r["above_inclusive"] else high <= r["above"]
    if np.isfinite(r["below"]):
        side &= high <= r["below"] if r["below_inclusive"] else high < r["below"]
        other |= low > r["below"] if r["below_inclusive"] else low >= r["below"]
    return side, other


def _state(simultaneous, own, r) -> str:
    """'shown', 'beyond', 'negligible' or 'undecided' of one cell: negligible when its own
    interval lies within its smallest effect of its bound, shown when its own interval is on the
    claim's side, beyond when the simultaneous one is wholly on the other side."""
    delta = r["smallest_effect"]
    if np.isfinite(delta) and np.isfinite(own[0]) and np.isfinite(own[1]):
        bound = r["above"] if np.isfinite(r["above"]) else r["below"]
        if bound - delta < own[0] and own[1] < bound + delta:
            return "negligible"
    if _sides(*own, r)[0]:
        return "shown"
    return "beyond" if _sides(*simultaneous, r)[1] else "undecided"


def _verdict(states: list[str], combine: str) -> str:
    m, shown, beyond = len(states), states.count("shown"), states.count("beyond")
    if combine == "majority":
        return "holds" if shown > m / 2 else "does not hold" if beyond >= m / 2 else "inconclusive"
    if shown == m:
        return "holds"
    if beyond:
        return "does not hold"
    negligible = states.count("negligible")
    return "no relevant difference" if negligible and shown + negligible == m else "inconclusive"


def test_the_committed_claims_are_there():
    names = {p.name for p in FOLDERS}
    assert {"kong_sim", "kong_powered", "ricci_sim", "box_sim"} <= names


#: the powered design's cells (93 subjects) in the slow tier
BY_SIZE = [
    pytest.param(f, marks=pytest.mark.slow) if f.name == "kong_powered" else f for f in FOLDERS
]


@pytest.mark.parametrize("folder", BY_SIZE, ids=lambda p: p.name)
def test_every_verdict_is_recomputed_from_its_committed_cells(folder):
    claims, estimates, cells = (
        _read(folder, n) for n in ("claims", "claim_estimates", "claim_cells")
    )
    for _, claim in claims[claims["cells"] > 0].iterrows():
        own = estimates[estimates["claim"] == claim["claim"]].set_index("cell")
        values = cells[cells["claim"] == claim["claim"]]
        m, combine = len(own), claim["combine"]
        shown_level = 0.95 if combine == "all" else 1 - 0.05 / m
        assert m == claim["cells"] and claim["level"] == pytest.approx(1 - 0.05 / m)
        assert claim["shown_level"] == pytest.approx(shown_level)
        states, sizes = [], []
        for cell, r in own.iterrows():
            x = values.loc[values["cell"] == cell, "value"].dropna().to_numpy(float)
            assert len(x) == r["n"], (claim["claim"], cell)
            sizes.append(len(x))
            intervals = []
            for level in (1 - 0.05 / m, shown_level):
                low, high = (np.nan, np.nan)
                if len(x) > 1:
                    low, high = stats.t.interval(level, len(x) - 1, x.mean(), stats.sem(x))
                    if x.std() == 0:
                        low = high = x.mean()
                intervals.append((low, high))
            committed = (r["mean"], r["low"], r["high"], r["low_each"], r["high_each"])
            assert committed == pytest.approx(
                (x.mean(), *intervals[0], *intervals[1]), rel=1e-6, abs=1e-9, nan_ok=True
            ), (claim["claim"], cell)
            states.append(_state(*intervals, r))
            assert states[-1] == r["state"], (claim["claim"], cell)
        expected = _verdict(states, combine) if max(sizes) >= 2 else "not testable on this dataset"
        assert expected == claim["verdict"], claim["claim"]
        deciding = own.loc[claim["deciding_cell"]]
        assert (claim["mean"], claim["low"], claim["high"]) == pytest.approx(
            (deciding["mean"], deciding["low"], deciding["high"]), rel=1e-6, nan_ok=True
        )
        if claim["verdict"] == "inconclusive" and claim["leaning"]:
            assert claim["n_to_decide"] > 0 or np.isnan(claim["n_to_decide"])


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda p: p.name)
def test_summary_says_what_the_claims_table_says(folder):
    """The counts and, in order, each claim's verdict of SUMMARY.md's tables are claims.csv's."""
    claims = _read(folder, "claims")
    text = (folder / "SUMMARY.md").read_text()
    paper = claims[claims["section"] == "paper"]["verdict"].tolist()
    counts = re.search(
        r"(\d+) hold, (\d+) do not hold, (\d+) no relevant difference, (\d+) inconclusive, "
        r"(\d+) not testable",
        text,
    )
    assert counts, "SUMMARY.md has no counts"
    kinds = ("holds", "does not hold", "no relevant difference", "inconclusive")
    expected = [paper.count(v) for v in kinds]
    expected.append(paper.count("not testable on this dataset"))
    assert [int(c) for c in counts.groups()] == expected
    rows = [line.split("|")[3].strip() for line in text.splitlines()
            if re.match(r"^\| [^:-]", line) and line.count("|") == 6]  # fmt: skip
    verdicts = [r for r in rows if r.split(" (")[0] in set(claims["verdict"])]
    # SUMMARY.md's sections: the papers' claims (the untestable last), the truth, the code
    order = {"paper": 0, "ground truth": 2, "code": 3}
    rank = claims["section"].map(order) + (
        (claims["section"] == "paper") & (claims["verdict"] == "not testable on this dataset")
    )
    shown = claims.assign(rank=rank).sort_values("rank", kind="stable")
    assert [v.split(" (")[0] for v in verdicts] == shown["verdict"].tolist()


def test_the_claims_without_subjects_are_recomputed_from_the_committed_tables():
    """The rigid box (Tables 4-5) and Ricci's random starts (table ricci_lm): judged on values."""
    from aceval.report import kong_claims, ricci_claims

    box = RESULTS / "box_sim" / "tables"
    tables = {n: pd.read_csv(box / f"table{n}.csv") for n in (4, 5)}
    verdict, _ = kong_claims._box(kong_claims.Evidence(tables, None, None, None))
    committed = _read(RESULTS / "box_sim", "claims").set_index("claim")
    assert committed.loc["obj1_box", "verdict"] == verdict
    lm = pd.read_csv(RESULTS / "ricci_sim" / "tables" / "ricci_lm.csv")
    verdict, _ = ricci_claims._random_starts(ricci_claims.Evidence({"ricci_lm": lm}, None))
    committed = _read(RESULTS / "ricci_sim", "claims").set_index("claim")
    assert committed.loc["ricci_random_starts", "verdict"] == verdict


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda p: p.name)
def test_every_summary_table_row_has_its_headers_cells(folder):
    """A '|' inside a claim's numbers (a '|t|') split its row and shifted every verdict after it;
    each row of SUMMARY.md's tables has as many cells as its table's header."""
    width = None
    for line in (folder / "SUMMARY.md").read_text().splitlines():
        if not line.startswith("|"):
            width = None
            continue
        if width is None:
            width = line.count("|")
        assert line.count("|") == width, line[:120]
