"""Is the right axis's sign verified by the data, and is a wrong sign caught? (not a speed
benchmark: config/README.md's table of checks quotes its numbers)

    python benchmarks/check_right_axis_sign.py resources/neura resources/hugadb ... [--walking-only]

Each argument is a dataset folder whose declared right axes are right. Every calibration from all
repetitions (all methods) is computed as `aceval calibrate --subsets full` does, twice: as
declared (``clean``), and with every IMU's ``right_axis`` negated (``flipped``: every calibration
180 deg off about the vertical, the same flags and cones otherwise). Per dataset it counts IMUs
(subject, set, IMU):

* ``verified``: an unflagged calibration of it has ``right_axis_sign_verified`` (before that
  column: where the direction checks judged it, ``first_phase_agreement`` above 0.5 and y within
  60 deg of the declared axis);
* ``false alarm``: flagged ``backward`` on clean data;
* ``caught``: flipped, every calibration that was unflagged on clean data is flagged; ``silent``:
  one stays unflagged (a decision could say "use" 180 deg off), of which ``unverified`` ones carry
  the fact (``right_axis_sign_verified`` False).

``--walking-only``: the dataset cut to its static tests and walking (``first_phase`` gait), every
IMU calibrated by walking: the walking cues alone (the feet's pitch, the trunk's pendulum, the
shank's swing), as a lab with only walking records.
"""

from __future__ import annotations

import argparse
import shutil
import tempfile
from pathlib import Path

import pandas as pd
from check_rates import calibrated

from aceval.calibrate.table import has_flag, unflagged
from aceval.data.dataset import load_dataset

KEY = ["subject", "sensor_set", "imu"]
CALIBRATION = [*KEY, "test", "method", "repetitions"]
NEGATED = {"+": "-", "-": "+"}


def copy_of(root: Path, out: Path, flip: bool, walking_only: bool) -> Path:
    """``root``'s sheets in ``out`` (its recordings linked), right axes negated (``flip``), cut
    to static tests and walking (``walking_only``)."""
    out.mkdir()
    for item in root.iterdir():
        if item.is_dir():
            (out / item.name).symlink_to(item.resolve())
        else:
            shutil.copy(item, out / item.name)
    imus = pd.read_csv(out / "imus.tsv", sep="\t", dtype=str, keep_default_na=False)
    if flip:
        imus["right_axis"] = [
            NEGATED[a[0]] + a[1:] if a[0] in NEGATED else "-" + a for a in imus["right_axis"]
        ]
    imus.to_csv(out / "imus.tsv", sep="\t", index=False)
    if walking_only:
        dataset = load_dataset(root)
        gait = [t for t, p in dataset.first_phases.items() if p == "gait"]
        keep = set(gait) | set(dataset.static_tests())
        recordings = pd.read_csv(out / "recordings.tsv", sep="\t", dtype=str)
        recordings = recordings[recordings["test"].isin(keep)]
        recordings.to_csv(out / "recordings.tsv", sep="\t", index=False)
        walked = recordings.loc[recordings["test"].isin(gait), "imu"].unique()
        pairs = [f"{t}\t{i}\n" for t in gait for i in walked]
        (out / "calibrates.tsv").write_text("test\timu\n" + "".join(pairs))
    return out


def verified(calibrations: pd.DataFrame) -> pd.Series:
    """Each calibration's verified sign (the column, or before it the judged direction)."""
    if "right_axis_sign_verified" in calibrations:
        return calibrations["right_axis_sign_verified"].astype(bool)
    if "first_phase_agreement" not in calibrations:  # Ricci's design had no direction check
        return pd.Series(False, calibrations.index)
    judged = calibrations["first_phase_agreement"] > 0.5
    return judged & (calibrations["right_axis_angle_deg"] <= 60.0)


def outcome(root: Path, walking_only: bool) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        runs = {
            name: calibrated(
                load_dataset(copy_of(root, Path(tmp) / name, name == "flipped", walking_only))
            )
            for name in ("clean", "flipped")
        }
    clean, flipped = runs["clean"], runs["flipped"]
    imus = clean.groupby(KEY).ngroups
    good = clean[unflagged(clean)]
    sure = good[verified(good)].groupby(KEY).ngroups
    unsure = good.groupby(KEY).filter(lambda imu: not verified(imu).any())
    segments = unsure.drop_duplicates(KEY)["segment"].value_counts()
    alarms = clean[has_flag(clean["flag"], "backward")].groupby(KEY).ngroups
    after = good[CALIBRATION].merge(flipped, on=CALIBRATION)  # the ones a decision could pick
    silent = after[unflagged(after)]
    return {
        "dataset": root.name + (" (walking only)" if walking_only else ""),
        "IMUs": imus,
        "verified": f"{sure}/{imus}",
        "false alarm": f"{alarms}/{imus}",
        "caught": f"{good.groupby(KEY).ngroups - silent.groupby(KEY).ngroups}/"
        f"{good.groupby(KEY).ngroups}",
        "silent": silent.groupby(KEY).ngroups,
        "silent unverified": silent[~verified(silent)].groupby(KEY).ngroups,
        "flipped verified": flipped[verified(flipped)].groupby(KEY).ngroups,
        "not verified": ", ".join(f"{segment} {n}" for segment, n in segments.items()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("datasets", nargs="+")
    parser.add_argument("--walking-only", action="store_true")
    args = parser.parse_args()
    rows = [outcome(Path(root), args.walking_only) for root in args.datasets]
    pd.set_option("display.width", 200)
    print(pd.DataFrame(rows).to_string(index=False))


if __name__ == "__main__":
    main()
