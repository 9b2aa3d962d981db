"""Which calibration ``aceval apply`` gives each IMU: the decision's choice
(:func:`decided_calibrations`: ``use``, ``use with care`` and ``not within tolerance`` are applied,
the last two said by name; ``no trustworthy calibration`` is refused by name unless asked for), or
one method's from a calibrations file (:func:`chosen_calibrations`). A file that gives one unit
two different calibrations (or one IMU two decisions), or a matrix that is not a rotation, is
refused with its lines.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aceval.calibrate.table import unflagged
from aceval.data.contract import FINGERPRINT, R_COLUMNS
from aceval.data.dataset import Dataset
from aceval.evaluation.decision_rules import NONE, VERDICT_KINDS
from aceval.methods import registry

KEY = ["subject", "sensor_set", "imu"]
#: largest |R R^T - I| and |det R - 1| of a matrix taken for a rotation (the calibrations CSV keeps
#: 17 digits; 1e-6 is a rotation error of about 6e-5 deg)
ROTATION_TOLERANCE = 1e-6
#: beside each IMU in applied_calibrations.tsv: which calibration apply used ('all repetitions',
#: 'subset' or 'none'; from a decision its verdict) and why
CHOICE_COLUMNS = ["calibration", "why"]
UNTRUSTED = NONE
#: the decision table's columns apply reads
DECISION_COLUMNS = [*KEY, "method", "test", "repetitions", "verdict_kind", "verdict", *R_COLUMNS]


class ApplyError(ValueError):
    """The calibrations cannot be applied to this dataset; the message says which row and why."""


def read_calibrations(path: str | Path) -> pd.DataFrame:
    """The CSV of `aceval calibrate` (or a peer's) at ``path``; ApplyError naming the file and
    the cause when it is missing, unreadable, binary or not such a file.
    """
    required = ["subject", "sensor_set", "imu", "test", "method", "n_reps", "flag"]
    return _read_table(path, required, "a file of `aceval calibrate`", "calibrations")


def _read_table(path, required: list[str], kind: str, rows: str) -> pd.DataFrame:
    """The table at ``path``; ApplyError naming it and the cause when it cannot be read, lacks a
    ``required`` column (is it ``kind``?) or holds no ``rows``.
    """
    from aceval.data.errors import InputError
    from aceval.report.results import read_tables

    try:
        table = read_tables([path], required=required)
    except InputError as exc:
        raise ApplyError(f"{exc}: is it {kind}?") from None
    if table.empty:
        raise ApplyError(f"{path} holds no {rows}")
    return table


def _repetitions(label) -> frozenset:
    """``'R1+R3'`` -> {1, 3} (empty for a missing label)."""
    return (
        frozenset(part.strip() for part in str(label).split("+"))
        if label == label
        else (frozenset())
    )


def chosen_calibrations(
    dataset: Dataset,
    calibrations: pd.DataFrame,
    method: str | None = None,
    test: str | None = None,
    allow_subset: bool = False,
    source: str = "the calibrations file",
) -> pd.DataFrame:
    """What apply does for each (subject, set, IMU) of the dataset that a test of calibrates.tsv
    calibrates: one row with the calibration's columns and :data:`CHOICE_COLUMNS`. The
    ``method``'s (default Kong's, the registry's method of Kong et al. 2016) calibration from
    all the unit's repetitions (the union of those of its rows: a hand-deleted row is missed,
    not replaced), unflagged, from ``test`` or else the first test
    of calibrates.tsv that has one (``calibration`` 'all repetitions'); failing that, with
    ``allow_subset`` only, the largest unflagged subset of the first test that has one
    ('subset'); else 'none'. ``why`` says which and why (which tests were passed over, flagged
    what). ApplyError naming ``source``'s lines where two of its rows give one calibration (the
    same IMU, test, method and repetitions) different rotations: which one is meant is unknown.
    """
    method = method or registry.paper_method("kong2016")
    rows = calibrations[calibrations["method"] == method]
    _refuse_conflicts(rows, [*KEY, "test", "method", "repetitions"], source)
    if test is not None:
        rows = rows[rows["test"] == test]
    rows = rows.assign(subject=rows["subject"].map(dataset.subject_label))
    tests = list(dict.fromkeys(dataset.calibrates["test"])) if test is None else [test]
    tests += sorted(set(rows["test"]) - set(tests))
    calibrated = dataset.calibrates["imu"].unique()
    wanted = dataset.recordings[dataset.recordings["imu"].isin(calibrated)][KEY].drop_duplicates()
    groups = dict(list(rows.groupby(KEY, sort=False)))
    out = []
    for key in wanted.itertuples(index=False, name=None):
        out.append(_choice(key, groups.get(key), tests, method, allow_subset))
    columns = list(dict.fromkeys([*KEY, "test", "repetitions", "n_reps", *calibrations.columns]))
    return pd.DataFrame(out, columns=[*columns, *CHOICE_COLUMNS])


def _choice(key, group, tests: list[str], method: str, allow_subset: bool) -> dict:
    """:func:`chosen_calibrations`' row of one IMU (``group``: its rows of the method, or None)."""
    passed = []
    if group is not None:
        sets = group["repetitions"].map(_repetitions)
        valid = unflagged(group)
        for test in tests:
            unit = (group["test"] == test).to_numpy()
            if not unit.any():
                continue
            everything = frozenset().union(*sets[unit])
            full = unit & (sets == everything).to_numpy()
            n = len(everything)
            if (full & valid.to_numpy()).any():
                row = group[full & valid.to_numpy()].iloc[0].to_dict()
                why = f"all {n} repetitions of {test}"
                return row | {"calibration": "all repetitions", "why": why + _passed(passed)}
            flag = group.loc[full, "flag"].astype(str)
            passed.append(
                f"{test}: its calibration from all {n} repetitions is "
                + (f"flagged {flag.iloc[0]}" if full.any() else "not in the calibrations file")
            )
        subsets = group[valid.to_numpy()]
        subsets = subsets.assign(_order=subsets["test"].map({t: k for k, t in enumerate(tests)}))
        if len(subsets):
            best = subsets.sort_values(["_order", "n_reps"], ascending=[True, False]).iloc[0]
            if allow_subset:
                row = best.drop("_order").to_dict()
                why = f"the subset {row['repetitions']} of {row['test']} (--allow-subset)"
                return row | {"calibration": "subset", "why": why + _passed(passed)}
            passed.append(
                f"an unflagged subset ({best['repetitions']} of {best['test']}) is there: "
                "--allow-subset applies the largest"
            )
    else:
        passed.append(f"no {method} calibration of it in the calibrations file")
    return dict(zip(KEY, key)) | {"calibration": "none", "why": "; ".join(passed)}


def _passed(passed: list[str]) -> str:
    return f" (passed over: {'; '.join(passed)})" if passed else ""


def _refuse_conflicts(rows: pd.DataFrame, key: list[str], source: str) -> None:
    """ApplyError naming ``source``'s lines (the rows' index + 2) where two rows with the same
    ``key`` hold different calibrations (rotations more than :data:`ROTATION_TOLERANCE` apart, or
    another method or test): the file does not say which one is meant.
    """
    from aceval.data.rotations import error_angle_deg

    twice = rows[rows.duplicated(key, keep=False)]
    for _, group in twice.groupby(key, sort=False, dropna=False):
        R = group[R_COLUMNS].apply(pd.to_numeric, errors="coerce").to_numpy(float)
        same = np.allclose(R, R[0], atol=ROTATION_TOLERANCE, equal_nan=True)
        same &= all(group[c].nunique(dropna=False) == 1 for c in ("method", "test") if c in group)
        if same:
            continue
        first, second = R[0].reshape(3, 3), R[1].reshape(3, 3)
        apart = (
            f" {float(error_angle_deg(first, second)):.1f} deg apart"
            if np.isfinite(R[:2]).all()
            else ""
        )
        lines = " and ".join(str(i + 2) for i in group.index[:2])
        what = " ".join(str(group.iloc[0][c]) for c in key)
        raise ApplyError(
            f"{source} lines {lines}: two different calibrations for {what}{apart}: which one "
            "is meant is unknown; remove the other (or correct it) and apply again"
        )


def read_decision(path: str | Path) -> pd.DataFrame:
    """The decision table at ``path`` (``results/<dataset>/tables/decision.csv``: one row per
    IMU, :data:`DECISION_COLUMNS`); ApplyError naming the file (and line) and the cause when it
    is missing, unreadable, not such a table, empty, or a verdict is not one of
    :data:`VERDICT_KINDS`.
    """
    decision = _read_table(path, DECISION_COLUMNS, "a decision.csv of the workflow", "decision")
    unknown = ~decision["verdict_kind"].isin(VERDICT_KINDS)
    if unknown.any():
        line = int(np.flatnonzero(unknown)[0]) + 2
        raise ApplyError(
            f"{path} line {line}: verdict_kind {decision['verdict_kind'][unknown].iloc[0]!r} is "
            f"not one of {', '.join(VERDICT_KINDS)}"
        )
    return decision


def decided_calibrations(
    dataset: Dataset, decision: pd.DataFrame, include_untrusted: bool = False, source: str = ""
) -> tuple[pd.DataFrame, list[str]]:
    """What apply does for each (subject, set, IMU) of the dataset that a test calibrates, by the
    ``decision`` (:func:`read_decision` of ``source``): ``(chosen, warnings)``, ``chosen`` as
    :func:`chosen_calibrations`' with ``verdict_kind`` and ``calibration`` the verdict where the
    decision's rotation is applied ('none' where not: an IMU the decision does not name, or
    ``no trustworthy calibration`` without ``include_untrusted``, or with it where the decision
    names no rotation; ``why`` says which). ApplyError naming ``source``'s lines where two rows
    decide one IMU differently, where an applied verdict has no rotation, or where the decision
    names none of the dataset's IMUs; the warnings name its rows for IMUs the dataset lacks.
    """
    decision = decision.assign(subject=decision["subject"].map(dataset.subject_label))
    _refuse_conflicts(decision, KEY, source)
    calibrated = dataset.calibrates["imu"].unique()
    wanted = dataset.recordings[dataset.recordings["imu"].isin(calibrated)][KEY].drop_duplicates()
    keys = set(wanted.itertuples(index=False, name=None))
    rows = {}
    for index, row in decision.iterrows():
        rows.setdefault(tuple(row[KEY]), (index, row))
    unknown = [" ".join(map(str, k)) for k in rows if k not in keys]
    if len(unknown) == len(rows):
        raise ApplyError(
            f"{source} decides none of the IMUs of {dataset.root} (it names "
            f"{', '.join(unknown[:4])}{' ...' if len(unknown) > 4 else ''}): another dataset's?"
        )
    warnings = (
        [f"{source} decides IMUs {dataset.root} does not have, left aside: {', '.join(unknown)}"]
        if unknown
        else []
    )
    out = []
    for key in wanted.itertuples(index=False, name=None):
        if key not in rows:
            out.append(dict(zip(KEY, key)) | {"calibration": "none", "why": f"not in {source}"})
            continue
        out.append(_decided(*rows[key], include_untrusted, source))
    columns = [*KEY, "test", "repetitions", "method", "verdict_kind", *CHOICE_COLUMNS, *R_COLUMNS]
    return pd.DataFrame(out).reindex(columns=[*columns, FINGERPRINT]), warnings


def _decided(index: int, row: pd.Series, include_untrusted: bool, source: str) -> dict:
    """:func:`decided_calibrations`' row of one IMU from its decision ``row`` (line index + 2)."""
    kind, verdict = row["verdict_kind"], str(row["verdict"])
    R = pd.to_numeric(row[R_COLUMNS], errors="coerce").to_numpy(float)
    named = np.isfinite(R).all()
    out = row[[*KEY, "test", "repetitions", "method", "verdict_kind", *R_COLUMNS]].to_dict()
    out[FINGERPRINT] = row.get(FINGERPRINT, np.nan)
    if kind != UNTRUSTED or (include_untrusted and named):
        if not named:
            raise ApplyError(
                f"{source} line {index + 2}: {' '.join(map(str, row[KEY]))} is decided "
                f"{kind!r} but r11..r33 are not all numbers: was the file edited?"
            )
        applied = " (--include-untrusted)" if kind == UNTRUSTED else ""
        return out | {"calibration": kind, "why": _said(kind, verdict) + applied}
    hint = (
        "; --include-untrusted applies the calibration it names anyway"
        if named
        else "; the decision names no calibration to apply"
    )
    return out | {"calibration": "none", "why": _said(kind, verdict) + hint}


def _said(kind: str, verdict: str) -> str:
    """A verdict in words: its text where it names its kind, else the kind and the text."""
    if verdict in ("", "nan") or verdict == kind:
        return kind
    return verdict if verdict.startswith(kind) else f"{kind} ({verdict})"


def check_rotations(chosen: pd.DataFrame, source: str) -> None:
    """ApplyError naming the first chosen row (subject, set, IMU, test) whose matrix is not a
    rotation: a cell that is not a number, not orthonormal, or a reflection.
    """
    for _, row in chosen.iterrows():
        what = f"{source}: {row['subject']} {row['sensor_set']} {row['imu']} {row['test']}"
        R = pd.to_numeric(row[R_COLUMNS], errors="coerce").to_numpy(float).reshape(3, 3)
        if not np.isfinite(R).all():
            raise ApplyError(f"{what}: r11..r33 are not all numbers")
        off = np.abs(R @ R.T - np.eye(3)).max()
        if off > ROTATION_TOLERANCE or abs(np.linalg.det(R) - 1) > ROTATION_TOLERANCE:
            raise ApplyError(
                f"{what}: the matrix is not a rotation (|R R^T - I| = {off:.3g}, "
                f"det {np.linalg.det(R):.6g}): was the file edited?"
            )


def choose(dataset: Dataset, options) -> tuple[pd.DataFrame, list[str]]:
    """``(chosen, warnings)`` of `aceval apply`'s ``options`` (its arguments): each IMU's
    calibration, the decision's (``decision``, ``include_untrusted``) or the method's from the
    calibrations file (``calibrations``, ``method``, ``test``, ``allow_subset``), its matrices
    checked (:func:`check_rotations`). ApplyError when an option is given with the wrong source,
    or when no IMU has one to apply (naming why for each).
    """
    wrong = [o for o in ("method", "test", "allow_subset") if getattr(options, o)]
    wrong = wrong if options.decision else ["include_untrusted"] * options.include_untrusted
    if wrong:
        other = "--calibrations" if options.decision else "--decision"
        raise ApplyError(f"--{wrong[0].replace('_', '-')} is an option of {other} only")
    if options.decision:
        chosen, said = decided_calibrations(
            dataset, read_decision(options.decision), options.include_untrusted, options.decision
        )
        what = f"{options.decision} decides no IMU a calibration to apply"
    else:
        calibrations = read_calibrations(options.calibrations)
        arguments = (options.method, options.test, options.allow_subset, options.calibrations)
        chosen, said = chosen_calibrations(dataset, calibrations, *arguments), []
        method = options.method or registry.paper_method("kong2016")
        what = f"{options.calibrations} has no valid {method} calibration" + (
            f" from test {options.test}" if options.test else ""
        )
    if (chosen["calibration"] == "none").all():
        reasons = chosen[[*KEY, "why"]].itertuples(index=False)
        why = [f"  {' '.join(map(str, r[:3]))}: {r[3]}" for r in reasons]
        raise ApplyError(f"{what} to apply:\n" + "\n".join(why))
    check_rotations(
        chosen[chosen["calibration"] != "none"], options.decision or options.calibrations
    )
    return chosen, said
