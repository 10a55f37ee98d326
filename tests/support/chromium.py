"""Headless Chromium for the tests: pages served over loopback HTTP and read through the DevTools protocol.

`evaluate(url, expression)` opens the page in a fresh profile, waits for its load event, and returns
the value of a JavaScript expression (a promise is awaited), over `--remote-debugging-pipe`
(null-terminated JSON messages on file descriptors 3 and 4): no port, no extra package.
`run(*arguments)` runs Chromium once (`--dump-dom`, `--screenshot`) in a fresh profile.

Chromium is a tree of processes (browser, renderer, GPU, utility, crash handler) that go on writing
into the profile for a while after the browser process ends. Each browser therefore runs in a process
group of its own (`browser`): the whole group is ended and waited for before its profile is removed,
so a test under load never races a renderer still writing its cache.
"""

from __future__ import annotations

import contextlib
import functools
import http.server
import json
import os
import shutil
import signal
import subprocess
import tempfile
import threading
import time
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
    def log_message(self, format, *args) -> None:
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


def _group_alive(group: int) -> bool:
    """Whether any process of process group `group` is still running (zombies do not count)."""
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:  # the process ended while we looked
            continue
        if int(fields[2]) == group and fields[0] != "Z":  # fields after the name: state, ppid, pgrp
            return True
    return False


def _kill_group(group: int) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(group, signal.SIGKILL)


def _end_group(process: subprocess.Popen, grace_s: float = 5.0, limit_s: float = 30.0) -> None:
    """End Chromium's whole process group: the browser first gets `grace_s` to close by itself (its
    pipe or stdin closed), then every member is killed, and this waits (up to `limit_s`) until none runs."""
    try:
        process.wait(timeout=grace_s)
    except subprocess.TimeoutExpired:
        pass
    _kill_group(process.pid)
    process.wait()
    deadline = time.monotonic() + limit_s
    while _group_alive(process.pid) and time.monotonic() < deadline:
        time.sleep(0.05)


def _remove_profile(profile: Path, limit_s: float = 10.0) -> None:
    """Remove a profile folder; a file that appears while removing it only costs another pass."""
    deadline = time.monotonic() + limit_s
    while profile.exists():
        try:
            shutil.rmtree(profile)
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.1)


@contextlib.contextmanager
def browser(arguments: list[str], **popen) -> Iterator[subprocess.Popen]:
    """Chromium with `arguments` in a fresh profile and a process group of its own; on exit the group
    is ended and waited for, then the profile removed."""
    require_chromium()
    profile = Path(tempfile.mkdtemp(prefix="chromium-profile-"))
    try:
        process = subprocess.Popen(
            [str(CHROMIUM), *FLAGS, f"--user-data-dir={profile}", *arguments], process_group=0, **popen
        )
        try:
            yield process
        finally:
            _end_group(process)
    finally:
        _remove_profile(profile)


def run(*arguments: str, timeout_s: float = 120.0) -> subprocess.CompletedProcess:
    """Chromium run once with `arguments` (e.g. `--dump-dom URL`); its output as text."""
    with browser(list(arguments), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as process:
        try:
            stdout, stderr = process.communicate(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            _kill_group(process.pid)
            raise
    return subprocess.CompletedProcess(process.args, process.returncode, stdout, stderr)


def evaluate(url: str, expression: str, timeout_s: float = 60.0):
    """The value of `expression` in the page at `url`, after its load event (promises awaited)."""
    to_chromium, from_chromium = os.pipe(), os.pipe()

    def descriptors() -> None:  # Chromium reads commands on fd 3 and writes replies on fd 4
        os.dup2(to_chromium[0], 3)
        os.dup2(from_chromium[1], 4)

    arguments = ["--remote-debugging-pipe", "--autoplay-policy=no-user-gesture-required", "about:blank"]
    with browser(
        arguments, pass_fds=(3, 4), preexec_fn=descriptors, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL
    ) as process:
        os.close(to_chromium[0])
        os.close(from_chromium[1])
        timer = threading.Timer(timeout_s, _kill_group, (process.pid,))  # a page that never answers ends the test
        timer.start()
        try:
            pipe = _Pipe(to_chromium[1], from_chromium[0])
            target = pipe.call("Target.createTarget", {"url": "about:blank"})["targetId"]
            session = pipe.call("Target.attachToTarget", {"targetId": target, "flatten": True})["sessionId"]
            pipe.call("Page.enable", session=session)
            pipe.send("Page.navigate", {"url": url}, session)
            pipe.wait("Page.loadEventFired")
            reply = pipe.call(
                "Runtime.evaluate", {"expression": expression, "awaitPromise": True, "returnByValue": True}, session
            )
            if "exceptionDetails" in reply:
                raise RuntimeError(f"{url}: {reply['exceptionDetails']}")
            return reply["result"].get("value")
        finally:
            timer.cancel()
            with contextlib.suppress(OSError, RuntimeError):
                pipe.send("Browser.close")  # a clean exit: the browser closes its profile itself
            os.close(to_chromium[1])
            os.close(from_chromium[0])
