"""The two sheets of a lab's Xsens import (:mod:`aceval.importers.xsens_lab` describes them):
trials.tsv and sensors.tsv read and checked, and each trial's export files found.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.data.contract import FIRST_PHASES, RIGHT_AXIS_SPELLINGS
from aceval.importers.shared import FormatError, ImportReport

#: the static tests the import writes besides the lab's own standing trials
STANDING, WALKING_VERTICAL = "standing", "walking_vertical"
#: Kong Table 2's walking segments and the pelvis (as the NeuRA and qmt imports)
WALKING_SEGMENTS = ("thigh", "shank", "foot", "waist")
UPPER_BODY = ("head", "chest", "waist")
SUFFIXES = (".txt", ".csv")


@dataclass
class Trial:
    """One trial: its sheet rows, its files and what it holds."""

    subject: str
    test: str
    rep: int
    static: str | float | None
    lines: list[int]
    prefixes: list[str]
    files: list[Path] = field(default_factory=list)
    #: the seconds of its files it is (trials.tsv ``start_s``, ``end_s``), None: all of them
    span: tuple[float, float] | None = None
    #: once read: ``{sensor_id: {acc, gyr, quat, row, file}}`` (SI), and what of it is static and
    #: what motion (``{"static": (test, slice)``, optional, ``"motion": slice or None}``)
    sensors: dict = field(default_factory=dict)
    parts: dict = field(default_factory=dict)

    @property
    def where(self) -> str:
        """The trial in the user's words."""
        lines = ", ".join(map(str, self.lines))
        cut = f" {self.span[0]:g}-{self.span[1]:g} s" if self.span else ""
        return f"trial {' + '.join(self.prefixes)}{cut} (trials.tsv line {lines})"


def read_trials(path: str | Path) -> tuple[list[dict], dict]:
    """trials.tsv as rows (with ``line``, ``rep`` filled in) and each test's ``{kind,
    first_phase, calibrates}``; FormatError naming the line and the cause.
    """
    sheet = _sheet(path, ["subject", "test"], one_of=("trial", "file"))
    if "trial" not in sheet:
        sheet["trial"] = sheet["file"]
    rows, tests, counts = [], {}, {}
    for index, row in sheet.iterrows():
        line, where = index + 2, f"{path}: line {index + 2}"
        for column in ("subject", "trial", "test"):
            if not row[column]:
                raise FormatError(f"{where}: {column} is empty")
        static = _static(row.get("static", ""), where)
        span = _span(row, where)
        test = _test(row, static, where, tests)
        rep = row.get("rep", "")
        if rep and not (rep.isdigit() and int(rep) > 0):
            raise FormatError(f"{where}: rep {rep!r} is not a positive whole number")
        key = (row["subject"], row["test"])
        if not rep:
            numbered = counts.setdefault(key, {})
            rep = numbered.setdefault((row["trial"], span), len(numbered) + 1)
        rows.append(
            {**row.to_dict(), "line": line, "rep": int(rep), "static": static, "span": span}
        )
        test.setdefault("lines", []).append(line)
    return rows, tests


def _sheet(path, required: list[str], one_of: tuple = ()) -> pd.DataFrame:
    """A tab-separated sheet of strings (stripped, ``#`` lines are comments)."""
    try:
        sheet = pd.read_csv(
            path, sep="\t", dtype=str, comment="#", keep_default_na=False, encoding="utf-8-sig"
        )
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise FormatError(f"{path}: cannot be read as a tab-separated sheet ({exc})") from None
    sheet.columns = [str(c).strip() for c in sheet.columns]
    sheet = sheet.apply(lambda c: c.str.strip())
    missing = [c for c in required if c not in sheet]
    if one_of and not set(one_of) & set(sheet):
        missing.append(" or ".join(one_of))
    if missing:
        raise FormatError(
            f"{path}: missing column(s) {', '.join(missing)} (found {', '.join(sheet.columns)}; "
            "the sheet is tab-separated with a header line)"
        )
    if sheet.empty:
        raise FormatError(
            f"{path}: only its header line, no row below it ({', '.join(sheet.columns)}): write "
            "one row per item under the header (docs/your_data.md)"
        )
    return sheet


def _span(row, where: str) -> tuple[float, float] | None:
    """A row's segment (``start_s``, ``end_s``: seconds from the first sample of its files), or
    None (the whole trial); FormatError unless both are numbers with ``0 <= start < end``.
    """
    cells = [row.get("start_s", ""), row.get("end_s", "")]
    if not any(cells):
        return None
    try:
        start, end = (float(c) for c in cells)
    except ValueError:
        start = end = np.nan
    if not 0 <= start < end < np.inf:
        raise FormatError(
            f"{where}: start_s {cells[0]!r} and end_s {cells[1]!r}: give both, in seconds from "
            "the trial's first sample, start before end (or neither: the whole trial)"
        )
    return start, end


def _static(value: str, where: str) -> str | float | None:
    """A ``static`` cell: None, 'file', 'walking' or seconds."""
    if not value:
        return None
    if value in ("file", "walking"):
        return value
    try:
        seconds = float(value)
    except ValueError:
        seconds = np.nan
    if not seconds > 0:
        raise FormatError(
            f"{where}: static {value!r}: write 'file' (the trial is quiet standing), the seconds "
            "of quiet standing at its start (e.g. 5), or 'walking' (no quiet standing: the mean "
            "walking posture gives the vertical)"
        )
    return seconds


def _test(row, static, where: str, tests: dict) -> dict:
    """The test's description, checked against its other rows."""
    name = row["test"]
    if name in (STANDING, WALKING_VERTICAL):
        raise FormatError(f"{where}: {name!r} is a test name the import writes; call it otherwise")
    kind = "static" if static == "file" else "motion"
    phase = row.get("first_phase", "")
    if phase not in FIRST_PHASES:
        raise FormatError(f"{where}: first_phase {phase!r} is not one of -y, +y, gait or empty")
    segments = tuple(s.strip() for s in row.get("calibrates", "").split(",") if s.strip())
    if kind == "motion" and not segments:
        if phase != "gait":
            raise FormatError(
                f"{where}: test {name!r}: say which segments it calibrates (column calibrates, "
                f"e.g. 'waist,chest,head' for bowing; Kong Table 2), or first_phase 'gait' for "
                f"walking (then {', '.join(WALKING_SEGMENTS)})"
            )
        segments = WALKING_SEGMENTS
    found = {"kind": kind, "first_phase": phase, "calibrates": segments}
    known = tests.setdefault(name, found)
    differs = [k for k in found if known[k] != found[k]]
    if differs:
        raise FormatError(
            f"{where}: test {name!r} has another {' and '.join(differs)} than in line "
            f"{known['lines'][0]} ({', '.join(f'{k} {known[k]!r}' for k in differs)}): one test, "
            "one description (a standing trial is static=file in every row of its test)"
        )
    return known


def read_lab_sensors(path: str | Path) -> pd.DataFrame:
    """sensors.tsv with its defaults filled in and ``line``; FormatError naming line and cause."""
    sheet = _sheet(path, ["sensor_id", "segment", "side"])
    for column in ("imu", "sensor_set", "region", "right_axis", "subject"):
        if column not in sheet:
            sheet[column] = ""
    sheet["line"] = sheet.index + 2
    sheet["sensor_id"] = sheet["sensor_id"].str.upper()
    short = {"left": "_l", "right": "_r"}
    for index, row in sheet.iterrows():
        where = f"{path}: line {index + 2}"
        for column in ("sensor_id", "segment", "side"):
            if not row[column]:
                raise FormatError(f"{where}: {column} is empty")
        if row["right_axis"] and row["right_axis"].lower() not in RIGHT_AXIS_SPELLINGS:
            raise FormatError(
                f"{where}: right_axis {row['right_axis']!r} is not one of +x -x +y -y +z -z (or "
                "empty: the import then proposes one from the recordings)"
            )
        sheet.loc[index, "imu"] = row["imu"] or row["segment"] + short.get(row["side"], "")
        sheet.loc[index, "sensor_set"] = row["sensor_set"] or "main"
        upper = row["segment"] in UPPER_BODY
        sheet.loc[index, "region"] = row["region"] or ("upper_body" if upper else "lower_body")
    sheet["source"] = [f"{Path(path).name} line {line}" for line in sheet["line"]]
    for keys, what in (
        (["subject", "sensor_id"], "sensor"),
        (["subject", "sensor_set", "imu"], "IMU"),
    ):
        twice = sheet[sheet.duplicated(keys, keep=False)]
        if len(twice):
            raise FormatError(
                f"{path}: lines {', '.join(map(str, twice['line']))} name the same {what} "
                f"({', '.join(f'{k} {twice.iloc[0][k]!r}' for k in keys if twice.iloc[0][k])})"
            )
    return sheet


def find_trials(
    src: Path, rows: list[dict], report: ImportReport, sheets: set, not_export=None
) -> list[Trial]:
    """The trials of the sheet's rows with their export files. ``not_export(path)``: why a file
    is not an export ('' when it is); such files that a trial's path matches are skipped and
    named, as are the exports in no trial. FormatError when a row matches nothing, when two
    trials share a file (unless both are segments, ``start_s``-``end_s``, that do not overlap)
    or one trial is given two static sources or segments.
    """
    if not src.is_dir():
        raise FormatError(f"{src}: not a folder of exports")
    files = [p for p in sorted(src.rglob("*")) if p.is_file() and p.resolve() not in sheets]
    relative = {p: p.relative_to(src).as_posix() for p in files}
    problems = {p: not_export(p) if not_export else "" for p in files}
    trials: dict[tuple, Trial] = {}
    owner: dict[Path, list] = {}
    for row in rows:
        key = (row["subject"], row["test"], row["rep"])
        trial = trials.setdefault(key, Trial(*key, row["static"], [], [], span=row["span"]))
        for what, called in (("static", "static sources"), ("span", "segments")):
            if row[what] != getattr(trial, what):
                raise FormatError(
                    f"trials.tsv lines {trial.lines[0]} and {row['line']}: one trial "
                    f"({row['subject']}, {row['test']} R{row['rep']}) with two {called} "
                    f"({getattr(trial, what)!r}, {row[what]!r}): give it once, the same on every "
                    "row of the trial"
                )
        trial.lines.append(row["line"])
        trial.prefixes.append(row["trial"])
        prefix = row["trial"].rstrip("/")
        matched = [p for p, rel in relative.items() if _starts(rel, prefix)]
        exports = [p for p in matched if not problems[p]]
        if not exports:
            raise FormatError(
                f"trials.tsv line {row['line']}: trial {row['trial']!r} matches no export under "
                f"{src} (a file whose path starts with it, followed by - _ . or /; "
                f"{sum(not v for v in problems.values())} export(s) there"
                + (
                    f"; {len(matched)} other file(s) it matches are not exports)"
                    if matched
                    else ")"
                )
            )
        for path in exports:
            _claim(owner.setdefault(path, []), path, key, row)
        trial.files += [p for p in exports if p not in trial.files]
    _name_skipped(files, relative, problems, owner, rows, report, src)
    return list(trials.values())


def _claim(claims: list, path: Path, key: tuple, row: dict) -> None:
    """Record that trial ``key`` (its sheet ``row``) reads ``path``; FormatError when another
    trial reads it too, unless both are segments that do not overlap.
    """
    for other_key, other in claims:
        if other_key == key:
            continue
        spans = (row["span"], other["span"])
        if None in spans or (spans[0][0] < spans[1][1] and spans[1][0] < spans[0][1]):
            raise FormatError(
                f"{path}: belongs to two trials (trials.tsv lines {other['line']} and "
                f"{row['line']})"
                + (
                    ": make the names tell them apart, or give each its segment (start_s, end_s)"
                    if None in spans
                    else f": their segments overlap ({spans[1][0]:g}-{spans[1][1]:g} s and "
                    f"{spans[0][0]:g}-{spans[0][1]:g} s)"
                )
            )
    claims.append((key, row))


def _name_skipped(files, relative, problems, owner, rows, report, src) -> None:
    """Report the files a trial matches that are not exports, and the exports in no trial."""
    prefixes = [row["trial"].rstrip("/") for row in rows]
    others = [p for p in files if problems[p] and any(_starts(relative[p], t) for t in prefixes)]
    for path in others:
        report.add(relative[path], "", "", "skipped", problems[path])
    if others:
        report.note(
            f"{len(others)} file(s) beside the exports are not exports (skipped, each in "
            "import_report.tsv): "
            + "; ".join(f"{relative[p]}: {problems[p]}" for p in others[:3])
            + (f"; and {len(others) - 3} more" if len(others) > 3 else "")
        )
    idle = [p for p in files if not problems[p] and p not in owner and p.suffix.lower() in SUFFIXES]
    for path in idle:
        report.add(relative[path], "", "", "skipped", "in no trial of trials.tsv")
    if idle:
        report.note(f"{len(idle)} export(s) under {src} are in no trial of trials.tsv (skipped)")


def _starts(relative: str, prefix: str) -> bool:
    """``relative`` is ``prefix`` or starts with it followed by a separator."""
    return relative == prefix or (relative.startswith(prefix) and relative[len(prefix)] in "-_./ ")


def subject_sensors(sensors: pd.DataFrame, subject: str) -> dict[str, dict]:
    """``{sensor_id: row}`` of a subject: its own rows, else the rows for every subject."""
    own = sensors[sensors["subject"] == subject]
    general = sensors[(sensors["subject"] == "") & ~sensors["sensor_id"].isin(own["sensor_id"])]
    return {row["sensor_id"]: row for row in pd.concat([own, general]).to_dict("records")}
