"""The registry of resolvers: names to classes, filled by ``@register_resolver`` and by entry points.

A resolver class joins the registry in one of two ways, the same for the
built-in ones and a user's:

* the decorator, where the class is defined::

      @register_resolver            # under the class's ``name`` attribute
      class MyResolver(torqueopt.NullSpaceResolver):
          name = "my-resolver"

      @register_resolver("my-resolver")   # or under this name (set as the class's ``name``)
      class MyResolver(torqueopt.NullSpaceResolver): ...

* an entry point of the group ``torqueopt.resolvers`` in the metadata of an
  installed distribution (``pyproject.toml``)::

      [project.entry-points."torqueopt.resolvers"]
      my-resolver = "mypkg.module:MyResolver"

  The entry points are loaded at the registry's first look-up (so ``import
  torqueopt`` imports no plug-in). One that fails to load breaks no other
  resolver: asking for its name raises :class:`~torqueopt.errors.ResolverNotFound`
  with one line naming the entry point and why, and ``torqueopt resolvers``
  lists it under the resolvers.

A class that is not registered at all is still reachable by its import path,
``mypkg.module:MyResolver`` (:func:`class_from_path`).
"""

from __future__ import annotations

import importlib
import re
from collections.abc import Iterator, MutableMapping

from ..errors import InvalidInput, ResolverNotFound
from .base import Resolver

__all__ = ["ENTRY_POINT_GROUP", "ResolverRegistry", "RESOLVERS", "register_resolver", "class_from_path"]

#: The entry-point group a distribution declares its resolvers in.
ENTRY_POINT_GROUP = "torqueopt.resolvers"

#: What a registered name may hold: the text before ``[`` in NAME[OPTION=VALUE], without ``:`` (which marks an
#: import path ``module:Class``).
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.+-]*$")


class ResolverRegistry(MutableMapping):
    """Resolver classes by name, in the order they registered; the entry points of ``group`` join at the first
    look-up.

    A mapping (``RESOLVERS["pinv"]``, ``"pinv" in RESOLVERS``, ``list(RESOLVERS)``); assigning or deleting
    entries is for tests that change the registry and put it back.
    """

    def __init__(self, group: str = ENTRY_POINT_GROUP, primary: bool = False):
        self.group = group
        #: True for :data:`RESOLVERS`, the registry ``get_resolver`` reads: it marks the classes it holds.
        self.primary = primary
        self._classes: dict[str, type[Resolver]] = {}
        #: {name: one line saying which entry point failed to load and why}
        self._failures: dict[str, str] = {}
        self._entry_points_loaded = False

    # -- registration -------------------------------------------------------------------------------------------
    def register(self, cls: type, name: str | None = None) -> type:
        """Add ``cls`` under ``name`` (default its ``name`` attribute); returns ``cls``.

        Raises:
            InvalidInput: ``cls`` is not a :class:`~torqueopt.Resolver` subclass, it has no name, the name is
                not a valid resolver name, disagrees with the class's ``name``, or is taken by another class.
        """
        if not (isinstance(cls, type) and issubclass(cls, Resolver)):
            raise InvalidInput(f"register_resolver: {cls!r} is not a subclass of torqueopt.Resolver")
        own = vars(cls).get("name")
        if name is None:
            name = getattr(cls, "name", None)
            if not isinstance(name, str):
                raise InvalidInput(
                    f"register_resolver: class {_path(cls)} has no name; set its name attribute "
                    "or give one, @register_resolver('my-resolver')"
                )
        elif own is not None and own != name:
            raise InvalidInput(f"register_resolver('{name}'): class {_path(cls)} says name = '{own}'; give one name")
        if not _NAME.match(name):
            raise InvalidInput(
                f"resolver name '{name}' of class {_path(cls)} is not a name: use letters, digits and -_.+ "
                "(no ':', '[', ',', '=' or spaces), e.g. my-resolver"
            )
        taken = self._classes.get(name)
        if taken is not None and _path(taken) != _path(cls):  # the same path: the module imported again
            raise InvalidInput(
                f"resolver name '{name}' of class {_path(cls)} is taken by {_path(taken)}; choose another name"
            )
        cls.name = name
        self[name] = cls
        return cls

    def load_entry_points(self) -> None:
        """Register every entry point of the registry's ``group`` (once); one that fails is kept as a failure, not raised."""
        if self._entry_points_loaded:
            return
        self._entry_points_loaded = True
        from importlib.metadata import entry_points

        for entry_point in entry_points(group=self.group):
            if entry_point.name in self._classes or entry_point.name in self._failures:
                continue
            where = f"entry point '{entry_point.name} = {entry_point.value}' of group {self.group}"
            dist = getattr(entry_point, "dist", None)
            if dist is not None:
                where += f" (distribution {dist.metadata['Name']} {dist.version})"
            try:
                cls = entry_point.load()
                if isinstance(cls, type) and vars(cls).get("name") not in (None, entry_point.name):
                    raise InvalidInput(f"its class says name = '{cls.name}'; make the two names equal")
                self.register(cls, entry_point.name)
            except Exception as error:  # a plug-in's import may raise anything: keep it as one line
                self._failures[entry_point.name] = f"{where} failed to load: {type(error).__name__}: {error}"

    @property
    def failures(self) -> dict[str, str]:
        """The names whose entry points failed to load, each with one line saying which entry point and why."""
        self.load_entry_points()
        return dict(self._failures)

    def lookup(self, name: str) -> type[Resolver]:
        """The class registered under ``name``.

        Raises:
            ResolverNotFound: no resolver has that name (the message lists those that exist and suggests the
                close one), or its entry point failed to load (the message says which and why).
        """
        self.load_entry_points()
        cls = self._classes.get(name)
        if cls is not None:
            return cls
        if name in self._failures:
            raise ResolverNotFound(f"resolver '{name}': {self._failures[name]}")
        import difflib

        close = difflib.get_close_matches(str(name), list(self._classes), n=1, cutoff=0.7)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        raise ResolverNotFound(f"unknown resolver '{name}'{hint}: choose one of {', '.join(self._classes)}")

    # -- the mapping ----------------------------------------------------------------------------------------------
    def __getitem__(self, name: str) -> type[Resolver]:
        self.load_entry_points()
        return self._classes[name]

    def __setitem__(self, name: str, cls: type[Resolver]) -> None:
        self._classes[name] = cls
        if self.primary:
            # What Resolver.spec reads (this very class, not a subclass, is what get_resolver(name) makes), so
            # that base.py need not import the registry, which imports it.
            cls._registered_name = name

    def __delitem__(self, name: str) -> None:
        cls = self._classes.pop(name)
        if self.primary and vars(cls).get("_registered_name") == name:
            del cls._registered_name

    def __iter__(self) -> Iterator[str]:
        self.load_entry_points()
        return iter(list(self._classes))

    def __len__(self) -> int:
        self.load_entry_points()
        return len(self._classes)

    def __contains__(self, name: object) -> bool:
        self.load_entry_points()
        return name in self._classes

    def put_first(self, names) -> None:
        """List ``names`` first, in that order (each must be registered); the others follow as they came."""
        self._classes = {**{name: self._classes[name] for name in names}, **self._classes}

    def __repr__(self) -> str:
        return f"ResolverRegistry({', '.join(self._classes)})"


#: Every registered resolver class by name: the built-in ones, those of ``@register_resolver`` and of entry points.
RESOLVERS = ResolverRegistry(primary=True)


def register_resolver(name_or_class=None):
    """Register a resolver class: ``@register_resolver`` (under its ``name``) or ``@register_resolver("name")``.

    Returns the class unchanged (with ``name`` set), so it reads as a class decorator.

    Raises:
        InvalidInput: not a Resolver subclass, no name, a malformed name or one another class holds.
    """
    if isinstance(name_or_class, type):
        return RESOLVERS.register(name_or_class)

    def decorate(cls):
        return RESOLVERS.register(cls, name_or_class)

    return decorate


def class_from_path(path: str) -> type[Resolver]:
    """The Resolver class at the import path ``module:Class`` (``Class`` may be dotted: ``module:Outer.Inner``).

    Raises:
        ResolverNotFound: the module does not import, has no such attribute, or it is not a Resolver class;
            one line saying which.
    """
    module_name, _, attribute = str(path).partition(":")
    if not module_name or not attribute:
        raise ResolverNotFound(f"resolver '{path}' is not module:Class, e.g. mypkg.resolvers:MyResolver")
    try:
        target = importlib.import_module(module_name)
    except ImportError as error:
        raise ResolverNotFound(
            f"resolver '{path}': module '{module_name}' does not import ({type(error).__name__}: {error})"
        ) from None
    for part in attribute.split("."):
        try:
            target = getattr(target, part)
        except AttributeError:
            raise ResolverNotFound(f"resolver '{path}': module '{module_name}' has no '{attribute}'") from None
    if not (isinstance(target, type) and issubclass(target, Resolver)):
        raise ResolverNotFound(f"resolver '{path}': {attribute} is not a subclass of torqueopt.Resolver")
    if getattr(target, "__abstractmethods__", None):
        raise ResolverNotFound(
            f"resolver '{path}': {attribute} leaves {', '.join(sorted(target.__abstractmethods__))} abstract"
        )
    return target


def _path(cls: type) -> str:
    return f"{cls.__module__}:{cls.__qualname__}"
