"""The task-space factorisations on stacks, under their former module name.

The resolvers' steps on stacks now live with their classes
(:meth:`Resolver.batch_solver <torqueopt.resolvers.base.Resolver.batch_solver>`),
the factorisations in :mod:`torqueopt.resolvers.stacks`; the registry
(:data:`torqueopt.resolvers.RESOLVERS`) is the only list of resolvers.
"""

from __future__ import annotations

from .resolvers.stacks import complete_qr, two_rows

__all__ = ["complete_qr", "two_rows"]
