"""The mapping file of ``aceval import table``: how a lab's delimited-text exports are laid out,
written once per vendor (docs/your_data.md, "Another vendor's exports"; every key in
``schemas/table_mapping.schema.yaml``). Read and checked here: every problem is a FormatError
naming the file, the line, the key and the cause.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import yaml

from aceval.importers.shared import FormatError

SCHEMA = Path(__file__).parent / "schemas" / "table_mapping.schema.yaml"
SEPARATORS = {"tab": "\t", "comma": ",", "semicolon": ";", "space": " ", "whitespace": None}
#: units -> the factor to SI (acc m/s^2, gyr rad/s, time s)
UNITS = {
    "g": 9.80665,
    "m/s^2": 1.0,
    "mg": 9.80665e-3,
    "rad/s": 1.0,
    "deg/s": 3.141592653589793 / 180.0,
    "s": 1.0,
    "ms": 1e-3,
    "us": 1e-6,
}
#: a file's sensor by default: the last word (between _ or - and the extension) of its name
DEFAULT_SENSOR_PATTERN = r"[_-](?P<sensor>[^_.\-]+)\.[^.]+$"
SENSOR = "{sensor}"


@dataclass(frozen=True)
class Mapping:
    """A checked mapping: its file and its values (the schema's keys)."""

    path: Path
    values: dict

    def get(self, key: str, default=None):
        """The value of a key, or ``default``."""
        return self.values.get(key, default)

    @property
    def per_file(self) -> bool:
        """One sensor per file (its ID from the file name)."""
        return self.values["sensor_from"] == "file_name"

    def sensor_pattern(self) -> re.Pattern:
        """The regular expression of the sensor ID in a file name."""
        return re.compile(self.values.get("sensor_pattern", DEFAULT_SENSOR_PATTERN))

    def columns(self, sensor: str = "") -> dict[str, list[str]]:
        """``{"acc": [...], "gyr": [...], "quat": [...] (optional)}``: the column names, with a
        sensor's ID put in for ``{sensor}``.
        """
        out = {}
        for key in ("acc", "gyr", "quat"):
            if key in self.values:
                out[key] = [c.replace(SENSOR, sensor) for c in self.values[key]["columns"]]
        return out

    def factor(self, key: str) -> float:
        """The factor from the unit of ``acc``, ``gyr`` or ``time`` to SI."""
        return UNITS[self.values[key].get("unit", "s")]


def read_mapping(path: str | Path) -> Mapping:
    """The mapping at ``path``, checked against the schema and for consistency; FormatError
    naming the line and the key of each problem found (all of them at once).
    """
    import jsonschema

    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
        values = yaml.safe_load(text)
    except (OSError, UnicodeDecodeError) as exc:
        raise FormatError(f"{path}: cannot be read ({exc})") from None
    except yaml.YAMLError as exc:
        raise FormatError(f"{path}: not valid YAML ({exc})") from None
    if not isinstance(values, dict):
        raise FormatError(
            f"{path}: must be a mapping of keys to values (sensor_from: ..., acc: ...), got "
            f"{type(values).__name__} {str(values)[:60]!r}"
        )
    schema = yaml.safe_load(SCHEMA.read_text())
    validator = jsonschema.Draft202012Validator(schema)
    problems = [
        (list(error.absolute_path), error.message)
        for error in sorted(validator.iter_errors(values), key=lambda e: list(map(str, e.path)))
    ]
    if not problems:
        problems = _consistency(values)
    if problems:
        raise FormatError(
            f"{path}: not a valid mapping (each key: {SCHEMA.name} and docs/your_data.md):\n"
            + "\n".join(
                f"  line {_line(text, key)}, key {'.'.join(map(str, key)) or '(top level)'}: "
                f"{message}"
                for key, message in problems
            )
        )
    return Mapping(path, values)


def _consistency(values: dict) -> list[tuple[list, str]]:
    """What the schema cannot say: regular expressions that compile and have their group, the
    ``{sensor}`` placeholders where (and only where) the sensors are in the columns.
    """
    problems = []
    for key, group in (("sensor_pattern", "sensor"), ("rate_line", None)):
        if key not in values:
            continue
        try:
            pattern = re.compile(values[key])
        except re.error as exc:
            problems.append(([key], f"not a regular expression: {exc}"))
            continue
        if pattern.groups == 0:
            needed = f"a group (?P<{group}>...)" if group else "a group (...) around the number"
            problems.append(([key], f"{values[key]!r} has no group: it needs {needed}"))
    for key in ("acc", "gyr", "quat"):
        for k, column in enumerate(values.get(key, {}).get("columns", [])):
            placed = SENSOR in column
            if values["sensor_from"] == "columns" and not placed:
                problems.append(
                    ([key, "columns", k], f"{column!r}: sensor_from columns needs {SENSOR} in it")
                )
            if values["sensor_from"] == "file_name" and placed:
                problems.append(
                    ([key, "columns", k], f"{column!r}: {SENSOR} is for sensor_from columns")
                )
    if values["sensor_from"] == "columns" and "sensor_pattern" in values:
        problems.append((["sensor_pattern"], "is for sensor_from file_name"))
    return problems


def _line(text: str, key: list) -> int | str:
    """The line (1-based) of ``key`` (a path of keys and indices) in the YAML ``text``: the
    deepest part of it that is there.
    """
    try:
        node = yaml.compose(text)
    except yaml.YAMLError:
        return "?"
    line = node.start_mark.line + 1 if node is not None else 1
    for part in key:
        if isinstance(node, yaml.MappingNode):
            found = [(k, v) for k, v in node.value if k.value == str(part)]
            if not found:
                break
            line, node = found[0][0].start_mark.line + 1, found[0][1]
        elif isinstance(node, yaml.SequenceNode) and isinstance(part, int):
            if part >= len(node.value):
                break
            node = node.value[part]
            line = node.start_mark.line + 1
        else:
            break
    return line
