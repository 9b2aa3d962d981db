"""Issue 27: every number that docs/ quotes from the committed results is checked against them.

A quoted number carries its source right after it, as an HTML comment (invisible when the
markdown is rendered)::

    on the subjects p = 0.0144<!--r kong_sim/tables/table8.csv segment=shank test=units: p -->

``path`` is relative to ``results/``; ``key=value`` pairs choose one row (a space in a value is
written ``_``); the column after the colon is the value. The quoted number (unsigned: a dash
before it is a range) must equal the committed value at the precision it is written with (a
number followed by ``%`` is a share written as a percentage).
"""

import functools
import re

import pandas as pd
import pytest

from .runner import REPO

MARKER = re.compile(
    r"(?P<number>\d+(?:\.\d+)?)(?P<percent> ?%)?\)?<!--r (?P<path>\S+)(?P<keys>(?: [^:=\s]+=\S+)*): "
    r"(?P<column>\w+) -->"
)


def _quotes():
    for doc in sorted((REPO / "docs").glob("*.md")):
        for match in MARKER.finditer(doc.read_text()):
            yield pytest.param(
                match, id=f"{doc.name}:{match['path']}{match['keys']}:{match['column']}"
            )


def _same(cell: str, wanted: str) -> bool:
    """A marker's value: a number, or the cell's text with its spaces written as '_'."""
    try:
        return float(cell) == float(wanted)
    except ValueError:
        return cell.replace(" ", "_") == wanted


@functools.cache
def _committed(path: str) -> pd.DataFrame:
    """A committed table as text, read once for all the quotes from it (not to be changed)."""
    return pd.read_csv(REPO / "results" / path, dtype=str, keep_default_na=False)


@pytest.mark.parametrize("match", list(_quotes()))
def test_a_quoted_number_is_the_committed_one(match):
    table = _committed(match["path"])
    chosen = pd.Series(True, index=table.index)
    for pair in match["keys"].split():
        key, value = pair.split("=", 1)
        chosen &= table[key].map(lambda cell, v=value: _same(cell, v))
    rows = table[chosen]
    assert len(rows) == 1, f"{match.group(0)} selects {len(rows)} rows"
    committed = float(rows.iloc[0][match["column"]]) * (100 if match["percent"] else 1)
    quoted = match["number"]
    decimals = len(quoted.split(".")[1]) if "." in quoted else 0
    assert abs(committed - float(quoted)) <= 0.5 * 10**-decimals + 1e-9, (
        f"docs quote {quoted}, results/{match['path']} has {committed}"
    )


def test_the_docs_quote_the_committed_results():
    """The markers are there (a docs rewrite that drops them would silently stop the check)."""
    assert len(list(_quotes())) >= 20


def refresh() -> int:
    """``python -m tests.test_docs_numbers``: rewrite every quoted number from its committed
    source at the precision it is written with (then read the prose around each change)."""
    changed = 0
    for doc in sorted((REPO / "docs").glob("*.md")):
        text = doc.read_text()

        def current(match) -> str:
            nonlocal changed
            table = pd.read_csv(REPO / "results" / match["path"], dtype=str, keep_default_na=False)
            chosen = pd.Series(True, index=table.index)
            for pair in match["keys"].split():
                key, value = pair.split("=", 1)
                chosen &= table[key].map(lambda cell, v=value: _same(cell, v))
            value = float(table[chosen].iloc[0][match["column"]]) * (100 if match["percent"] else 1)
            quoted = match["number"]
            decimals = len(quoted.split(".")[1]) if "." in quoted else 0
            new = f"{value:.{decimals}f}"
            changed += new != quoted
            return new + match.group(0)[len(quoted) :]

        doc.write_text(MARKER.sub(current, text))
    print(f"{changed} quoted number(s) refreshed")
    return 0


if __name__ == "__main__":
    raise SystemExit(refresh())
