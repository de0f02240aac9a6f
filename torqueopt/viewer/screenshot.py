"""Screenshots of a playback page in headless Chromium."""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from pathlib import Path

from ..errors import InvalidInput, MissingDependency, TorqueoptError
from ..io import atomic_write

__all__ = ["BROWSERS", "find_browser", "screenshot_html"]

#: Browsers :func:`find_browser` looks for, in this order.
BROWSERS = ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable")


def find_browser(browser: str | None = None) -> str:
    """Path of a Chromium-family browser: ``browser`` if given, else the first of :data:`BROWSERS` on PATH."""
    candidates = (browser,) if browser else BROWSERS
    for name in candidates:
        found = shutil.which(name)
        if found:
            return found
    raise MissingDependency(
        f"no headless browser found (looked for {', '.join(candidates)}): install Chromium, "
        "e.g. apt-get install chromium"
    )


def screenshot_html(
    html_path: str | Path,
    png_path: str | Path,
    *,
    at: float | None = None,
    wait: float = 1.0,
    width: int = 1280,
    height: int = 800,
    browser: str | None = None,
    timeout: float = 120.0,
) -> Path:
    """Render a playback page in headless Chromium and save a PNG screenshot, atomically.

    Args:
        at: simulated time [s] at which the page pauses the run (see
            :meth:`Playback.html`); None for the end of the run.
        wait: virtual time [s] the page gets to load and draw. Playing the
            animation under virtual time is slow and erratic in software
            WebGL, hence the pause.
        width, height: window size [pixels].
        browser: browser executable; see :func:`find_browser`.

    The browser runs without sandbox, GPU (WebGL falls back to SwiftShader),
    network services, sync or first-run setup, with a fresh profile.
    """
    executable = find_browser(browser)
    html_path, png_path = Path(html_path).resolve(), Path(png_path)
    if not html_path.is_file():
        raise InvalidInput(f"HTML file '{html_path}' does not exist")
    with tempfile.TemporaryDirectory(prefix="torqueopt-chromium-") as scratch:
        shot = Path(scratch) / "screenshot.png"
        command = [
            executable,
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            # Chromium only falls back to software WebGL when told that is fine.
            "--enable-unsafe-swiftshader",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--disable-extensions",
            "--disable-crash-reporter",
            "--no-first-run",
            "--no-default-browser-check",
            "--hide-scrollbars",
            "--mute-audio",
            f"--user-data-dir={Path(scratch) / 'profile'}",
            f"--window-size={int(width)},{int(height)}",
            f"--virtual-time-budget={int(wait * 1000)}",
            f"--screenshot={shot}",
            f"{html_path.as_uri()}#t={'end' if at is None else repr(float(at))}",
        ]
        try:
            completed = subprocess.run(
                command, check=False, capture_output=True, timeout=timeout, stdin=subprocess.DEVNULL
            )
        except subprocess.TimeoutExpired:
            raise TorqueoptError(
                f"{executable} did not finish the screenshot of '{html_path}' within {timeout:g} s"
            ) from None
        if not shot.is_file():
            detail = completed.stderr.decode("utf-8", "replace").strip().splitlines()[-1:] or ["no output"]
            raise TorqueoptError(f"{executable} wrote no screenshot (exit code {completed.returncode}): {detail[0]}")
        image = shot.read_bytes()
    atomic_write(png_path, lambda handle: handle.write(image))
    return png_path
