"""``jaxroll reproduce``: the paper's examples against the full 3D model, with a timing table."""

from __future__ import annotations

import sys
import time
from pathlib import Path


from .options import choices, count, progress_args


def run(args) -> int:
    from .. import reproduce as rp

    over = {}
    if args.speeds is not None:
        over["n_speeds"] = args.speeds
    if args.loads is not None:
        over["n_loads"] = args.loads
    settings = rp.settings_for(args.quick, cases=args.cases, methods=args.methods, **over)
    if over or args.cases or args.methods:
        settings = rp.dataclasses.replace(settings, label=settings.label + " (with command-line selections)")
    t0 = time.perf_counter()
    rep = rp.reproduce(settings, args.out, progress=sys.stderr if args.progress else None)
    print(rp.timing_table(rep))
    print()
    print(rp.accuracy_table(rep))
    print(f"\nwrote {Path(args.out) / 'report.md'} and figures, results.csv, timing.csv "
          f"(wall time {time.perf_counter() - t0:.1f} s)")
    return 0


def add_parser(sub) -> None:
    """The ``reproduce`` subcommand on ``sub`` (argparse subparsers)."""
    from ..reproduce import ALL_METHODS, CASES

    r = sub.add_parser(
        "reproduce", help="the paper's examples: PD / PP / SP / direct against the full 3D model, timing table",
        description="Reproduce [ZG]'s examples (sphere R = 2 cm on H = 2, 5, 30 mm; R = 2000 m on H = 10 um; "
        "G0 = 3 MPa, tau = 0.25 s, f = 1; 23 speeds 1e-4..1 m/s x 15 loads 10..150 N, 0.2..2 kN for 10 um): "
        "R_r against V per load for each method against the full 3D model (period 0.2 m, 0.25 mm cells, "
        "500 terms), the relative error against V and P, and a timing table in the form of the paper's "
        "Table 1 measured on this machine (compile time apart). Writes PNG figures, report.md, results.csv "
        "and timing.csv into --out. Units SI (m, N, Pa, s). The full run is the paper's resolution (its "
        "measured time on 2 CPU cores is in benchmarks/README.md); --quick is a reduced run for a first look.")
    r.add_argument("--quick", action="store_true",
                   help="reduced run: 7 speeds 1e-3..1 m/s x 3 loads, an aperiodic 3D reference on 0.5 mm cells "
                   "(valid at every point of H = 2, 5, 30 mm), slices on 512 cells")
    r.add_argument("--out", default="jaxroll-reproduce", help="output folder (jaxroll-reproduce)")
    r.add_argument("--cases", type=choices("--cases", tuple(CASES)), default=None,
                   help=f"comma-separated subset of {','.join(CASES)} (default: all)")
    r.add_argument("--methods", type=choices("--methods", ALL_METHODS), default=None,
                   help=f"comma-separated subset of {','.join(ALL_METHODS)} (default: all; the full 3D "
                   "reference always runs)")
    r.add_argument("--speeds", type=count("--speeds"), default=None, help="number of log-spaced speeds (23; quick 7)")
    r.add_argument("--loads", type=count("--loads"), default=None, help="number of loads per case (15; quick 3)")
    progress_args(r)
    r.set_defaults(func=run)
