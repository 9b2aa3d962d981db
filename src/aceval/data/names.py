"""Names that survive a CSV round trip: every results table of aceval is written as CSV and read
back by a reader that guesses types (pandas.read_csv). A name it takes for a missing value
('NA', 'null', ...) would drop its rows out of every table (:func:`check_names`); labels it
reads as one number ('1', '01', '001') would merge subjects, so subject labels are compared by
that one rule (:func:`subject_key`) everywhere aceval meets them. A subject label names files
(the workflow's per-subject jobs), so it holds no path (:func:`check_subject_labels`); segment
and side are compared exactly by the checks that know them by name (the shank's swing in
walking, the legs' sides), so another spelling of a known one is refused (:func:`check_places`).
"""

from __future__ import annotations

import csv
import difflib
import io
import re
import unicodedata

import numpy as np
import pandas as pd

from aceval.data.contract import ValidationReport


def sheet_line(index: int) -> str:
    """Where row ``index`` (0-based) of a sheet is: its line (the header is line 1)."""
    return f"line {index + 2}"


#: the sheets' name columns: every results table is keyed by them
NAME_COLUMNS = {
    "subjects.tsv": ["subject"],
    "tests.tsv": ["test"],
    "imus.tsv": ["imu", "segment", "side", "sensor_set"],
}


def read_as_missing(names) -> set[str]:
    """The ``names`` that a CSV reader with its default settings (:func:`pandas.read_csv`, as
    every reader of aceval's results tables) takes for a missing value: '', 'NA', 'N/A', 'null',
    'nan', 'None' and the like. As a subject, test, IMU, segment or side such a name would come
    back as NaN and its rows would silently drop out of every grouping.
    """
    unique = sorted(set(names))
    text = io.StringIO()
    writer = csv.writer(text)
    writer.writerow(["position", "name"])  # a second column: an empty name is a line, not skipped
    writer.writerows(enumerate(unique))
    read = pd.read_csv(io.StringIO(text.getvalue()), dtype={"name": str})["name"]
    return {unique[k] for k in np.flatnonzero(read.isna().to_numpy())}


def check_names(sheets: dict[str, pd.DataFrame], sensor_sets: list[str], report) -> None:
    """An error for each name of :data:`NAME_COLUMNS` (and of dataset.yaml sensor_sets) that is
    empty or :func:`read_as_missing` (an empty sensor_set of imus.tsv means every set: allowed).
    """
    for sheet, columns in NAME_COLUMNS.items():
        table = sheets[sheet]
        for column in [c for c in columns if c in table.columns]:
            values = table[column]
            missing = read_as_missing(values) - ({""} if column == "sensor_set" else set())
            for index in table.index[values.isin(missing)]:
                if values[index] == "":
                    report.error(f"{sheet} {sheet_line(index)}", f"{column} is empty")
                    continue
                report.error(
                    f"{sheet} {sheet_line(index)}",
                    f"{column} {values[index]!r} reads as a missing value in CSV readers "
                    "(pandas.read_csv takes '', NA, N/A, null, nan, None and the like for "
                    "missing): its rows would drop out of every results table; rename it",
                )
    for name in sorted(read_as_missing(str(s) for s in sensor_sets)):
        report.error(
            "dataset.yaml",
            f"sensor_sets: {name!r} reads as a missing value in CSV readers; rename it",
        )


_NUMBER = re.compile(r"[+-]?(\d+\.?\d*|\.\d+)([eE][+-]?\d+)?")


def subject_key(label: str) -> str:
    """The one rule by which subject labels are compared (the contract's): a label that a CSV
    reader reads as a number ('1', '01', '001', '1.0') is that number, so those are one subject;
    any other label is itself. Every results table is read back by such a reader.
    """
    return repr(float(label)) if _NUMBER.fullmatch(str(label)) else str(label)


def unique_subjects(subjects: pd.DataFrame, report: ValidationReport) -> pd.DataFrame:
    """subjects.tsv indexed by subject, a label defined twice (by :func:`subject_key`: '1' and
    '01' are one subject) an error, the first kept.
    """
    keys = subjects["subject"].map(subject_key)
    for index in subjects.index[keys.duplicated(keep="first")]:
        first = subjects.loc[keys[keys == keys[index]].index[0], "subject"]
        label = subjects.loc[index, "subject"]
        report.error(
            f"subjects.tsv {sheet_line(index)}",
            f"subject {label!r} is defined twice"
            + (
                f" ({first!r} and {label!r} are one subject: CSV readers, and aceval, read both as "
                f"the number {float(label):g}); rename one"
                if first != label
                else ""
            ),
        )
    return subjects[~keys.duplicated(keep="first")].set_index("subject", drop=False)


#: segments known by name: Kong's (Table 2: the direction check in walking reads the shank's
#: swing, the step-harmonic method the legs, Kong's recommendation its six), and the others
#: aceval's simulators and importers write (the box, qmt's lower back, Ricci's upper body)
KONG_SEGMENTS = ("head", "chest", "waist", "thigh", "shank", "foot")
KNOWN_SEGMENTS = (*KONG_SEGMENTS, "lower_back", "box", "thorax", "upper_arm", "forearm")
#: sides known by name: the side check in walking compares a leg's sensors with left and right
KNOWN_SIDES = ("left", "right", "center")


def folded(name: str) -> str:
    """``name`` without case, accents, surrounding blanks or word separators: 'Shank', 'SHANK',
    'shánk' and 'shank' fold alike, as 'Upper Arm', 'upper-arm' and 'upper_arm'.
    """
    decomposed = unicodedata.normalize("NFKD", str(name))
    plain = "".join(c for c in decomposed if not unicodedata.combining(c))
    return re.sub(r"[\s_-]+", "_", plain.strip().casefold())


def check_places(imus: pd.DataFrame, functional_axes, report: ValidationReport) -> None:
    """imus.tsv's ``segment`` and ``side`` against the names aceval knows (:data:`KNOWN_SEGMENTS`
    and the segments of functional_axes.tsv, :data:`KNOWN_SIDES`): another spelling of a known
    name ('Shank', 'thígh', 'Right') is an error with the sheet's line, since every check compares
    names exactly (a 'Shank' would switch the direction check in walking off); a segment aceval
    does not know is a warning naming what is not judged for it.
    """
    named = set() if functional_axes is None else set(functional_axes["segment"])
    segments = (*KNOWN_SEGMENTS, *sorted(named))
    for column, known in (("segment", segments), ("side", KNOWN_SIDES)):
        for index, value in imus[column].items():
            if value in known or not value:
                continue
            where = f"imus.tsv {sheet_line(index)}"
            same = [name for name in known if folded(name) == folded(value)]
            if same:
                report.error(
                    where,
                    f"{column} {value!r} is not aceval's spelling of {same[0]!r}: the checks "
                    f"compare names exactly (a {column} {value!r} is judged as none of aceval's); "
                    f"write {same[0]!r}",
                )
            elif column == "segment":
                close = difflib.get_close_matches(folded(value), KNOWN_SEGMENTS, n=1, cutoff=0.8)
                report.warning(
                    where,
                    f"segment {value!r} is not one aceval knows ({', '.join(KNOWN_SEGMENTS)}"
                    + (f"; did you mean {close[0]!r}?" if close else "")
                    + "): the checks and methods that know a segment by name (the shank's swing "
                    "in walking, the step-harmonic method's legs) do not take it for any of them",
                )


def check_subject_labels(subjects: pd.DataFrame, report: ValidationReport) -> None:
    """An error for each subjects.tsv label that holds a path: a separator (slash or
    backslash) or '..', or one that is '.': the workflow names each subject's files after it.
    """
    for index, label in subjects["subject"].items():
        if re.search(r"[/\\]|\.\.", label) or label == ".":
            report.error(
                f"subjects.tsv {sheet_line(index)}",
                f"subject {label!r} holds a path ('/', '\\' or '..'): the workflow names each "
                "subject's files after its label; rename it (e.g. with '-' or '_')",
            )
