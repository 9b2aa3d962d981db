"""Any vendor's delimited-text exports -> the dataset contract, driven by a mapping file the lab
writes once (:mod:`aceval.importers.table_mapping`): which columns hold the accelerometer, the
gyroscope (and optionally the orientation), their units, where the rate is (a number, a line
before the column header, or a time column), how many lines precede the header, and how a
file names its sensor (one sensor per file, from the file name; or every sensor in one file,
from the column names, as APDM's CSV export). The trials and sensors are the lab's two sheets,
as for Xsens exports (:mod:`aceval.importers.xsens_lab`: the rest of the import is theirs).

The sensors of a trial are synchronised by the mapping's ``counter`` (lost samples named with
their sizes), else by its ``time`` column (time jumps named), else by row: they must start
together.
"""

from __future__ import annotations

import fnmatch
import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from aceval.importers.lab_trials import SensorSamples
from aceval.importers.shared import FormatError, ImportReport, text_encoding
from aceval.importers.table_mapping import SENSOR, SEPARATORS, Mapping, read_mapping
from aceval.importers.xsens_lab import LabImport, import_lab

#: the files a trial's path matches that are read when the mapping has no ``files``
DEFAULT_FILES = ("*.txt", "*.csv", "*.tsv")
#: how many lines are searched for the column header
HEADER_SEARCH_LINES = 200


def import_table(
    src: str | Path,
    out: Path,
    mapping_path: str | Path,
    trials_path: str | Path,
    sensors_path: str | Path,
    name: str = "lab",
    rate: float | None = None,
    trim_to_shared: bool = False,
) -> ImportReport:
    """Write the dataset of every trial of ``trials_path`` (exports under ``src`` laid out as
    ``mapping_path`` says) into ``out``; ``rate``: ``--rate``.
    """
    mapping = read_mapping(mapping_path)
    lab = LabImport(
        src=Path(src),
        trials=Path(trials_path),
        sensors=Path(sensors_path),
        name=name,
        description=f"delimited-text exports ({Path(src).name}) read with "
        f"{mapping.path.name}, imported by aceval import table",
        read_file=lambda path: table_samples(path, mapping, rate),
        not_export=lambda path: not_a_table(path, mapping),
        trim_to_shared=trim_to_shared,
    )
    return import_lab(lab, out)


def not_a_table(path: Path, mapping: Mapping) -> str:
    """Why a file is not an export the mapping reads ('' when it is one)."""
    if path.resolve() == mapping.path.resolve():
        return "the mapping file"
    patterns = [mapping.get("files")] if mapping.get("files") else list(DEFAULT_FILES)
    if not any(fnmatch.fnmatch(path.name, p) for p in patterns):
        return f"not an export (the mapping's files: {', '.join(patterns)})"
    if mapping.per_file and not mapping.sensor_pattern().search(path.name):
        return f"its name gives no sensor (sensor_pattern {mapping.sensor_pattern().pattern!r})"
    return ""


def table_samples(path: Path, mapping: Mapping, rate: float | None = None) -> list[SensorSamples]:
    """The sensors of one export file, as the mapping reads it (module docstring)."""
    lines = _lines(path)
    header, separator = _header(path, lines, mapping)
    names = _split(lines[header], separator)
    first = header + 1 + bool(mapping.get("units_line"))
    table = _numbers(path, lines, first, names, separator, mapping)
    rates = {} if rate is None else {"--rate": float(rate)}
    if mapping.get("rate") is not None:
        rates["the mapping's rate"] = float(mapping.get("rate"))
    if mapping.get("rate_line"):
        rates.update(_rate_line(path, lines[:header], mapping))
    time = _time(path, table, mapping)
    if time is not None:
        rates["its time column"] = float(1.0 / np.median(np.diff(time)))
    declared = bool(rates) and not mapping.get("rate_line") and time is None
    fs_hz = next(iter(rates.values()), None)
    index = _index(path, table, mapping, time, fs_hz)
    clock = mapping.get("counter") or ("time column" if time is not None else "row")
    sensors = [_file_sensor(path, mapping)] if mapping.per_file else _column_sensors(names, mapping)
    if not sensors:
        raise FormatError(
            f"{path}: line {header + 1}: no column is {mapping.columns('<sensor>')['acc'][0]!r} "
            "for any sensor (the mapping's acc columns)"
        )
    up = -1.0 if mapping.get("acc_at_rest") == "down" else 1.0  # the contract's: specific force
    out = []
    for sensor in sensors:
        columns = mapping.columns(sensor)
        out.append(
            SensorSamples(
                sensor=sensor,
                path=path,
                acc=_vector(path, table, columns["acc"], header) * mapping.factor("acc") * up,
                gyr=_vector(path, table, columns["gyr"], header) * mapping.factor("gyr"),
                quat=_vector(path, table, columns["quat"], header) if "quat" in columns else None,
                index=index,
                rates=rates,
                declared=declared,
                clock=clock,
            )
        )
    return out


def _lines(path: Path) -> list[str]:
    """The file's lines (its byte-order mark, if any, read as such); FormatError when empty."""
    try:
        with open(path, encoding=text_encoding(path), errors="replace", newline="") as handle:
            lines = handle.read().splitlines()
    except OSError as exc:
        raise FormatError(f"{path}: cannot be read ({exc})") from None
    if not any(line.strip() for line in lines):
        raise FormatError(f"{path}: empty")
    return lines


def _split(line: str, separator: str | None) -> list[str]:
    """A line's fields, stripped of spaces and quotes."""
    fields = line.split(separator) if separator else line.split()
    return [f.strip().strip('"').strip() for f in fields]


def _header(path: Path, lines: list[str], mapping: Mapping) -> tuple[int, str | None]:
    """(index of the column header line, separator): the line ``skip_lines`` says, or the first
    holding the first acc column (a sensor's, for sensor_from columns); the separator the
    mapping's, or the one of tab, comma and semicolon that splits that line into the column.
    """
    given = mapping.get("separator")
    candidates = [SEPARATORS[given]] if given else ["\t", ",", ";"]
    wanted = mapping.columns(SENSOR)["acc"][0]
    pattern = re.compile("^" + re.escape(wanted).replace(re.escape(SENSOR), ".+") + "$")
    skip = mapping.get("skip_lines")
    rows = [skip] if skip is not None else range(min(len(lines), HEADER_SEARCH_LINES))
    for k in rows:
        if k >= len(lines):
            break
        for separator in candidates:
            if any(pattern.match(field) for field in _split(lines[k], separator)):
                return k, separator
    where = f"line {skip + 1}" if skip is not None else f"the first {len(rows)} lines"
    raise FormatError(
        f"{path}: {where}: no column header with {wanted!r} (the mapping's first acc column"
        + (f", separated by {given}" if given else ", tab-, comma- or semicolon-separated")
        + "): is this one of the exports, and are skip_lines and the column names right?"
    )


def _numbers(path, lines, first, names, separator, mapping) -> pd.DataFrame:
    """The samples below the header, as numbers; FormatError naming the first line that is not."""
    seen: dict[str, int] = {}
    unique = []
    for name in names:  # a repeated name (two empty ones) gets .1, .2 (as pandas does)
        unique.append(f"{name}.{seen[name]}" if name in seen else name)
        seen[name] = seen.get(name, 0) + 1
    try:
        table = pd.read_csv(
            io.StringIO("\n".join(lines[first:])),
            sep=separator if separator else r"\s+",
            header=None,
            names=unique,
            engine="c" if separator else "python",
            dtype=str,
        )
    except (ValueError, pd.errors.ParserError) as exc:
        raise FormatError(
            f"{path}: from line {first + 1}: cannot be read as a table ({exc})"
        ) from None
    if len(table) < 2:
        raise FormatError(f"{path}: fewer than 2 samples below the column header")
    table.attrs["decimal"] = mapping.get("decimal", ".")
    return table


def _vector(path: Path, table: pd.DataFrame, columns: list[str], header: int) -> np.ndarray:
    """The columns as an (N, k) float array; FormatError naming a missing column or the first
    line with a value that is not a number.
    """
    missing = [c for c in columns if c not in table]
    if missing:
        raise FormatError(
            f"{path}: line {header + 1}: no column {', '.join(map(repr, missing))} (found "
            f"{', '.join(map(str, table.columns[:12]))}{' ...' if len(table.columns) > 12 else ''})"
        )
    text = table[columns]
    if table.attrs.get("decimal") == ",":
        text = text.apply(lambda c: c.str.replace(",", ".", regex=False))
    values = text.apply(lambda c: pd.to_numeric(c, errors="coerce"))
    bad = ~np.isfinite(values.to_numpy(float)).all(axis=1)
    if bad.any():
        row = int(np.flatnonzero(bad)[0])
        raise FormatError(
            f"{path}: sample {row + 1} below the header: a missing or non-numeric value in "
            f"{', '.join(columns)} ({', '.join(map(str, table[columns].iloc[row]))})"
        )
    return values.to_numpy(float)


def _rate_line(path: Path, lines: list[str], mapping: Mapping) -> dict:
    """``{"its line N": Hz}`` from the line before the header that the mapping's rate_line
    matches; FormatError when none does.
    """
    pattern = re.compile(mapping.get("rate_line"))
    for k, line in enumerate(lines):
        match = pattern.search(line)
        if match:
            try:
                return {f"its line {k + 1}": float(match.group(1).replace(",", "."))}
            except ValueError:
                raise FormatError(
                    f"{path}: line {k + 1}: the rate_line's group is {match.group(1)!r}, not a "
                    "number"
                ) from None
    raise FormatError(
        f"{path}: none of the {len(lines)} line(s) before the column header matches the "
        f"mapping's rate_line {pattern.pattern!r}"
    )


def _time(path: Path, table: pd.DataFrame, mapping: Mapping) -> np.ndarray | None:
    """The time column in seconds (None without one); FormatError when it does not increase."""
    if not mapping.get("time"):
        return None
    column = mapping.get("time")["column"]
    time = _vector(path, table, [column], -1)[:, 0] * mapping.factor("time")
    if not (np.median(np.diff(time)) > 0):
        raise FormatError(f"{path}: the time column {column!r} does not increase")
    return time


def _index(path, table, mapping: Mapping, time, fs_hz) -> np.ndarray:
    """The sample index the trial's sensors share: the counter unwrapped, the time stamps
    times the rate, or the row.
    """
    counter = mapping.get("counter")
    if counter:
        values = _vector(path, table, [counter], -1)[:, 0].astype(np.int64)
        steps = np.diff(values)
        wrap = mapping.get("counter_wrap")
        if wrap:
            steps = steps % wrap
        return values[0] + np.concatenate([[0], np.cumsum(steps)])
    if time is not None and fs_hz:
        return np.round(time * fs_hz).astype(np.int64)
    return np.arange(len(table))


def _file_sensor(path: Path, mapping: Mapping) -> str:
    """The sensor ID in a file's name (the mapping's sensor_pattern)."""
    match = mapping.sensor_pattern().search(path.name)
    if not match:
        raise FormatError(
            f"{path}: its name gives no sensor (sensor_pattern {mapping.sensor_pattern().pattern!r})"
        )
    return match.groupdict().get("sensor") or match.group(1)


def _column_sensors(names: list[str], mapping: Mapping) -> list[str]:
    """The sensors named in the column header (those with the first acc column)."""
    wanted = mapping.columns(SENSOR)["acc"][0]
    before, _, after = wanted.partition(SENSOR)
    pattern = re.compile("^" + re.escape(before) + "(.+)" + re.escape(after) + "$")
    return list(dict.fromkeys(m.group(1) for n in names if (m := pattern.match(n))))
