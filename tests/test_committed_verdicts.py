"""Issue 42: every committed verdict is recomputed from committed files, without the code that
made it: each cell's interval from the per-subject cells (scipy's t-interval at the level
simultaneous over the claim's cells), each cell's state from its requirement, each claim's
verdict from its cells, and SUMMARY.md's counts and verdicts from the claims. The claims without
subjects are recomputed from the committed tables they read. Quick: it reads the committed
results, it does not regenerate them (the slow tests do)."""

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


def _state(low, high, r) -> str:
    """'shown', 'beyond' or 'undecided' of one interval against one cell's requirement."""
    if not (np.isfinite(low) and np.isfinite(high)):
        return "undecided"
    shown, beyond = True, False
    if np.isfinite(r["above"]):
        shown &= low >= r["above"] if r["above_inclusive"] else low > r["above"]
        beyond |= high < r["above"] if r["above_inclusive"] else high <= r["above"]
    if np.isfinite(r["below"]):
        shown &= high <= r["below"] if r["below_inclusive"] else high < r["below"]
        beyond |= low > r["below"] if r["below_inclusive"] else low >= r["below"]
    return "shown" if shown else "beyond" if beyond else "undecided"


def _verdict(states: list[str], combine: str) -> str:
    m, shown, beyond = len(states), states.count("shown"), states.count("beyond")
    if combine == "majority":
        return "holds" if shown > m / 2 else "does not hold" if beyond >= m / 2 else "inconclusive"
    return "holds" if shown == m else "does not hold" if beyond else "inconclusive"


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
        m = len(own)
        assert m == claim["cells"] and claim["level"] == pytest.approx(1 - 0.05 / m)
        states = []
        for cell, r in own.iterrows():
            x = values.loc[values["cell"] == cell, "value"].dropna().to_numpy(float)
            assert len(x) == r["n"], (claim["claim"], cell)
            low, high = (np.nan, np.nan)
            if len(x) > 1:
                low, high = stats.t.interval(1 - 0.05 / m, len(x) - 1, x.mean(), stats.sem(x))
                if x.std() == 0:
                    low = high = x.mean()
            assert (r["mean"], r["low"], r["high"]) == pytest.approx(
                (x.mean(), low, high), rel=1e-6, abs=1e-9, nan_ok=True
            ), (claim["claim"], cell)
            states.append(_state(low, high, r))
            assert states[-1] == r["state"], (claim["claim"], cell)
        assert _verdict(states, claim["combine"]) == claim["verdict"], claim["claim"]
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
        r"(\d+) hold, (\d+) do not hold, (\d+) inconclusive, (\d+) not testable", text
    )
    assert counts, "SUMMARY.md has no counts"
    expected = [paper.count(v) for v in ("holds", "does not hold", "inconclusive")]
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
