"""Headless Chromium for the tests: pages served over loopback HTTP and read through the DevTools protocol.

`evaluate(url, expression)` opens the page in a fresh profile, waits for its load event, and returns
the value of a JavaScript expression (a promise is awaited), over `--remote-debugging-pipe`
(null-terminated JSON messages on file descriptors 3 and 4): no port, no extra package.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import json
import os
import subprocess
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path


CHROMIUM = Path("/usr/bin/chromium")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def require_chromium() -> None:
    assert CHROMIUM.exists(), "/usr/bin/chromium is missing (Debian package `chromium`; `make setup` installs it)"


@contextlib.contextmanager
def serve(directory: Path) -> Iterator[str]:
    """`directory` over HTTP on a free loopback port; yields the base URL."""
    handler = functools.partial(_QuietHandler, directory=str(directory))
    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{server.server_address[1]}"
    finally:
        server.shutdown()
        server.server_close()


class _QuietHandler(http.server.SimpleHTTPRequestHandler):
    def log_message(self, format, *args) -> None:  # noqa: A002 - http.server's signature
        pass


class _Pipe:
    """DevTools protocol messages over Chromium's debugging pipe."""

    def __init__(self, write_fd: int, read_fd: int):
        self.write_fd, self.read_fd = write_fd, read_fd
        self.buffer = b""
        self.last_id = 0

    def send(self, method: str, params: dict | None = None, session: str | None = None) -> int:
        self.last_id += 1
        message = {"id": self.last_id, "method": method, "params": params or {}}
        if session:
            message["sessionId"] = session
        os.write(self.write_fd, json.dumps(message).encode() + b"\0")
        return self.last_id

    def wait(self, key: int | str) -> dict:
        """The reply to message `key`, or the next event named `key`."""
        while True:
            while b"\0" not in self.buffer:
                chunk = os.read(self.read_fd, 1 << 16)
                if not chunk:
                    raise RuntimeError("Chromium closed the DevTools pipe")
                self.buffer += chunk
            raw, self.buffer = self.buffer.split(b"\0", 1)
            message = json.loads(raw)
            if message.get("id") == key or message.get("method") == key:
                if "error" in message:
                    raise RuntimeError(f"DevTools: {message['error']}")
                return message

    def call(self, method: str, params: dict | None = None, session: str | None = None) -> dict:
        return self.wait(self.send(method, params, session)).get("result", {})


def evaluate(url: str, expression: str, timeout_s: float = 60.0):
    """The value of `expression` in the page at `url`, after its load event (promises awaited)."""
    require_chromium()
    to_chromium, from_chromium = os.pipe(), os.pipe()
    with tempfile.TemporaryDirectory(prefix="chromium-profile-") as profile:

        def descriptors() -> None:  # Chromium reads commands on fd 3 and writes replies on fd 4
            os.dup2(to_chromium[0], 3)
            os.dup2(from_chromium[1], 4)

        process = subprocess.Popen(
            [str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", "--remote-debugging-pipe",
             "--autoplay-policy=no-user-gesture-required", "about:blank"],
            pass_fds=(3, 4), preexec_fn=descriptors, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )
        os.close(to_chromium[0])
        os.close(from_chromium[1])
        timer = threading.Timer(timeout_s, process.kill)  # a page that never answers ends the browser, and the test
        timer.start()
        try:
            pipe = _Pipe(to_chromium[1], from_chromium[0])
            target = pipe.call("Target.createTarget", {"url": "about:blank"})["targetId"]
            session = pipe.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
            pipe.call("Page.enable", session=session)
            pipe.send("Page.navigate", {"url": url}, session)
            pipe.wait("Page.loadEventFired")
            reply = pipe.call("Runtime.evaluate", {"expression": expression, "awaitPromise": True, "returnByValue": True}, session)
            if "exceptionDetails" in reply:
                raise RuntimeError(f"{url}: {reply['exceptionDetails']}")
            return reply["result"].get("value")
        finally:
            timer.cancel()
            process.kill()
            process.wait()
            os.close(to_chromium[1])
            os.close(from_chromium[0])
