"""False-alarm and catch rates of aceval's calibration checks (not a speed benchmark: the rates in
config/README.md's table of checks come from here).

    python benchmarks/check_rates.py clean resources/kong_sim resources/box_sim resources/neura ...
    python benchmarks/check_rates.py defects [--seeds 1 2] [--repetitions 3 5]

``clean``: each argument is a dataset folder (the workflow writes the committed ones under
resources/). Every calibration from all repetitions (all methods) is computed as `aceval
calibrate --subsets full` does, and each flag is counted: on how many IMUs (subject, set, IMU) it
fires on at least one calibration, and on how many calibrations. On the simulated datasets every
flag is a false alarm; on the real ones a flag may be a real defect (the count is what a user sees).

``signal-defects``: as ``defects``, the checks of a sensor's signals only (:func:`signal_defects`).

``signals``: per recording of each dataset, the stuck-channel and spike checks as it is and with
a channel stuck or a spike put in (:func:`signals`).

``defects``: for each seed and repetition count, a 1-subject Kong simulation (both sets, every IMU
in every test, as a lab records) is broken one way at a time and calibrated:
* ``exchanged``: two IMUs' labels exchanged in every test of one sensor set (chest-right thigh,
  right thigh-right shank, right thigh-left thigh, right shank-left shank, right foot-right shank);
  caught when every calibration of both IMUs is flagged;
* ``random``: one IMU's recordings of one of its tests replaced by a rigid random 3-D rotation
  (every IMU and test of the frontal set); counted per Kong calibration (every subset) of it,
  and per calibration from all repetitions (every method) flagged ``heading_undetermined``;
* ``static``: the static trial's vertical turned 10/20/45/90 deg about the declared right axis
  (every IMU); caught when the IMU is flagged ``static_not_standing``;
* ``acc_x, acc_y swapped`` (a mirrored frame), every IMU of the frontal set: caught when every
  calibration of the IMU is flagged (by any check), and how often by ``gyro_acc_inconsistent``;
* ``clean``: the unbroken copy, every IMU of both sets (a flag is a false alarm);
* the checks of a sensor's signals on defects made in the pass's statistics
  (:func:`signal_defects`): a gyroscope offset, a second static trial leaning, one
  accelerometer negated.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from collections import Counter
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.spatial.transform import Rotation

from aceval.calibrate.pipeline import calibrate
from aceval.calibrate.plan import imu_checks
from aceval.calibrate.table import has_flag
from aceval.data.dataset import load_dataset
from aceval.data.rotations import AXIS_VECTORS
from aceval.signals.reduction import reduce_recordings

KEY = ["subject", "sensor_set", "imu"]
Z0 = ["z0_x", "z0_y", "z0_z"]
EXCHANGES = [
    ("IMU2", "IMU4"),
    ("IMU4", "IMU5"),
    ("IMU4", "IMU7"),
    ("IMU5", "IMU8"),
    ("IMU5", "IMU6"),
]


def summaries_of(dataset) -> pd.DataFrame:
    return reduced_of(dataset)[0]


def reduced_of(dataset) -> tuple[pd.DataFrame, pd.DataFrame]:
    """The one pass's summaries and Obj 1-2 pair moments of every subject."""
    parts = [reduce_recordings(dataset, s) for s in dataset.subjects.index]
    return (
        pd.concat([p.summaries for p in parts], ignore_index=True),
        pd.concat([p.pairs for p in parts], ignore_index=True),
    )


def calibrated(dataset, subsets: str = "full") -> pd.DataFrame:
    """Every calibration as `aceval calibrate` makes it (the sensor checks with the pairs)."""
    summaries, pairs = reduced_of(dataset)
    sensors = imu_checks(dataset, summaries, pairs)
    return calibrate(dataset, summaries, subsets, retest_k=None, sensors=sensors)[0]


def flag_names(flags: pd.Series) -> pd.Series:
    return flags.fillna("").astype(str).str.split(";").map(lambda f: [n for n in f if n])


def clean(root: str) -> list[dict]:
    """One row per flag that fires on ``root``: IMUs and calibrations it fires on."""
    dataset = load_dataset(root)
    calibrations = calibrated(dataset)
    imus = calibrations.groupby(KEY).ngroups
    named = calibrations.assign(name=flag_names(calibrations["flag"])).explode("name")
    named = named[named["name"].notna()]
    rows = [{"dataset": root, "flag": "(none)", "imus": f"0/{imus}", "calibrations": "0"}]
    for name, group in named.groupby("name"):
        rows.append(
            {
                "dataset": root,
                "flag": name,
                "imus": f"{group.groupby(KEY).ngroups}/{imus}",
                "calibrations": f"{len(group)}/{len(calibrations)}",
            }
        )
    return rows if len(rows) == 1 else rows[1:]


def random_motion(t: np.ndarray, rng) -> tuple[np.ndarray, np.ndarray]:
    """(acc g, gyr deg/s) of a rigid random 3-D rotation of a still body (no plane, no axis)."""
    omega = 1.5 * np.column_stack(
        [
            np.sin(2 * np.pi * f * t + p)
            for f, p in zip(rng.uniform(0.3, 1.2, 3), rng.uniform(0, 6, 3))
        ]
    )
    steps = Rotation.from_rotvec(omega * np.gradient(t)[:, None])
    orientation, up = Rotation.identity(), []
    for step in steps:
        orientation = orientation * step
        up.append(orientation.inv().apply([0.0, 0.0, -1.0]))
    return np.array(up), np.degrees(omega)


def _all_flagged(calibrations: pd.DataFrame, imu: str, sensor_set: str) -> tuple[bool, set]:
    rows = calibrations[(calibrations["imu"] == imu) & (calibrations["sensor_set"] == sensor_set)]
    names = flag_names(rows["flag"])
    return bool(len(rows)) and bool(names.map(bool).all()), set(names.explode().dropna())


_KEPT: dict[Path, bytes] = {}


def _rewritten(root: Path, recordings: pd.DataFrame, imu: str, test: str | None, change) -> None:
    """The frontal ``imu``'s recordings (of ``test``, or all) changed in place (a temporary
    simulation; :func:`_restore` puts them back)."""
    chosen = recordings[(recordings["imu"] == imu) & (recordings["sensor_set"] == "frontal")]
    for path in chosen[chosen["test"] == test]["path"] if test else chosen["path"]:
        file = root / path
        _KEPT[file] = file.read_bytes()
        change(pd.read_csv(file)).to_csv(file, index=False, float_format="%.6g")


def _restore() -> None:
    for file, content in _KEPT.items():
        file.write_bytes(content)
    _KEPT.clear()


def defects(root: Path, counts: Counter, found: dict) -> None:
    dataset = load_dataset(root)
    original = dataset.recordings.copy()
    for a, b in EXCHANGES:  # exchanged labels
        for sensor_set in dataset.meta["sensor_sets"]:
            swapped = original.copy()
            rows = swapped["sensor_set"] == sensor_set
            swapped.loc[rows, "imu"] = swapped.loc[rows, "imu"].replace({a: b, b: a})
            dataset.recordings = swapped
            calibrations = calibrated(dataset)
            for imu in (a, b):
                caught, names = _all_flagged(calibrations, imu, sensor_set)
                counts[f"exchanged {a}-{b}"] += 1
                counts[f"exchanged {a}-{b} caught"] += caught
                found.setdefault(f"exchanged {a}-{b}", set()).update(names)
    dataset.recordings = original
    summaries, pairs = reduced_of(dataset)
    clean_checks = imu_checks(dataset, summaries, pairs)
    calibrations, _ = calibrate(dataset, summaries, "full", retest_k=None, sensors=clean_checks)
    for _, group in calibrations.groupby(KEY):  # false alarms on the clean copy
        counts["clean IMUs (no flag expected)"] += 1
        names = set(flag_names(group["flag"]).explode().dropna())
        counts["clean IMUs (no flag expected) caught"] += bool(names)
        found.setdefault("clean IMUs (no flag expected)", set()).update(names)
    static = summaries["kind"] == "static"
    for key in clean_checks:  # static trial turned
        axis = np.asarray(AXIS_VECTORS[dataset.right_axis(key[1], key[2])], float)
        for degrees in (10, 20, 45, 90):
            turn = Rotation.from_rotvec(np.radians(degrees) * axis).as_matrix()
            changed = summaries.copy()
            rows = static & (changed[KEY] == pd.Series(key, index=KEY)).all(axis=1)
            changed.loc[rows, Z0] = changed.loc[rows, Z0].to_numpy(float) @ turn.T
            counts[f"static {degrees} deg"] += 1
            flag = imu_checks(dataset, changed)[key]["flag"]
            counts[f"static {degrees} deg caught"] += "static_not_standing" in flag.split(";")
    signal_defects(dataset, summaries, pairs, clean_checks, counts)
    for imu in dataset.imus.loc["frontal"].index:  # acc_x and acc_y swapped (a mirrored frame)
        _rewritten(
            root, original, imu, None, lambda t: t.assign(acc_x=t["acc_y"], acc_y=t["acc_x"])
        )
        try:
            calibrations = calibrated(dataset)
        finally:
            _restore()
        caught, names = _all_flagged(calibrations, imu, "frontal")
        for name, hit in [("acc_x, acc_y swapped", caught),
                          ("acc_x, acc_y swapped: gyro_acc_inconsistent",
                           "gyro_acc_inconsistent" in names)]:  # fmt: skip
            counts[name] += 1
            counts[name + " caught"] += hit
        found.setdefault("acc_x, acc_y swapped", set()).update(names)
    rng = np.random.default_rng(0)
    calibrates = dataset.calibrates
    for test, imu in calibrates[["test", "imu"]].itertuples(index=False):  # random motion
        chosen = original[
            (original["test"] == test)
            & (original["imu"] == imu)
            & (original["sensor_set"] == "frontal")
        ]
        kept = {}
        for path in chosen["path"]:
            file = root / path
            kept[file] = file.read_bytes()
            table = pd.read_csv(file)
            acc, gyr = random_motion(table["t"].to_numpy(), rng)
            table[["acc_x", "acc_y", "acc_z"]], table[["gyr_x", "gyr_y", "gyr_z"]] = acc, gyr
            table.to_csv(file, index=False, float_format="%.6g")
        try:
            calibrations, _ = calibrate(dataset, summaries_of(dataset), "all", retest_k=None)
        finally:
            for file, content in kept.items():
                file.write_bytes(content)
        kong = calibrations[
            (calibrations["imu"] == imu)
            & (calibrations["test"] == test)
            & (calibrations["sensor_set"] == "frontal")
            & (calibrations["method"] == "kong")
        ]
        names = flag_names(kong["flag"])
        name = f"random in {test} (Kong calibrations)"
        counts[name] += len(kong)
        counts[name + " caught"] += int(names.map(bool).sum())
        found.setdefault(name, set()).update(set(names.explode().dropna()))
        full = calibrations[
            (calibrations["imu"] == imu)
            & (calibrations["test"] == test)
            & (calibrations["sensor_set"] == "frontal")
            & calibrations["cone_deg"].notna()
        ]  # every method's calibration from all repetitions, with its cone
        name = f"random in {test}: heading_undetermined (all methods, all repetitions)"
        counts[name] += len(full)
        counts[name + " caught"] += int(has_flag(full["flag"], "heading_undetermined").sum())


def _caught(counts: Counter, name: str, hit: bool) -> None:
    counts[name] += 1
    counts[name + " caught"] += bool(hit)


def signal_defects(dataset, summaries, pairs, clean_checks: dict, counts: Counter) -> None:
    """The checks of a sensor's signals (aceval.signals.checks) on defects made in the one
    pass's statistics, which is all they read: a gyroscope offset added to every still
    recording of an IMU (``rest_gyro_*``); a second static trial turned about the right axis;
    one accelerometer negated in the Obj 1 pair moments (the same IMU in the other set agrees).
    Caught: the IMU flagged ``gyro_bias``, ``static_disagree``, ``acc_sign_mismatch``.
    """
    from aceval.signals.reduction import C_AB, MEAN_A

    static = summaries["kind"] == "static"
    for key in clean_checks:
        rows = (summaries[KEY] == pd.Series(key, index=KEY)).all(axis=1)
        for dps in (3, 4, 5, 7):
            for axes in ("x", "xz"):
                changed = summaries.copy()
                for axis in axes:
                    changed.loc[rows, f"rest_gyro_{axis}"] += np.radians(dps)
                flag = imu_checks(dataset, changed, pairs)[key]["flag"]
                name = f"gyro offset {dps} deg/s on {'+'.join(axes)}"
                _caught(counts, name, "gyro_bias" in flag.split(";"))
        axis = np.asarray(AXIS_VECTORS[dataset.right_axis(key[1], key[2])], float)
        first = summaries[static & rows].iloc[[0]]
        for degrees in (5, 10, 15, 18, 30):
            turn = Rotation.from_rotvec(np.radians(degrees) * axis).as_matrix()
            second = first.assign(rep=first["rep"] + 1)
            second[Z0] = second[Z0].to_numpy(float) @ turn.T
            changed = pd.concat([summaries, second], ignore_index=True)
            flag = imu_checks(dataset, changed, pairs)[key]["flag"]
            _caught(counts, f"second static trial {degrees} deg", "static_disagree" in flag)
    if pairs.empty or not (pairs["objective"] == "frontal_lateral").any():
        return
    for imu in dataset.imus.loc["frontal"].index:
        negated = pairs.copy()
        rows = (negated["imu"] == imu) & (negated["signal"] == "acc")
        negated.loc[rows, MEAN_A] = -negated.loc[rows, MEAN_A]
        negated.loc[rows, C_AB] = -negated.loc[rows, C_AB]
        found = imu_checks(dataset, summaries, negated)
        for key, verdict in found.items():
            if key[2] == imu and key[1] == "frontal":
                _caught(
                    counts,
                    "one accelerometer negated (two sets)",
                    "acc_sign_mismatch" in verdict["flag"],
                )


def signals(roots: list[str]) -> None:
    """Per recording of each dataset: the stuck-channel and spike checks on the recording as it
    is (a hit is a false alarm on simulated data) and with a channel stuck (at 0, or at its
    median) or one sample set to a spike of 4, 8 or 16 g on acc_x (5 samples of each motion
    recording drawn where it turns faster than 30 deg/s, one at a time)."""
    from aceval.data.recording_checks import acc_spikes, stuck_channel

    names = ["acc_x", "acc_y", "acc_z", "gyr_x", "gyr_y", "gyr_z"]
    rng = np.random.default_rng(0)
    for root in roots:
        dataset = load_dataset(root)
        counts = Counter()
        for row in dataset.recordings.itertuples():
            data = dataset.read_recording(row.path)
            static = dataset.test_kinds[row.test] == "static"
            sensors = [(data.acc, names[:3])] + ([] if static else [(data.gyr, names[3:])])
            found = any(stuck_channel(values, columns) for values, columns in sensors)
            _caught(counts, "clean: stuck", found)
            _caught(counts, "clean: spikes", acc_spikes(data.acc, data.gyr).any())
            kind = "static" if static else "motion"
            for values, columns in sensors:
                for k in range(3):
                    for level in ("0", "median"):
                        broken = values.copy()
                        broken[:, k] = 0.0 if level == "0" else np.median(values[:, k])
                        hit = stuck_channel(broken, columns) is not None
                        _caught(counts, f"{columns[k][:3]} stuck at {level} ({kind})", hit)
            if static:
                continue
            moving = np.flatnonzero(np.linalg.norm(data.gyr, axis=1) > np.radians(30.0))
            for at in rng.choice(moving, min(5, len(moving)), replace=False):
                for g in (4, 8, 16):
                    broken = data.acc.copy()
                    broken[at, 0] = g * 9.81
                    _caught(counts, f"a {g} g spike (motion)", acc_spikes(broken, data.gyr)[at])
        rows = [
            {"dataset": root, "case": name, "hits": f"{counts[name + ' caught']}/{counts[name]}"}
            for name in counts
            if not name.endswith(" caught")
        ]
        print(pd.DataFrame(rows).to_string(index=False), flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["clean", "defects", "signal-defects", "signals"])
    parser.add_argument("datasets", nargs="*")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repetitions", type=int, nargs="+", default=[3, 5])
    args = parser.parse_args()
    if args.mode == "signals":
        signals(args.datasets)
        return
    if args.mode == "clean":
        table = pd.DataFrame([r for root in args.datasets for r in clean(root)])
        print(table.to_string(index=False))
        return
    counts, found = Counter(), {}
    with tempfile.TemporaryDirectory() as tmp:
        for seed in args.seeds:
            for repetitions in args.repetitions:
                root = Path(tmp) / f"kong_{seed}_{repetitions}"
                subprocess.run(
                    [sys.executable, "-m", "aceval", "simulate", "kong", "--out", str(root),
                     "--format", "csv", "--subjects", "1", "--repetitions", str(repetitions),
                     "--seed", str(seed)],
                    check=True, capture_output=True,
                )  # fmt: skip
                if args.mode == "defects":
                    defects(root, counts, found)
                else:  # the checks of a sensor's signals only (their defects need no calibration)
                    dataset = load_dataset(root)
                    summaries, pairs = reduced_of(dataset)
                    checks = imu_checks(dataset, summaries, pairs)
                    for verdict in checks.values():
                        _caught(counts, "clean IMUs (no flag expected)", verdict["flag"] != "")
                    signal_defects(dataset, summaries, pairs, checks, counts)
    rows = [
        {"defect": name, "caught": f"{counts[name + ' caught']}/{counts[name]}",
         "flags": ", ".join(sorted(found.get(name, set())))}
        for name in counts if not name.endswith(" caught")
    ]  # fmt: skip
    print(pd.DataFrame(rows).to_string(index=False))


if __name__ == "__main__":
    main()
