"""Live playback: the localhost meshcat server in a subprocess, and a visualizer connected to it."""

from __future__ import annotations

import contextlib
import io
import subprocess
import sys
import threading
import time

from ..errors import TorqueoptError
from .dependency import require_meshcat

__all__ = ["LOCALHOST", "LiveViewer"]

#: The only address the live server listens on.
LOCALHOST = "127.0.0.1"


class LiveViewer:
    """A meshcat server on 127.0.0.1 in a subprocess, and a visualizer connected to it.

    Use it as a context manager; leaving it stops the server::

        with LiveViewer() as live:
            print(live.url)
            playback.draw_scene(live.visualizer)
            live.wait_for_browser()
            playback.play(live.visualizer)
    """

    def __init__(self, startup_timeout: float = 30.0):
        meshcat = require_meshcat()
        self._process = subprocess.Popen(
            [sys.executable, "-u", "-m", "torqueopt.viewer.server"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            start_new_session=True,
        )
        try:
            urls = self._read_urls(startup_timeout)
            self.zmq_url, self.url = urls["zmq_url"], urls["web_url"]
            # meshcat prints the URL itself; the caller says it in its own words.
            with contextlib.redirect_stdout(io.StringIO()):
                self.visualizer = meshcat.Visualizer(zmq_url=self.zmq_url)
        except BaseException:
            self.close()
            raise

    @property
    def pid(self) -> int:
        """Process id of the server."""
        return self._process.pid

    def _read_urls(self, timeout: float) -> dict[str, str]:
        urls: dict[str, str] = {}
        stdout = self._process.stdout

        def read():
            for line in stdout:
                key, _, value = line.decode("utf-8", "replace").strip().partition("=")
                urls[key] = value
                if "web_url" in urls:
                    break

        reader = threading.Thread(target=read, daemon=True)
        reader.start()
        reader.join(timeout)
        if "zmq_url" not in urls or "web_url" not in urls:
            raise TorqueoptError(f"the meshcat server did not start within {timeout:g} s")
        # Keep draining the pipe so that the server never blocks on a full one.
        threading.Thread(target=lambda: stdout.read(), daemon=True).start()
        return urls

    def wait_for_browser(self, timeout: float | None = None, poll: float = 0.5) -> None:
        """Block until a browser has opened :attr:`url`, or ``timeout`` seconds (then close the viewer)."""
        socket = self.visualizer.window.zmq_socket
        socket.send(b"wait")
        deadline = None if timeout is None else time.monotonic() + timeout
        while not socket.poll(int(poll * 1000)):
            if self._process.poll() is not None:
                raise TorqueoptError(f"the meshcat server stopped (exit code {self._process.returncode})")
            if deadline is not None and time.monotonic() > deadline:
                raise TorqueoptError(f"no browser opened {self.url} within {timeout:g} s")
        socket.recv()

    def close(self) -> None:
        """Stop the server and close the connection to it."""
        visualizer = getattr(self, "visualizer", None)
        if visualizer is not None:
            visualizer.window.zmq_socket.close(linger=0)
        if self._process.stdin is not None:
            self._process.stdin.close()
        if self._process.poll() is None:
            self._process.terminate()
            try:
                self._process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self._process.kill()
                self._process.wait()
        if self._process.stdout is not None:
            self._process.stdout.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc_info) -> None:
        self.close()
