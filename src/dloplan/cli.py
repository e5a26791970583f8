"""The ``dloplan`` command: parse, load, call one library function, write.

``main(argv=None) -> int`` returns the exit code: 0 success, 1 warnings only, 2 failure or bad
input (a one-line error naming the problem, never a traceback).
"""

from __future__ import annotations

import argparse
import sys

from .cable import CATALOGUE_NAMES, catalogue_cable

EXIT_OK, EXIT_WARNINGS, EXIT_FAILURE = 0, 1, 2


def _constants_table(n_links: int) -> str:
    cables = [catalogue_cable(name, n_links=n_links) for name in CATALOGUE_NAMES]
    keys = list(cables[0].constants())
    width = max(len(k) for k in keys)
    lines = [" " * width + "".join(f"{c.name:>13}" for c in cables)]
    for key in keys:
        lines.append(f"{key:<{width}}" + "".join(f"{c.constants()[key]:>13.4g}" for c in cables))
    return "\n".join(lines)


def _cmd_demo(args: argparse.Namespace) -> int:
    print(f"The thesis' cables (section 7.2), n = {args.links}, bending model 'rod':")
    print(_constants_table(args.links))
    return EXIT_OK


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="dloplan", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="run the embedded default job")
    demo.add_argument("-o", "--output", default="out/demo", help="output folder")
    demo.add_argument("--links", type=int, default=10, help="number of links n")
    demo.set_defaults(func=_cmd_demo)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except ValueError as exc:
        print(f"dloplan: error: {exc}", file=sys.stderr)
        return EXIT_FAILURE


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
