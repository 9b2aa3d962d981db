"""The optional sheet ``verticals.tsv``: the vertical (z0, Kong Eq. 2) of each motion repetition
from its own static recording, where the sensors were put on again between repetitions (repeated
walks, each with its own quiet standing): ``subject test rep static_test static_rep``, for every
IMU and sensor set of that subject and repetition. A motion repetition that is not listed takes,
as without the sheet, every static recording of its IMU averaged. A calibration from several
repetitions takes the mean of their verticals (config/README.md, "Sheets").
"""

from __future__ import annotations

import pandas as pd

from aceval.data.contract import ValidationReport

COLUMNS = ["subject", "test", "rep", "static_test", "static_rep"]


def check_verticals(
    sheet: pd.DataFrame, tests: pd.DataFrame, recordings: pd.DataFrame, report: ValidationReport
) -> pd.DataFrame:
    """verticals.tsv checked (each problem an error naming its line): a motion test and a static
    one of tests.tsv, whole repetition numbers, a static recording of that subject, test and
    repetition in recordings.tsv, one line per motion repetition. Returns its good rows (``rep``
    and ``static_rep`` as int).
    """
    kinds = tests["kind"].to_dict()
    statics = set(
        zip(recordings["subject"], recordings["test"], recordings["rep"].astype(str).str.strip())
    )
    good = []
    for index, row in sheet.iterrows():
        where = f"verticals.tsv line {index + 2}"
        problems = [
            f"test {row['test']!r} is not a motion test of tests.tsv"
            if kinds.get(row["test"]) != "motion"
            else "",
            f"static_test {row['static_test']!r} is not a static test of tests.tsv"
            if kinds.get(row["static_test"]) != "static"
            else "",
            *(
                f"{column} {row[column]!r} is not a whole number from 1"
                for column in ("rep", "static_rep")
                if not (row[column].isdigit() and int(row[column]) > 0)
            ),
        ]
        if not any(problems) and (row["subject"], row["static_test"], row["static_rep"]) not in (
            statics
        ):
            problems.append(
                f"recordings.tsv has no {row['static_test']} R{row['static_rep']} of subject "
                f"{row['subject']!r}"
            )
        for problem in filter(None, problems):
            report.error(where, problem)
        if not any(problems):
            good.append(index)
    out = sheet.loc[good, COLUMNS].astype({"rep": int, "static_rep": int})
    for index in out.index[out.duplicated(["subject", "test", "rep"], keep="first")]:
        report.error(f"verticals.tsv line {index + 2}", "this motion repetition is listed twice")
    return out.drop_duplicates(["subject", "test", "rep"])
