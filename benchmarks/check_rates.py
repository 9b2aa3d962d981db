"""False-alarm and catch rates of aceval's calibration checks (not a speed benchmark: the rates in
config/README.md's table of checks come from here).

    python benchmarks/check_rates.py clean resources/kong_sim resources/box_sim resources/neura ...
    python benchmarks/check_rates.py defects [--seeds 1 2] [--repetitions 3 5]

``clean``: each argument is a dataset folder (the workflow writes the committed ones under
resources/). Every calibration from all repetitions (all methods) is computed as `aceval
calibrate --subsets full` does, and each flag is counted: on how many IMUs (subject, set, IMU) it
fires on at least one calibration, and on how many calibrations. On the simulated datasets every
flag is a false alarm; on the real ones a flag may be a real defect (the count is what a user sees).

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
* ``clean``: the unbroken copy, every IMU of both sets (a flag is a false alarm).
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
    return pd.concat(
        [reduce_recordings(dataset, s).summaries for s in dataset.subjects.index],
        ignore_index=True,
    )


def flag_names(flags: pd.Series) -> pd.Series:
    return flags.fillna("").astype(str).str.split(";").map(lambda f: [n for n in f if n])


def clean(root: str) -> list[dict]:
    """One row per flag that fires on ``root``: IMUs and calibrations it fires on."""
    dataset = load_dataset(root)
    calibrations, _ = calibrate(dataset, summaries_of(dataset), "full", retest_k=None)
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
            calibrations, _ = calibrate(dataset, summaries_of(dataset), "full", retest_k=None)
            for imu in (a, b):
                caught, names = _all_flagged(calibrations, imu, sensor_set)
                counts[f"exchanged {a}-{b}"] += 1
                counts[f"exchanged {a}-{b} caught"] += caught
                found.setdefault(f"exchanged {a}-{b}", set()).update(names)
    dataset.recordings = original
    summaries = summaries_of(dataset)
    clean_checks = imu_checks(dataset, summaries)
    calibrations, _ = calibrate(dataset, summaries, "full", retest_k=None)
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
    for imu in dataset.imus.loc["frontal"].index:  # acc_x and acc_y swapped (a mirrored frame)
        _rewritten(
            root, original, imu, None, lambda t: t.assign(acc_x=t["acc_y"], acc_y=t["acc_x"])
        )
        try:
            calibrations, _ = calibrate(dataset, summaries_of(dataset), "full", retest_k=None)
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


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mode", choices=["clean", "defects"])
    parser.add_argument("datasets", nargs="*")
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--repetitions", type=int, nargs="+", default=[3, 5])
    args = parser.parse_args()
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
                defects(root, counts, found)
    rows = [
        {"defect": name, "caught": f"{counts[name + ' caught']}/{counts[name]}",
         "flags": ", ".join(sorted(found.get(name, set())))}
        for name in counts if not name.endswith(" caught")
    ]  # fmt: skip
    print(pd.DataFrame(rows).to_string(index=False))


if __name__ == "__main__":
    main()
