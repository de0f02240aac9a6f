"""meshcat, imported only when a playback needs it, with an error that says how to install it."""

from __future__ import annotations

import contextlib
import warnings

from ..errors import MissingDependency

__all__ = ["quiet_meshcat_import", "require_meshcat"]


@contextlib.contextmanager
def quiet_meshcat_import():
    """meshcat 0.3's server imports pyzmq's ``zmq.eventloop.ioloop``, which warns that it is deprecated: a
    DeprecationWarning in every playback (an error under ``python -W error``) about code that is not ours."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="zmq.eventloop.ioloop is deprecated", category=DeprecationWarning)
        yield


def require_meshcat():
    """meshcat and its submodules, or MissingDependency saying how to install it."""
    try:
        with quiet_meshcat_import():
            import meshcat
            import meshcat.animation
            import meshcat.geometry
    except ImportError:
        raise MissingDependency(
            "meshcat playback needs the 'meshcat' package, which is not installed: pip install meshcat"
        ) from None
    return meshcat
