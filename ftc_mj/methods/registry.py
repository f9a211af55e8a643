"""Find observer and controller plugins by name.

Built-in methods are always there. A third-party package adds its own by declaring an entry point, e.g. in
its ``pyproject.toml``::

    [project.entry-points."ftc_mj.observers"]
    my_observer = "my_package.module:MyObserver"

The class must follow :class:`ftc_mj.methods.observers.Observer` (or :class:`ftc_mj.methods.controllers.Controller`): a
``name``, a pydantic ``Config`` derived from :class:`ftc_mj.methods.gains.GainConfig`, and the update methods.
Entry points are imported only when a scenario asks for their name, so a broken third-party package cannot
stop scenarios that do not use it; one that is asked for and fails to import raises :class:`PluginError`.

A scenario names a method with a :class:`MethodSpec` (``type`` and ``gains``); :func:`compile_method` finds
the class and validates the gains with its ``Config``.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from functools import cache
from importlib.metadata import EntryPoint, entry_points
from typing import Any


from ftc_mj.methods import controllers, observers
from ftc_mj.methods.gains import GainConfig
from ftc_mj.config.errors import InputError, validate
from ftc_mj.config.types import Strict

OBSERVER_GROUP = "ftc_mj.observers"
CONTROLLER_GROUP = "ftc_mj.controllers"


class PluginError(Exception):
    """A declared plugin could not be imported."""


class Plugins(Mapping[str, type]):
    """Name -> class; built-ins first, entry points imported on first use."""

    def __init__(self, builtin: Mapping[str, type], declared: Mapping[str, EntryPoint]):
        self._loaded = dict(builtin)
        self._declared = {name: entry for name, entry in declared.items() if name not in builtin}

    def __getitem__(self, name: str) -> type:
        if name not in self._loaded:
            entry = self._declared[name]  # KeyError for unknown names, as a Mapping should
            try:
                self._loaded[name] = entry.load()
            except Exception as exc:  # any import-time failure of third-party code
                raise PluginError(f"plugin {name!r} ({entry.value}) cannot be imported: {exc}") from None
        return self._loaded[name]

    def __contains__(self, name: object) -> bool:  # without importing anything
        return name in self._loaded or name in self._declared

    def __iter__(self) -> Iterator[str]:
        yield from self._loaded
        yield from (name for name in self._declared if name not in self._loaded)

    def __len__(self) -> int:
        return len(self._loaded.keys() | self._declared.keys())


@cache
def _discover(group: str) -> Plugins:
    builtin = observers.BUILTIN if group == OBSERVER_GROUP else controllers.BUILTIN
    return Plugins(builtin, {entry.name: entry for entry in entry_points(group=group)})


def observer_types() -> Plugins:
    """Every observer plugin, by name."""
    return _discover(OBSERVER_GROUP)


def controller_types() -> Plugins:
    """Every controller plugin, by name."""
    return _discover(CONTROLLER_GROUP)


class MethodSpec(Strict):
    """An observer or controller of a scenario: the plugin's name and its gains."""

    #: The method's registered name: a built-in or an entry point of ``ftc_mj.observers`` / ``ftc_mj.controllers``.
    type: str
    #: The method's gains, checked by its ``Config`` (the methods reference lists them).
    gains: dict[str, Any] = {}


def compile_method(file: str, field: str, method: MethodSpec, known: Mapping[str, type], kind: str,
                   n: int) -> tuple[type, GainConfig]:
    """The plugin class named by ``method`` among ``known`` (``kind``: observer or controller), and its gains
    validated by the plugin's ``Config`` for ``n`` joints."""
    if method.type not in known:
        raise InputError(file, f"{field}.type", f"unknown {kind} {method.type!r} (known: {', '.join(sorted(known))})")
    try:
        plugin = known[method.type]
    except PluginError as exc:
        raise InputError(file, f"{field}.type", str(exc)) from None
    # Gains without defaults, all named in one line (the schema would report the first and a count).
    needed = [name for name, info in plugin.Config.model_fields.items()
              if info.is_required() and name not in method.gains]
    if needed:
        also = f"; it also needs {', '.join(needed[1:])}" if len(needed) > 1 else ""
        raise InputError(file, f"{field}.gains.{needed[0]}", f"required field is missing ({kind} {method.type!r} "
                                                             f"has no default for it{also})")
    return plugin, validate(plugin.Config, method.gains, file, f"{field}.gains", context={"n_joints": n})
