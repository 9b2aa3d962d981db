"""The rules of the decision (beyond both papers; :mod:`aceval.evaluation.decision`): the lab's
tolerance, which flags take a calibration out of the choice, and the verdict, a small type.

* **The tolerance** ``T`` (``tolerance_deg``): the heading accuracy the lab needs.
  :data:`DEFAULT_TOLERANCE_DEG` is 5 deg: a flexion ``phi`` about an axis turned by ``theta``
  about the body vertical reads, in flexion-ab/adduction-rotation (Cardan) angles, about
  ``theta * sin(phi)`` of ab/adduction (the cross-talk of a misaligned flexion axis: Piazza &
  Cavanagh 2000, J Biomech 33:1029); at the knee's 60 deg of flexion in swing (Perry & Burnfield
  2010, *Gait Analysis*, Ch. 5) 5 deg of heading error gives 4.3 deg of false varus-valgus, under
  the 5 deg at which a joint-angle error "should raise concern and may be large enough to mislead
  clinical interpretation" (McGinley et al. 2009, Gait Posture 29:360; 6 deg would give 5.2).
* **The flags** (:func:`removes`): a check that caught a defect of the data or its labels
  (:data:`DEFECT_FLAGS`) always takes the calibration out; a flag whose flagged calibrations are
  not worse than the unflagged ones where a truth measured it (:data:`ADVISORY_FLAGS`, table
  ``flag_value`` of the committed datasets with a truth; ``tests/test_decision_rules.py`` checks
  the list against them) leaves it in the choice and is shown beside it; every other flag takes
  it out.
* **The verdict** (:class:`Verdict`, :func:`verdict`): ``use`` (its cone within T, the other
  methods of its test within T of each other, and at least two calibrations, its own and one
  more, within T of it), ``use with care`` (its cone within 2T, and: the cone beyond T, the
  methods more than T apart, a single calibration behind it, or the right axis's sign not
  verified by the data: which, with the numbers), ``not within tolerance`` (the best available,
  its numbers and why), ``no trustworthy calibration`` (why).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from aceval.calibrate.table import COMPARISON_FLAGS, flag_sets

#: the heading accuracy (deg) a lab needs unless it says otherwise (module docstring)
DEFAULT_TOLERANCE_DEG = 5.0

USE = "use"
CARE = "use with care"
NOT_WITHIN = "not within tolerance"
NONE = "no trustworthy calibration"
#: the four verdicts, from the best
VERDICT_KINDS = (USE, CARE, NOT_WITHIN, NONE)
#: the reason when the right axis's sign could not be checked on the recordings
SIGN_UNVERIFIED = "right-axis sign not verified by the data"

#: checks that caught a defect of the data or its labels (config/README.md, their catch rates): a
#: calibration carrying one is never chosen, whatever the evidence on clean data says
DEFECT_FLAGS = (
    "backward",
    "right_axis_mismatch",
    "gyro_acc_inconsistent",
    "static_not_standing",
    "unexpected_motion_pattern",
    "not_moving_with_others",
    "opposite_side_timing",
    "gyro_implausible",
    "gyro_bias",
    "static_disagree",
    "acc_sign_mismatch",
    "not_applicable",
)
#: flags that leave a calibration in the choice: the comparison flags (the decision judges the
#: methods' spread itself) and the flags whose flagged calibrations lie no farther from the truth
#: than the unflagged ones where a truth measured them (kong_powered: ``weight_switch`` 2.4 against
#: 2.7 deg, 29 flagged; ``step_frequency_disagrees`` 2.8 against 3.3, 12 flagged)
ADVISORY_FLAGS = (*COMPARISON_FLAGS, "step_frequency_disagrees", "weight_switch")


def removes(flags: pd.Series) -> pd.Series:
    """True for the rows (a ``flag`` column) carrying a flag that takes them out of the choice
    (any but :data:`ADVISORY_FLAGS`).
    """
    advisory = frozenset(ADVISORY_FLAGS)
    return flag_sets(flags).map(lambda names: not names <= advisory).astype(bool)


def advisory(flags: pd.Series) -> pd.Series:
    """Each row's advisory flags but the comparison flags (which the decision reads as the
    methods' spread), ';'-joined ('' where none).
    """
    shown = set(ADVISORY_FLAGS) - set(COMPARISON_FLAGS)
    return flag_sets(flags).map(lambda names: ";".join(sorted(names & shown)))


@dataclass(frozen=True)
class Verdict:
    """A decision's verdict: ``kind`` (one of :data:`VERDICT_KINDS`), the ``reasons`` behind it
    (each with its numbers) and those ``numbers`` by name (deg).
    """

    kind: str
    reasons: tuple[str, ...] = ()
    numbers: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self):
        if self.kind not in VERDICT_KINDS:
            raise ValueError(f"no verdict {self.kind!r}; the verdicts are {VERDICT_KINDS}")

    @property
    def text(self) -> str:
        """'kind' or 'kind: reason; reason' (the table's ``verdict``)."""
        return f"{self.kind}: {'; '.join(self.reasons)}" if self.reasons else self.kind


@dataclass(frozen=True)
class Evidence:
    """What the verdict of a chosen calibration reads (deg; NaN where there is none): its
    ``cone``, the largest angle between two methods' calibrations of its test (``methods_range``;
    ``disagreeing``: those two methods), ``n_behind`` (the calibrations within T of
    it, its own included), whether the right axis's sign was verified (``sign_verified``) and
    whether its cone is the recording's own (``measured``: a peer's is not).
    """

    cone: float
    methods_range: float
    disagreeing: str
    n_behind: int
    sign_verified: bool = True
    measured: bool = True


def verdict(evidence: Evidence, tolerance: float) -> Verdict:
    """The verdict of a chosen calibration (module docstring) at the tolerance ``tolerance``
    (deg).
    """
    e, t = evidence, tolerance
    numbers = {"cone_deg": e.cone, "methods_range_deg": e.methods_range, "tolerance_deg": t}
    care = []
    if e.methods_range > t:
        care.append(
            f"methods disagree: up to {e.methods_range:.1f} deg apart > T {t:g} ({e.disagreeing})"
        )
    if not e.measured:
        why = "its uncertainty is not measured on the recording"
        return Verdict(NOT_WITHIN, (why, *care), numbers)
    if not e.cone <= 2 * t:
        why = f"uncertainty {e.cone:.1f} deg > 2T {2 * t:g}"
        return Verdict(NOT_WITHIN, (why, *care), numbers)
    if e.cone > t:
        care.insert(0, f"uncertainty {e.cone:.1f} deg > T {t:g}")
    if e.n_behind < 2:
        care.append(f"no other calibration within T {t:g} of it")
    if not e.sign_verified:
        care.append(SIGN_UNVERIFIED)
    return Verdict(CARE if care else USE, tuple(care), numbers)


def none_verdict(why: str) -> Verdict:
    """``no trustworthy calibration: why``."""
    return Verdict(NONE, (why,))


def sign_verified(imu: pd.DataFrame) -> bool:
    """False where a calibration of the IMU says the data could not verify its right axis's sign
    (column ``right_axis_sign_verified`` False); True without the column or a False in it.
    """
    if "right_axis_sign_verified" not in imu:
        return True
    values = imu["right_axis_sign_verified"].astype(object)
    return not values.map(lambda v: str(v).strip().lower() in ("false", "0", "0.0")).any()


def cone_within(cone: pd.Series, tolerance: float) -> np.ndarray:
    """True where a cone (deg) is within the tolerance (NaN: not)."""
    return (cone.to_numpy(float) <= tolerance) & np.isfinite(cone.to_numpy(float))
