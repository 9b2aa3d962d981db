"""``aceval apply``: body-frame copies of a dataset's recordings, each IMU with the calibration
its decision chose (:mod:`aceval.apply.choice`: which calibration; :mod:`aceval.apply.copies`:
the copies).
"""

from aceval.apply.choice import (
    CHOICE_COLUMNS,
    DECISION_COLUMNS,
    KEY,
    ROTATION_TOLERANCE,
    UNTRUSTED,
    VERDICT_KINDS,
    ApplyError,
    check_rotations,
    choose,
    chosen_calibrations,
    decided_calibrations,
    read_calibrations,
    read_decision,
)
from aceval.apply.copies import (
    APPLIED_SHEET,
    FINGERPRINT,
    apply_calibrations,
    body_frame_table,
    check_not_applied,
    check_source,
    fingerprints,
    recordings_fingerprint,
    write_body_frame,
)

__all__ = [
    "APPLIED_SHEET",
    "CHOICE_COLUMNS",
    "DECISION_COLUMNS",
    "FINGERPRINT",
    "KEY",
    "ROTATION_TOLERANCE",
    "UNTRUSTED",
    "VERDICT_KINDS",
    "ApplyError",
    "apply_calibrations",
    "body_frame_table",
    "check_not_applied",
    "check_rotations",
    "check_source",
    "choose",
    "chosen_calibrations",
    "decided_calibrations",
    "fingerprints",
    "read_calibrations",
    "read_decision",
    "recordings_fingerprint",
    "write_body_frame",
]
