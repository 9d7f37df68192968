"""`twmr compare`, registered through the `twmr.commands` entry point; the analysis itself
(`twmr.components.compare`) loads only when the command runs."""
from __future__ import annotations

import argparse
from pathlib import Path


def register(subparsers: argparse._SubParsersAction, common: argparse.ArgumentParser) -> None:
    """Add `twmr compare` to the command line."""
    cp = subparsers.add_parser("compare", parents=[common],
                               help="run scenarios and print Table III metrics side by side")
    cp.add_argument("scenarios", nargs="+")
    cp.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    cp.add_argument("--out", help="directory for the comparison figures")
    cp.add_argument("--set", action="append", default=[], metavar="COMP.PARAM=VALUE",
                    help="override a parameter in every scenario (repeatable)")
    cp.set_defaults(fn=_compare)


def _compare(args: argparse.Namespace) -> int:
    from twmr.components.compare import compare

    return compare([Path(s) for s in args.scenarios], as_json=args.json,
                   out=Path(args.out) if args.out else None, overrides=args.set)
