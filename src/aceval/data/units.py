"""The subjects of each calibration job (config ``subjects_per_job``): one rule for the
workflow, which names each job's outputs, and for the job that writes them. Imports nothing
heavy: the workflow reads it at every start.
"""

from __future__ import annotations

#: subjects of each simulated protocol unless the configuration says (the papers' designs: Kong's
#: five subjects, Ricci's forty children, one box)
SIMULATED_SUBJECTS = {"kong": 5, "ricci": 40, "box": 1}


def subject_batches(subjects: list[str], size: int = 1) -> dict[str, list[str]]:
    """``{unit: [subject, ...]}``: ``subjects`` (in subjects.tsv order) in batches of ``size``;
    a batch of one subject is named after it, others ``_batch1``, ``_batch2``, ... (zero-padded
    to the same width).
    """
    if size == 1:
        return {name: [name] for name in subjects}
    chunks = [subjects[k : k + size] for k in range(0, len(subjects), size)]
    width = len(str(len(chunks)))
    return {f"_batch{k:0{width}d}": chunk for k, chunk in enumerate(chunks, start=1)}
