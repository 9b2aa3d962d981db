"""Issue 41's sweep (tests/sweep.py) run once: every case's observed outcome beside the one it
expects, and the counts by outcome. Not a speed benchmark; the counts in the issue's closing note
come from here.

    python benchmarks/bad_input_sweep.py [--only TEXT] [--workdir DIR]

Each case runs `python -m aceval` in a subprocess (the tests run most of them in their own
process), so an older checkout is swept by pointing ``PYTHONPATH`` at its ``src`` (the cases read
only the command line and the files).
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests import sweep  # noqa: E402
from tests.sweep import CASES, Workspace  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", default="", help="only the cases whose name contains this")
    parser.add_argument("--workdir", help="keep the cases' folders here (default: a temporary one)")
    args = parser.parse_args()
    sweep.IN_SUBPROCESSES = True
    with tempfile.TemporaryDirectory() as scratch:
        root = Path(args.workdir or scratch)
        workspace = Workspace(root)
        observed = Counter()
        for number, case in enumerate(CASES):
            if args.only not in case.name:
                continue
            folder = root / f"case{number:03d}"
            shutil.rmtree(folder, ignore_errors=True)
            folder.mkdir(parents=True)
            start = time.time()
            try:
                outcome = case.run(workspace, folder)
            except Exception as exc:  # the harness itself failed: shown, counted apart
                outcome = f"harness: {type(exc).__name__}: {exc}"[:80]
            observed[outcome if not outcome.startswith("harness") else "harness"] += 1
            mark = "" if outcome == case.expected else "  <-- expected " + case.expected
            print(f"{time.time() - start:6.1f}s  {outcome:14s} {case.group}: {case.name}{mark}",
                  flush=True)  # fmt: skip
        print("\nobserved:", dict(observed.most_common()))
        print("expected:", dict(Counter(c.expected for c in CASES if args.only in c.name)))


if __name__ == "__main__":
    main()
