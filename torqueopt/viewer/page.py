"""The self-contained HTML page of a playback: meshcat's viewer script, the scene commands and a little JS.

:class:`RecordingWindow` stands in for meshcat's connection to a server and
keeps the scene commands; :data:`PAGE` is the page they go into. Opened with
``#t=SECONDS`` after its address, the page pauses the animation at that
simulated time (``#t=end``: at its end).
"""

from __future__ import annotations

import base64
from pathlib import Path
from typing import TYPE_CHECKING

from ..io import atomic_write
from .dependency import require_meshcat

if TYPE_CHECKING:
    from .scene import Playback

__all__ = ["PAGE", "RecordingWindow", "export_html"]


class RecordingWindow:
    """Stands in for meshcat's ViewerWindow: keeps the scene commands in order, no server.

    ``get_scene`` returns the page that meshcat's server would give for
    ``static_html()``, except that the commands run synchronously and in
    the order they were sent, and that ``#t=SECONDS`` in the page's address
    pauses the animation at that simulated time (``speed`` converts it to
    the animation's time).
    """

    def __init__(self, speed: float = 1.0):
        self.commands: list[bytes] = []
        self.speed = speed

    def send(self, command) -> None:
        import umsgpack

        self.commands.append(umsgpack.packb(command.lower()))

    def get_scene(self) -> str:
        meshcat = require_meshcat()
        viewer_script = Path(meshcat.__file__).parent / "viewer" / "dist" / "main.min.js"
        script = viewer_script.read_text(encoding="utf-8")
        encoded = ",\n".join(f'"{base64.b64encode(command).decode("ascii")}"' for command in self.commands)
        return PAGE.format(viewer_script=script, commands=encoded, speed=repr(float(self.speed)))


PAGE = """<!DOCTYPE html>
<html>
<head>
<meta charset="utf-8">
<title>torqueopt playback</title>
<style>body {{ margin: 0; }} #meshcat-pane {{ width: 100vw; height: 100vh; overflow: hidden; }}</style>
</head>
<body>
<div id="meshcat-pane"></div>
<script>
{viewer_script}
</script>
<script>
var viewer = new MeshCat.Viewer(document.getElementById("meshcat-pane"));
var commands = [
{commands}
];
for (const command of commands) {{
    const text = atob(command);
    const bytes = new Uint8Array(text.length);
    for (let i = 0; i < text.length; i++) {{ bytes[i] = text.charCodeAt(i); }}
    viewer.handle_command_bytearray(bytes);
}}
// Simulated seconds per second of animation.
const speed = {speed};
const shown = /[#&]t=(end|[0-9.eE+-]+)/.exec(location.hash);
if (shown !== null) {{
    viewer.animator.pause();
    viewer.animator.seek(shown[1] === "end" ? viewer.animator.duration : parseFloat(shown[1]) / speed);
}}
document.title = "torqueopt playback (loaded)";
</script>
</body>
</html>
"""


def export_html(playback: Playback, path: str | Path) -> Path:
    """Write ``playback`` as a self-contained HTML file, atomically; returns the path."""
    path = Path(path)
    page = playback.html().encode("utf-8")
    atomic_write(path, lambda handle: handle.write(page))
    return path
