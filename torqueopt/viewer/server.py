"""The live meshcat server, every socket on 127.0.0.1: ``python -m torqueopt.viewer.server``.

meshcat 0.3's own server binds its web port on every interface; this one
serves the same ZMQ/websocket bridge on 127.0.0.1 only. It prints
``zmq_url=...`` and ``web_url=...`` on stdout, one per line, and exits when
its stdin closes (the parent, :class:`torqueopt.viewer.LiveViewer`, holds
the other end), so it never outlives the process that started it.
"""

from __future__ import annotations

import os
import sys
import threading

from .live import LOCALHOST

__all__ = ["main"]


def main() -> None:
    """Serve meshcat's ZMQ/websocket bridge on 127.0.0.1 until stdin closes."""
    import tornado.web

    from .dependency import quiet_meshcat_import

    with quiet_meshcat_import():
        from meshcat.servers import zmqserver

    class LocalhostApplication(tornado.web.Application):
        def listen(self, port, address=None, **kwargs):
            return super().listen(port, LOCALHOST, **kwargs)

    class LocalhostBridge(zmqserver.ZMQWebSocketBridge):
        def make_app(self):
            return LocalhostApplication(
                [
                    (
                        r"/static/(.*)",
                        zmqserver.StaticFileHandlerNoCache,
                        {"path": zmqserver.VIEWER_ROOT, "default_filename": zmqserver.VIEWER_HTML},
                    ),
                    (r"/", zmqserver.WebSocketHandler, {"bridge": self}),
                ]
            )

        def wait_for_websockets(self):
            # meshcat answers "wait" on the raw socket from a timer, outside its
            # ZMQStream's handler, and the stream then misses every later
            # command; answering through the stream keeps it polling.
            if self.websocket_pool:
                self.zmq_stream.send(b"ok")
            else:
                self.ioloop.call_later(0.1, self.wait_for_websockets)

    def exit_with_parent():
        # The parent holds the other end of stdin: EOF means it has gone,
        # even when killed without the chance to stop this server.
        sys.stdin.buffer.read()
        os._exit(0)

    threading.Thread(target=exit_with_parent, daemon=True).start()
    bridge = LocalhostBridge(zmq_url=None, host=LOCALHOST)
    print(f"zmq_url={bridge.zmq_url}", flush=True)
    print(f"web_url={bridge.web_url}", flush=True)
    bridge.run()


if __name__ == "__main__":
    main()
