"""meshcat, imported only when a playback needs it, with an error that says how to install it."""

from __future__ import annotations

from ..errors import MissingDependency

__all__ = ["require_meshcat"]


def require_meshcat():
    """meshcat and its submodules, or MissingDependency saying how to install it."""
    try:
        import meshcat
        import meshcat.animation
        import meshcat.geometry
    except ImportError:
        raise MissingDependency(
            "meshcat playback needs the 'meshcat' package, which is not installed: pip install meshcat"
        ) from None
    return meshcat
