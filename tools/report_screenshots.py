"""Screenshots of HTML reports in headless Chromium (the figures of docs/figures/report_*.png).

    python tools/report_screenshots.py out/demo/report.html docs/figures/report_demo.png \
        --at 0.5 --view iso

``--at`` is the moment along the report's timeline (0 start, 1 end), ``--view`` one of the
viewer's views (iso, front, side, top, job). Uses the tests' Chromium (tests/browser.py:
software WebGL, a fresh profile); prints the file written and the page's console messages.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from browser import CHROMIUM, Browser  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("report", type=Path)
    parser.add_argument("output", type=Path)
    parser.add_argument("--at", type=float, default=0.5, help="moment along the timeline (0..1)")
    parser.add_argument("--view", default="iso", choices=("iso", "front", "side", "top", "job"))
    parser.add_argument("--size", default="1280x900", help="window size WIDTHxHEIGHT [px]")
    args = parser.parse_args()
    if CHROMIUM is None:
        parser.error("Chromium is not installed (make browser)")
    page = args.report.read_text()
    data = json.loads(page.split('id="plan-data" type="application/json">', 1)[1]
                      .split("</script>", 1)[0].replace("<\\/", "</"))
    times = data["timeline"]["times"]
    moment = times[0] + args.at * (times[-1] - times[0])
    width, height = (int(v) for v in args.size.split("x"))
    with tempfile.TemporaryDirectory() as profile, Browser(Path(profile), (width, height)) as b:
        _, messages = b.screenshot(args.report, args.output, f"t={moment:.3f}&view={args.view}")
    print(f"{args.output}: {args.report} at t = {moment:.2f} ({args.view})")
    for line in messages:
        print(f"  console: {line}")


if __name__ == "__main__":
    main()
