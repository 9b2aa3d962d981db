"""A sensor sheet proposed from the sensorspec files beside a lab's MT Manager exports.

Some labs keep, in each export folder, a ``sensorspec.json.txt`` that says which sensor was on
which body part (the Sint Maartenskliniek's public IMU gait analysis, for one). MT Manager does
not write it and no schema of it is published; the one public reader
(SintMaartenskliniek/IMU_GaitAnalysis, gaittool/helpers/preprocessor.py) reads a JSON object
from a place to the end of that sensor's file names, ``{"leftfoot": "00B40AC5.txt", "lumbar":
"00B40A8D.txt", ...}``, and an optional ``sample_frequency``. So any JSON object is read whose
values hold an 8-hex sensor ID (a nested object too); its keys name the places, and the
common spellings of Kong's segments and of a side are recognised (``leftfoot``, ``L_Shank``,
``lumbar``, ``sternum``...). What is not recognised keeps its name as the segment, and the
import names it as not calibrated.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

from aceval.importers.shared import FormatError

#: a sensorspec is a few hundred bytes; a larger file (an export) is not read as one
MAX_BYTES = 65536
_ID = re.compile(r"(?<![0-9A-Fa-f])([0-9A-Fa-f]{8})(?![0-9A-Fa-f])")
#: words of a place -> Kong's segment (the first that a place's name contains)
SEGMENT_WORDS = [
    (("foot", "feet", "toe"), "foot"),
    (("thigh", "upperleg", "upleg", "femur"), "thigh"),
    (("shank", "shin", "lowerleg", "lowleg", "tibia", "calf", "ankle"), "shank"),
    (("lumbar", "pelvis", "sacrum", "waist", "lowerback", "hip"), "waist"),
    (("sternum", "chest", "thorax", "trunk", "upperback"), "chest"),
    (("head",), "head"),
]


def read_sensorspec(path: Path) -> dict[str, str]:
    """``{place: sensor ID}`` of one sensorspec file ({} when it is not JSON or names no sensor)."""
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as handle:
            text = handle.read(MAX_BYTES + 1)
        content = json.loads(text) if len(text) <= MAX_BYTES else None
    except (OSError, ValueError):
        return {}
    places: dict[str, str] = {}

    def walk(value) -> None:
        for key, item in value.items() if isinstance(value, dict) else []:
            if isinstance(item, str) and (match := _ID.search(item)):
                places[str(key)] = match.group(1).upper()  # place: file or sensor
            elif isinstance(item, str) and (match := _ID.search(str(key))):
                places[item] = match.group(1).upper()  # sensor: place
            walk(item)

    walk(content)
    return places


def place_of(name: str) -> tuple[str, str]:
    """(segment, side) that a place's name spells (segment: the name itself when unknown)."""
    word = re.sub(r"[^a-z]", "", name.lower())
    side = (
        "left"
        if word.startswith(("left", "l")) and not word.startswith("lumbar") or "left" in word
        else "right"
        if word.startswith(("right", "r")) or "right" in word
        else "center"
    )
    for spellings, segment in SEGMENT_WORDS:
        if any(s in word for s in spellings):
            return segment, "center" if segment in ("waist", "chest", "head") else side
    return name, side


def sensorspecs(src: Path) -> dict[Path, dict[str, str]]:
    """``{file: {place: sensor ID}}`` of the sensorspec files under ``src`` (the files that are
    not named as exports and read as JSON naming a sensor).
    """
    specs = {}
    for path in sorted(src.rglob("*")):
        named = _ID.search(path.name)
        if path.is_file() and path.suffix.lower() in (".txt", ".json") and not named:
            if places := read_sensorspec(path):
                specs[path] = places
    return specs


def disagreements(src: Path, sheet) -> list[str]:
    """Where the sensor sheet (its rows: ``sensor_id segment side source``) and the sensorspec
    files under ``src`` name another segment or side for one sensor: one line each.
    """
    lines = []
    for path, places in sensorspecs(src).items():
        for place, sensor in places.items():
            segment, side = place_of(place)
            for row in sheet[sheet["sensor_id"] == sensor].itertuples():
                if (row.segment, row.side) != (segment, side) and segment != place:
                    lines.append(
                        f"{row.source} says sensor {sensor} is {row.segment} {row.side}; "
                        f"{path.relative_to(src)} says {place!r} ({segment} {side}): check which "
                        "is right"
                    )
    return list(dict.fromkeys(lines))


def propose_sensor_sheet(src: Path, trials_path: Path) -> None:
    """Write the sensor sheet the sensorspec files under ``src`` propose beside ``trials_path``
    (``sensors.tsv``, unless one is there) and stop with FormatError saying so; FormatError
    asking for ``--sensors`` when there is no sensorspec.
    """
    specs = sensorspecs(src)
    if not specs:
        raise FormatError(
            "--trials needs --sensors, the sheet of sensor IDs and segments (docs/your_data.md); "
            f"no sensorspec file under {src} proposes one"
        )
    rows, seen = [], {}
    for path, places in specs.items():
        for place, sensor in places.items():
            if seen.setdefault(sensor, place) != place:
                raise FormatError(
                    f"{path}: sensor {sensor} is {place!r} here, {seen[sensor]!r} in another "
                    "sensorspec: write sensors.tsv with a subject column (docs/your_data.md)"
                )
            if all(row[0] != sensor for row in rows):
                rows.append([sensor, re.sub(r"\W+", "_", place), *place_of(place), ""])
    text = "sensor_id\timu\tsegment\tside\tright_axis\n" + "".join(
        "\t".join(row) + "\n" for row in rows
    )
    target = trials_path.parent / "sensors.tsv"
    where = f"written to {target}" if not target.exists() else f"not written: {target} exists"
    if not target.exists():
        target.write_text(text)
    raise FormatError(
        f"no --sensors: the {len(specs)} sensorspec file(s) under {src} (e.g. "
        f"{next(iter(specs)).relative_to(src)}) propose this sensor sheet ({where}):\n{text}"
        "Check each segment and side (Kong's segments: head chest waist thigh shank foot), fill "
        "in right_axis or leave it empty (the import then proposes it), and import again with "
        "--sensors"
    )
