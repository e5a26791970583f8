"""Headless Chromium for the report tests (and tools/report_screenshots.py): a page's DOM after
its scripts ran, a screenshot as pixels, and the page's console messages.

WebGL runs on SwiftShader (software), which Chromium only enables on request:
``--use-angle=swiftshader --enable-unsafe-swiftshader`` (without them recent Chromium warns that
its automatic software fallback is deprecated).
"""

from __future__ import annotations

import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--enable-logging=stderr", "--v=0"]
TIMEOUT = 180
"""[s] for one Chromium run (software WebGL on a shared machine)."""


def _run(page: Path, profile: Path, fragment: str, *args: str) -> subprocess.CompletedProcess:
    url = Path(page).resolve().as_uri() + (f"#{fragment}" if fragment else "")
    return subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", *args, url],
                          capture_output=True, text=True, timeout=TIMEOUT)


def console(stderr: str, page: Path) -> list[str]:
    """The console messages the page logged (errors, warnings, uncaught exceptions); not the
    GL driver's performance notes Chromium files under the page (SwiftShader's read-backs)."""
    name = Path(page).name
    return [line for line in stderr.splitlines()
            if (("CONSOLE" in line and name in line) or "Uncaught" in line)
            and "GL Driver Message" not in line]


def dom(page: Path, profile: Path, fragment: str = "",
        seconds: float | None = None) -> tuple[str, list[str]]:
    """The page's DOM after its scripts ran (and, given ``seconds``, after that much virtual
    time: animation frames run), and its console messages."""
    budget = () if seconds is None else (f"--virtual-time-budget={int(1000 * seconds)}",)
    run = _run(page, profile, fragment, "--dump-dom", *budget)
    return run.stdout, console(run.stderr, page)


def body_data(html: str) -> dict[str, str]:
    """The ``data-*`` attributes of the dumped page's ``<body>``."""
    tag = re.search(r"<body([^>]*)>", html).group(1)
    return {k: v.replace("&quot;", '"').replace("&amp;", "&")
            for k, v in re.findall(r'data-([a-z]+)="([^"]*)"', tag)}


def screenshot(page: Path, out: Path, profile: Path, fragment: str = "",
               size: tuple[int, int] = (1280, 900)) -> tuple[np.ndarray, list[str]]:
    """Screenshot of the page at ``size`` [px] into ``out``: (H, W, 3) uint8 RGB pixels, and the
    page's console messages."""
    from matplotlib import image

    run = _run(page, profile, fragment, f"--window-size={size[0]},{size[1]}",
               f"--screenshot={out}")
    if not Path(out).exists():
        raise RuntimeError(f"no screenshot of {page}: {run.stderr[-2000:]}")
    pixels = (image.imread(out)[..., :3] * 255).round().astype(np.uint8)
    return pixels, console(run.stderr, page)
