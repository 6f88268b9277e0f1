"""``jaxroll datasets``: list the example data shipped with jaxroll, or copy files into a folder."""

from __future__ import annotations

import shutil
from pathlib import Path


def run(args) -> int:
    from ... import datasets

    if not args.names:
        width = max(map(len, datasets.DATASETS))
        for name, (what, licence) in datasets.DATASETS.items():
            print(f"{name:<{width}}  {what}; licence {licence}")
        return 0
    for name in args.names:
        src = datasets.path(name)  # ValueError (one line) for an unknown name
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, out / name)
        print(f"wrote {out / name}")
    return 0


def add_parser(sub) -> None:
    """The ``datasets`` subcommand on ``sub`` (argparse subparsers)."""
    d = sub.add_parser("datasets", help="list the shipped example data, or copy files into a folder")
    d.add_argument("names", nargs="*", metavar="NAME", help="files to copy (e.g. rolling_example.csv); none: list them")
    d.add_argument("--out", default=".", help="folder to copy into (default: the current folder)")
    d.set_defaults(func=run)
