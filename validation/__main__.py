"""``python -m validation``: run the validation campaign and regenerate the report folder.

Examples (from the repository root)::

    python -m validation                      # full campaign into reports/
    python -m validation --quick              # CI size, a few minutes on 2 cores
    python -m validation --only integrators   # one study; the report keeps the others' data
    python -m validation --jobs 2             # accuracy-only cases on 2 local processes
    python -m validation --scheduler tcp://10.0.0.5:8786   # on a Dask cluster
    python -m validation --fresh --only long_runs          # forget stored results first

``main(argv)`` is the entry point the ``thesis-rbd validate`` command calls.
"""

from __future__ import annotations

import argparse
import sys

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m validation",
        description="Run the validation campaign (accuracy, stability, performance against "
        "peers) and regenerate report.md, report.html, figures/ and data/. Finished cases "
        "are kept in DATA/cases/ and not run again: an interrupted campaign resumes.",
    )
    size = parser.add_mutually_exclusive_group()
    size.add_argument("--quick", action="store_true", help="smaller sweeps (CI: < 5 min)")
    size.add_argument(
        "--tiny", action="store_true", help="smallest sweeps (the test suite's smoke run)"
    )
    parser.add_argument("--only", nargs="+", metavar="STUDY", help="run only these studies")
    parser.add_argument(
        "--scheduler",
        metavar="tcp://HOST:PORT",
        help="run the cases on this Dask distributed scheduler instead of locally",
    )
    parser.add_argument("--out", default="reports", help="report folder (default: reports)")
    parser.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="local processes for accuracy-only cases (default 1); timing cases always run "
        "one at a time",
    )
    parser.add_argument(
        "--fresh", action="store_true", help="forget stored results of the selected studies"
    )
    parser.add_argument("--note", help="a sentence on the run's conditions, for the report")
    parser.add_argument("--list", action="store_true", help="list the studies and exit")
    return parser


def main(argv=None) -> int:
    """Run the campaign with command-line arguments ``argv``; return the exit status."""
    args = _parser().parse_args(argv)
    from validation.campaign import run_campaign
    from validation.studies import STUDIES

    if args.list:
        for name, study in STUDIES.items():
            print(f"{name}: {study.TITLE}")
        return 0
    unknown = [name for name in args.only or [] if name not in STUDIES]
    if unknown:
        print(f"unknown study {', '.join(unknown)}; known: {', '.join(STUDIES)}", file=sys.stderr)
        return 2
    if args.jobs < 1:
        print("--jobs must be >= 1", file=sys.stderr)
        return 2
    scale = "quick" if args.quick else "tiny" if args.tiny else "full"
    run_campaign(
        out=args.out,
        scale=scale,
        only=args.only,
        jobs=args.jobs,
        scheduler=args.scheduler,
        fresh=args.fresh,
        note=args.note,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
