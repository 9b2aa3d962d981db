"""Mutation-testing benchmark (issue 44): how many of mutmut's mutants of the core packages the
quick tier (``pytest -m "not slow"``) kills, per package, and which survive.

Run from the repository root, in a virtual environment with the ``mutation`` extra
(``pip install -c requirements.lock -e ".[test,mutation]"``; the configuration is
``[tool.mutmut]`` in pyproject.toml). On demand, not in CI: under ``nice -n 10`` with two
workers it takes tens of minutes (benchmarks/README.md, section Mutation testing)::

    nice -n 10 python benchmarks/mutation.py --max-children 2

The small packages (report/claims, evaluation/verdicts, evaluation/stats, data/rotations,
data/safety: 2,191 mutants)
are run whole; methods and signals (about 4,300 and 1,900, reached by slower tests), and the
decision, apply and report modules (about 5,300: evaluation's decision modules, flag_value and
peer_gates, apply, report's decisions, summary and kong2016) on a fixed
sample of ``1 / --sample`` (default 1 in 20) of their mutants, chosen by a hash of the mutant's
name: the same mutants each time, before and after a change of the tests, and a sample of 1 in
20 is part of the sample of 1 in 10. Mutants with a result in
``mutants/`` are not run again unless ``--fresh``. ``--report-only`` prints the table and the
survivors from the results there.

``--before CHECKOUT`` measures a change of the tests against an earlier run on the same source
(CHECKOUT/mutants, e.g. a copy of main): its killed and timed-out mutants keep their result
without running again (the tests after the change include every test before it), and only its
survivors and unreached mutants are run here.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import subprocess
import sys
import time
from pathlib import Path

#: the packages measured, and whether each is run whole (True) or sampled
PACKAGES = {
    "aceval.report.claims": True,
    "aceval.evaluation.verdicts": True,
    "aceval.evaluation.stats": True,
    "aceval.data.rotations": True,
    "aceval.data.safety": True,
    "aceval.methods": False,
    "aceval.signals": False,
    "aceval.evaluation.decision": False,
    "aceval.evaluation.decision_rules": False,
    "aceval.evaluation.decision_evidence": False,
    "aceval.evaluation.flag_value": False,
    "aceval.evaluation.peer_gates": False,
    "aceval.apply": False,
    "aceval.report.decisions": False,
    "aceval.report.summary": False,
    "aceval.report.kong2016": False,
}
KILLED, SURVIVED, TIMEOUT, NO_TESTS = "killed", "survived", "timeout", "no tests"
#: mutmut's exit codes (mutmut.stats.status_by_exit_code)
STATUS = {
    1: KILLED,
    3: KILLED,
    0: SURVIVED,
    5: NO_TESTS,
    33: NO_TESTS,
    36: TIMEOUT,
    -24: TIMEOUT,
    24: TIMEOUT,
    152: TIMEOUT,
    255: TIMEOUT,
}
#: a mutant that makes a quick test loop: its test run is stopped and counts as detected
FIRST = "aceval.data.rotations.x_axis_vector__mutmut_1"


def detected(code) -> bool:
    """Killed or timed out."""
    return STATUS.get(code) in (KILLED, TIMEOUT)


def results(root: Path = Path("mutants")) -> dict[str, int | None]:
    """Every generated mutant's name and exit code (None: not run yet)."""
    found = {}
    for meta in (root / "src").rglob("*.py.meta"):
        found |= json.loads(meta.read_text())["exit_code_by_key"]
    return found


def package(name: str) -> str | None:
    """The measured package of a mutant, or None."""
    return next((p for p in PACKAGES if name.startswith(p + ".")), None)


def chosen(name: str, sample: int) -> bool:
    """Whether a mutant is measured: every one of a whole package, else 1 in ``sample``."""
    whole = PACKAGES[package(name)]
    return whole or int(hashlib.sha1(name.encode()).hexdigest(), 16) % sample == 0


def usable_stats(path: Path = Path("mutants") / "mutmut-stats.json") -> None:
    """Remove mutmut's record of which tests reach which function when it is empty (a stopped run
    can leave it so; mutmut would then report every mutant as reached by no test)."""
    if path.exists() and not json.loads(path.read_text())["tests_by_mangled_function_name"]:
        path.unlink()


def mutmut(*args: str, max_children: int) -> None:
    command = ["mutmut", "run", "--max-children", str(max_children), *args]
    subprocess.run(command, check=False)


def table(codes: dict[str, int | None]) -> tuple[str, list[str]]:
    """The score per package and the surviving and timed-out mutants."""
    lines = [
        "| package | mutants | run | killed | timeout | survived | no test | score (95 % CI) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    survivors, totals = [], {KILLED: 0, TIMEOUT: 0, SURVIVED: 0, NO_TESTS: 0, "n": 0, "all": 0}
    for name, whole in PACKAGES.items():
        mine = {k: v for k, v in codes.items() if package(k) == name}
        measured = {k: STATUS.get(v, "other") for k, v in mine.items() if v is not None}
        count = {
            s: sum(1 for v in measured.values() if v == s) for s in totals if s not in ("n", "all")
        }
        survivors += sorted(k for k, v in measured.items() if v in (SURVIVED, TIMEOUT))
        for s in count:
            totals[s] += count[s]
        totals["n"] += len(measured)
        totals["all"] += len(mine)
        lines.append(_row(name + ("" if whole else " (sample)"), len(mine), len(measured), count))
    lines.append(_row("all", totals["all"], totals["n"], totals))
    return "\n".join(lines), survivors


def _row(name: str, n_all: int, n_measured: int, count: dict) -> str:
    """A package's row: the score is killed / (killed + survived). A timeout (its tests ran 15x
    their clean time, mutmut's default) is counted as neither, and listed with the survivors:
    mutmut calls it caught, but a slow fixture can stop a mutant that would survive."""
    found = count[KILLED]
    ran = found + count[SURVIVED]
    score = "-"
    if ran:
        share = found / ran
        half = 1.96 * math.sqrt(share * (1 - share) / ran)  # Wald; the sample's, not the code's
        score = f"{100 * share:.1f} % ({100 * max(share - half, 0):.0f}-{100 * min(share + half, 1):.0f})"
    return (
        f"| {name} | {n_all} | {n_measured} | {count[KILLED]} | {count[TIMEOUT]} | "
        f"{count[SURVIVED]} | {count[NO_TESTS]} | {score} |"
    )


def change(name: str) -> str:
    """The mutant's change, one line per side (``mutmut show``)."""
    shown = subprocess.run(["mutmut", "show", name], capture_output=True, text=True).stdout
    lines = [line[1:].strip() for line in shown.splitlines() if line[:1] in "+-"]
    return " -> ".join(line for line in lines if not line.startswith(("++", "--")))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sample", type=int, default=20, help="1 in N of methods and signals")
    parser.add_argument("--max-children", type=int, default=2)
    parser.add_argument("--fresh", action="store_true", help="run measured mutants again")
    parser.add_argument("--again", action="store_true", help="run the survivors and timeouts again")
    parser.add_argument("--report-only", action="store_true")
    parser.add_argument("--before", type=Path, help="a checkout with an earlier run's mutants/")
    parser.add_argument("--survivors-only", action="store_true", help="only --before's survivors")
    parser.add_argument("--packages", nargs="+", choices=PACKAGES, default=list(PACKAGES))
    parser.add_argument("--changes", action="store_true", help="print each survivor's change")
    args = parser.parse_args()
    before = results(args.before / "mutants") if args.before else {}
    start = time.perf_counter()
    if not args.report_only:
        if not results():  # mutmut generates every mutant before it runs the ones named
            mutmut(FIRST, max_children=args.max_children)
        usable_stats()
        codes = results()
        todo = [  # those not run, and those no test reached (again: cheap, and tests change)
            name
            for name, code in codes.items()
            if package(name) in args.packages
            and chosen(name, args.sample)
            and (
                args.fresh
                or STATUS.get(code, NO_TESTS) == NO_TESTS
                or (args.again and STATUS.get(code) != KILLED)
            )
            and not detected(before.get(name))
            and (not args.survivors_only or STATUS.get(before.get(name)) == SURVIVED)
        ]
        if todo:
            mutmut(*todo, max_children=args.max_children)
    codes = {k: v for k, v in results().items() if package(k) and chosen(k, args.sample)}
    codes |= {k: v for k, v in before.items() if k in codes and detected(v)}
    text, survivors = table(codes)
    print(text)
    print(f"\n{len(survivors)} surviving or timed-out mutant(s) (`mutmut show NAME`):")
    for name in survivors:
        status = STATUS[codes[name]]
        print(f"{name} ({status}): `{change(name)}`" if args.changes else f"{name} ({status})")
    print(f"\nwall time {time.perf_counter() - start:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
