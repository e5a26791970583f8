"""Headless Chromium for the report tests (and tools/report_screenshots.py): a page's DOM after
its scripts ran, a screenshot as pixels, and the page's console messages.

One :class:`Browser` serves every page of a test module: one Chromium started once and driven
over the DevTools protocol on a pipe (``--remote-debugging-pipe``: commands on the browser's
fd 3, replies and events on its fd 4, each a JSON text ended by a NUL byte), where the tests
used to start a Chromium per page (``--dump-dom``, ``--screenshot``): a launch is a few seconds
of CPU, most of it in the zygote, GPU and renderer processes the launcher leaves behind when
it exits, which neither the test nor ``/usr/bin/time make test`` counted.

Chromium runs in a process group of its own and the test process is made a child subreaper
(Linux ``prctl(PR_SET_CHILD_SUBREAPER)``) while a browser runs, so :meth:`Browser.close` ends
the whole group and reaps every one of its processes (and the crash handlers, which start a
session of their own): none outlives the module, and their CPU is counted in the test
process's children.

WebGL runs on SwiftShader (software), which Chromium only enables on request:
``--use-angle=swiftshader --enable-unsafe-swiftshader`` (without them recent Chromium warns that
its automatic software fallback is deprecated).
"""

from __future__ import annotations

import base64
import contextlib
import ctypes
import io
import json
import os
import re
import select
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--hide-scrollbars", "--use-angle=swiftshader", "--enable-unsafe-swiftshader",
         "--remote-debugging-pipe"]
TIMEOUT = 180
"""[s] for one command or page load (software WebGL on a shared machine)."""
PR_SET_CHILD_SUBREAPER, PR_GET_CHILD_SUBREAPER = 36, 37
PIPES_AT_3_AND_4 = ("import os, sys; os.dup2(int(sys.argv[1]), 3); os.dup2(int(sys.argv[2]), 4); "
                    "os.execv(sys.argv[3], sys.argv[3:])")
"""Run by the launcher: the two pipe ends as fds 3 and 4, then Chromium in its place."""


def _set_subreaper(on: bool) -> None:
    """Make this process the reaper of its orphaned descendants (Linux; a no-op elsewhere)."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_CHILD_SUBREAPER, int(on), 0, 0, 0)
    except (OSError, AttributeError):
        pass


def is_subreaper() -> bool:
    """Whether this process reaps its orphaned descendants (Linux; False elsewhere)."""
    flag = ctypes.c_int(0)
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_GET_CHILD_SUBREAPER, ctypes.byref(flag), 0,
                                                0, 0)
    except (OSError, AttributeError):
        return False
    return bool(flag.value)


class Browser:
    """One headless Chromium, its pages loaded one after the other in one tab.

    Parameters
    ----------
    profile : Path
        An empty folder for the browser's profile.
    size : (int, int)
        The window's width and height [px]: every page is laid out, and screenshot, at it.
    """

    def __init__(self, profile: Path, size: tuple[int, int] = (1280, 900)):
        if CHROMIUM is None:
            raise RuntimeError("Chromium is not installed (make browser; apt-get install chromium)")
        self.size = size
        # a browser opened while another runs (a test's own beside the module's) leaves the
        # process a subreaper when it closes, and kills only its own crash handlers
        self._was_subreaper, others = is_subreaper(), set(_orphaned_crash_handlers())
        _set_subreaper(True)
        to_browser, self._commands = os.pipe()
        self._replies, from_browser = os.pipe()
        # the browser reads its fd 3 and writes its fd 4: a small exec puts the pipes there
        self._process = subprocess.Popen(
            [sys.executable, "-c", PIPES_AT_3_AND_4, str(to_browser), str(from_browser), CHROMIUM,
             *FLAGS, f"--user-data-dir={profile}", f"--window-size={size[0]},{size[1]}",
             "about:blank"],
            pass_fds=(to_browser, from_browser), start_new_session=True,
            stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        os.close(to_browser)
        os.close(from_browser)
        self.group = self._process.pid
        """The browser's process group (the browser's process id)."""
        self._buffer, self._events, self._next_id = b"", [], 0
        try:
            target = self.send("Target.createTarget", url="about:blank")["targetId"]
            self._session = self.send("Target.attachToTarget", targetId=target,
                                      flatten=True)["sessionId"]
            for domain in ("Page", "Runtime", "Log", "Inspector"):
                self.send(f"{domain}.enable", session=True)
            self.send("Emulation.setDeviceMetricsOverride", session=True, width=size[0],
                      height=size[1], deviceScaleFactor=1, mobile=False)
            self._crash_handlers = set(_orphaned_crash_handlers()) - others  # started by now
        except BaseException:
            self._crash_handlers = set(_orphaned_crash_handlers()) - others
            self.close()
            raise

    # -- the protocol ---------------------------------------------------------------------------

    def _receive(self, deadline: float, what: str) -> dict:
        """The next message from Chromium, waiting until ``deadline`` (``time.monotonic``) for
        ``what`` (named in the error); a crash of the page's renderer is an error at once."""
        while b"\0" not in self._buffer:
            left = deadline - time.monotonic()
            if left <= 0 or not select.select([self._replies], [], [], left)[0]:
                raise TimeoutError(f"Chromium did not finish {what} within {TIMEOUT} s")
            chunk = os.read(self._replies, 1 << 20)
            if not chunk:
                raise RuntimeError(f"Chromium exited (code {self._process.poll()}) during {what}")
            self._buffer += chunk
        message, self._buffer = self._buffer.split(b"\0", 1)
        message = json.loads(message)
        if message.get("method") == "Inspector.targetCrashed":
            raise RuntimeError(f"the page's renderer crashed during {what}")
        return message

    def send(self, method: str, session: bool = False, **params) -> dict:
        """Send one DevTools command (to the page's session if ``session``) and return its
        result; the events that arrive meanwhile are kept for :meth:`wait_for`."""
        self._next_id += 1
        command = {"id": self._next_id, "method": method, "params": params}
        if session:
            command["sessionId"] = self._session
        os.write(self._commands, json.dumps(command).encode() + b"\0")
        deadline = time.monotonic() + TIMEOUT
        while True:
            message = self._receive(deadline, method)
            if message.get("id") == self._next_id:
                if "error" in message:
                    raise RuntimeError(f"{method}: {message['error']}")
                return message.get("result", {})
            self._events.append(message)

    def wait_for(self, method: str, what: str) -> dict:
        """The next event ``method`` (those before it stay kept), waited for as ``what``."""
        deadline = time.monotonic() + TIMEOUT
        for k, event in enumerate(self._events):
            if event.get("method") == method:
                return self._events.pop(k)
        while True:
            event = self._receive(deadline, what)
            if event.get("method") == method:
                return event
            self._events.append(event)

    def evaluate(self, expression: str):
        """The value of a JavaScript expression in the page (promises awaited)."""
        result = self.send("Runtime.evaluate", session=True, expression=expression,
                           returnByValue=True, awaitPromise=True)
        if "exceptionDetails" in result:
            raise RuntimeError(f"{expression}: {result['exceptionDetails']}")
        return result["result"].get("value")

    # -- pages ------------------------------------------------------------------------------

    def open(self, page: Path, fragment: str = "", seconds: float | None = None) -> None:
        """Load ``page`` (``#fragment`` appended) afresh and wait until its scripts ran, its
        load event fired and two frames were drawn (then ``seconds`` more [s] of animation).
        Its console messages from then on are :meth:`messages`'."""
        url = Path(page).resolve().as_uri() + (f"#{fragment}" if fragment else "")
        self._events.clear()
        self.send("Page.navigate", session=True, url="about:blank")  # a new hash reloads too
        self.wait_for("Page.loadEventFired", "the load of about:blank")
        self._events.clear()
        self.send("Page.navigate", session=True, url=url)
        self.wait_for("Page.loadEventFired", f"the load of {url}")
        self.evaluate("new Promise(r => requestAnimationFrame(() => requestAnimationFrame(r)))")
        if seconds:
            time.sleep(seconds)

    def messages(self) -> list[str]:
        """The console messages the page opened last logged up to the last command's answer
        (call it after reading the page, so that what it logged meanwhile is in): console
        calls, uncaught exceptions and the browser's log entries, not the GL driver's
        performance notes Chromium files under the page (SwiftShader's read-backs)."""
        messages, self._events = _console(self._events), []
        return messages

    def dom(self, page: Path, fragment: str = "", seconds: float | None = None
            ) -> tuple[str, list[str]]:
        """The page's DOM after its scripts ran (and ``seconds`` [s] of animation), and its
        console messages up to then."""
        self.open(page, fragment, seconds)
        return self.evaluate("document.documentElement.outerHTML"), self.messages()

    def screenshot(self, page: Path, out: Path, fragment: str = ""
                   ) -> tuple[np.ndarray, list[str]]:
        """Screenshot of the page at the browser's ``size`` into the PNG ``out``: (H, W, 3)
        uint8 RGB pixels, and the page's console messages."""
        from matplotlib import image

        self.open(page, fragment)
        png = base64.b64decode(self.send("Page.captureScreenshot", session=True,
                                         format="png")["data"])
        messages = self.messages()
        Path(out).write_bytes(png)
        pixels = (image.imread(io.BytesIO(png))[..., :3] * 255).round().astype(np.uint8)
        return pixels, messages

    # -- the end ------------------------------------------------------------------------------

    def close(self) -> None:
        """End the browser and every process of its group, and reap them."""
        if self._process.poll() is None:
            try:
                os.write(self._commands, json.dumps(
                    {"id": 0, "method": "Browser.close"}).encode() + b"\0")
                self._process.wait(timeout=10)
            except (OSError, subprocess.TimeoutExpired):
                pass
        group = self.group
        try:
            os.killpg(group, signal.SIGKILL)
        except ProcessLookupError:
            pass
        self._process.wait()
        while True:  # the group's orphans, re-parented to this subreaper
            try:
                os.waitpid(-group, 0)
            except ChildProcessError:
                break
        for pid in self._crash_handlers:  # they leave the group (a session of their own)
            with contextlib.suppress(ProcessLookupError, ChildProcessError):
                os.kill(pid, signal.SIGKILL)
                os.waitpid(pid, 0)
        for fd in (self._commands, self._replies):
            os.close(fd)
        if not self._was_subreaper:
            _set_subreaper(False)

    def __enter__(self) -> Browser:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _orphaned_crash_handlers() -> list[int]:
    """The Chromium crash handlers (``chrome_crashpad``) re-parented to this process."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        with contextlib.suppress(OSError):
            name, fields = stat.read_text().rsplit(")", 1)
            if name.split("(", 1)[1].startswith("chrome") and int(fields.split()[1]) == os.getpid():
                found.append(int(stat.parent.name))
    return found


def _console(events: list[dict]) -> list[str]:
    messages = []
    for event in events:
        method, params = event.get("method"), event.get("params", {})
        if method == "Runtime.consoleAPICalled":
            text = " ".join(str(a.get("value", a.get("description", ""))) for a in params["args"])
            messages.append(f"console.{params['type']}: {text}")
        elif method == "Runtime.exceptionThrown":
            details = params["exceptionDetails"]
            messages.append(details.get("exception", {}).get("description", details["text"]))
        elif method == "Log.entryAdded":
            entry = params["entry"]
            if "GL Driver Message" not in entry["text"]:
                messages.append(f"{entry['source']} {entry['level']}: {entry['text']}")
    return messages


def body_data(html: str) -> dict[str, str]:
    """The ``data-*`` attributes of the dumped page's ``<body>``."""
    tag = re.search(r"<body([^>]*)>", html).group(1)
    return {k: v.replace("&quot;", '"').replace("&amp;", "&")
            for k, v in re.findall(r'data-([a-z]+)="([^"]*)"', tag)}
