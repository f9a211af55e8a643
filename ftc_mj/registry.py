"""Find observer and controller plugins by name.

Built-in methods are always there. A third-party package adds its own by declaring an entry point, e.g. in
its ``pyproject.toml``::

    [project.entry-points."ftc_mj.observers"]
    my_observer = "my_package.module:MyObserver"

The class must follow :class:`ftc_mj.observers.Observer` (or :class:`ftc_mj.controllers.Controller`): a
``name``, a pydantic ``Config`` derived from :class:`ftc_mj.gains.GainConfig`, and the update methods.
"""

from __future__ import annotations

from functools import cache
from importlib.metadata import entry_points

from ftc_mj import controllers, observers

OBSERVER_GROUP = "ftc_mj.observers"
CONTROLLER_GROUP = "ftc_mj.controllers"


@cache
def _discover(group: str) -> dict[str, type]:
    builtin = observers.BUILTIN if group == OBSERVER_GROUP else controllers.BUILTIN
    found = dict(builtin)
    for entry in entry_points(group=group):
        if entry.name not in found:
            found[entry.name] = entry.load()
    return found


def observer_types() -> dict[str, type[observers.Observer]]:
    """Every observer plugin, by name."""
    return _discover(OBSERVER_GROUP)


def controller_types() -> dict[str, type[controllers.Controller]]:
    """Every controller plugin, by name."""
    return _discover(CONTROLLER_GROUP)
