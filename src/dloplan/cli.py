"""The ``dloplan`` command: parse, load, call one library function, write.

``main(argv=None) -> int`` returns the exit code: 0 success, 1 success with warnings, 2 failure
or bad input (a one-line error naming the problem, never a traceback, no output written).
"""

from __future__ import annotations

import argparse
import json
import sys
import time

from . import __version__
from .cable import CATALOGUE_NAMES, catalogue_cable

EXIT_OK, EXIT_WARNINGS, EXIT_FAILURE = 0, 1, 2


class Console:
    """Human-readable progress on stderr (silenced by -q); results on stdout."""

    def __init__(self, quiet: bool) -> None:
        self.quiet = quiet
        self.start = time.perf_counter()

    def stage(self, text: str) -> None:
        if not self.quiet:
            elapsed = time.perf_counter() - self.start
            print(f"[{elapsed:7.2f} s] {text}", file=sys.stderr, flush=True)


def _constants_table(n_links: int) -> str:
    cables = [catalogue_cable(name, n_links=n_links) for name in CATALOGUE_NAMES]
    keys = list(cables[0].constants())
    width = max(len(k) for k in keys)
    lines = [" " * width + "".join(f"{c.name:>13}" for c in cables)]
    for key in keys:
        lines.append(f"{key:<{width}}" + "".join(f"{c.constants()[key]:>13.4g}" for c in cables))
    return "\n".join(lines)


def _cmd_cables(args: argparse.Namespace) -> int:
    print(f"The thesis' cables (section 7.2), n = {args.links}, bending model 'rod':")
    print(_constants_table(args.links))
    return EXIT_OK


def _cmd_schema(args: argparse.Namespace) -> int:
    from .io.scenario import scenario_json_schema

    print(json.dumps(scenario_json_schema(), indent=2))
    return EXIT_OK


def _cmd_check(args: argparse.Namespace) -> int:
    from .io.scenario import load_scenario
    from .jobs import check_job

    console = Console(args.quiet)
    job = load_scenario(args.scenario)
    console.stage(f"loaded {args.scenario}: {job.cable.name or 'cable'}, n = {job.cable.n_links}")
    report = check_job(job)
    console.stage("checked start, target, target stability and obstacles")
    if args.json:
        print(json.dumps({"findings": [f.__dict__ for f in report.findings],
                          "errors": len(report.errors), "warnings": len(report.warnings)},
                         indent=2))
    else:
        for finding in report.findings:
            print(finding.line())
    if report.errors:
        return EXIT_FAILURE
    return EXIT_WARNINGS if report.warnings else EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="dloplan",
        description="Plan dual-arm robot manipulation of cables and hoses (deformable linear "
                    "objects).",
    )
    parser.add_argument("--version", action="version", version=f"dloplan {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    def command(name: str, func, help_: str) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=help_, description=help_)
        p.add_argument("-q", "--quiet", action="store_true", help="no progress lines")
        p.add_argument("--json", action="store_true", help="machine-readable summary on stdout")
        p.set_defaults(func=func)
        return p

    cables = command("cables", _cmd_cables, "print the model constants of the thesis' cables")
    cables.add_argument("--links", type=int, default=10, help="number of links n")
    command("schema", _cmd_schema, "print the JSON Schema of scenario files")
    check = command("check", _cmd_check, "check a scenario without planning (target stability, "
                    "clip reach, obstacles at start and target)")
    check.add_argument("scenario", help="scenario file (.yaml or .json)")
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ValueError, FileNotFoundError, OSError) as exc:
        print(f"dloplan: error: {exc}", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
