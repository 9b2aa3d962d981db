"""Command line: ``aceval simulate|validate ...`` (also ``python -m aceval``)."""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path


def _simulate(args) -> int:
    from .simulate import GENERATORS, SimOptions

    out = Path(args.out)
    if out.exists() and any(out.iterdir()):
        if not args.force:
            print(f"aceval simulate: {out} exists and is not empty (use --force to replace it)", file=sys.stderr)
            return 2
    options = SimOptions(
        noise=not args.no_noise, offplane=0.0 if args.no_offplane else 1.0,
        wobble=0.0 if args.no_wobble else 1.0,
    )
    kwargs = {"options": options}
    if args.subjects is not None:
        kwargs["n_subjects"] = args.subjects
    # write into a temporary sibling and move it into place: a failed run leaves nothing behind
    out.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{out.name}.", dir=out.parent))
    try:
        GENERATORS[args.protocol](staging, args.seed, **kwargs)
        if out.exists():
            shutil.rmtree(out)
        staging.rename(out)
    finally:
        if staging.exists():
            shutil.rmtree(staging)
    print(f"wrote {out}", file=sys.stderr)
    return 0


def _validate(args) -> int:
    from .dataset import validate

    _, report = validate(args.dataset)
    print(report.format())
    return 0 if report.ok else 1


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="aceval", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)

    simulate = commands.add_parser("simulate", help="write a SIMULATED dataset in the contract, with ground truth")
    simulate.add_argument("protocol", choices=["kong", "ricci", "box"])
    simulate.add_argument("--out", required=True, help="output folder (created)")
    simulate.add_argument("--seed", type=int, default=0)
    simulate.add_argument("--subjects", type=int, help="number of subjects (default: the paper's)")
    simulate.add_argument("--no-noise", action="store_true", help="ideal sensors: no noise, bias or saturation")
    simulate.add_argument("--no-offplane", action="store_true", help="pure sagittal-plane motion")
    simulate.add_argument("--no-wobble", action="store_true", help="no soft-tissue wobble")
    simulate.add_argument("--force", action="store_true", help="replace a non-empty output folder")
    simulate.set_defaults(run=_simulate)

    validate = commands.add_parser("validate", help="check a dataset folder against the contract")
    validate.add_argument("dataset")
    validate.set_defaults(run=_validate)

    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
