"""The colours and line styles of every figure the package draws: a run's figures and its recording's viewer
(:func:`ftc_mj.outputs.layout.variant_styles`), a campaign's report figures and a tuning's convergence figure.

All colours are matplotlib's ``tab10`` plus black, named so that the viewer's legend and the recording's info
page can say "red: proposed". A variant has one colour everywhere (:func:`assign_colours`): the one its
scenario gives it (``variants.NAME.colour``), else the first colour of :data:`ORDER` that no variant before
it in the scenario file has, in the order the file declares them (each variant followed by its monitors).
Running fewer variants (``--variant``), a campaign or a tuning of the same scenario keeps every colour. The
order follows the dissertation's figures: the proposed method red, TOSMO blue, SOSMO green, then black.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping

#: Colour name -> "#rrggbb".
COLOURS: dict[str, str] = {
    "red": "#d62728", "blue": "#1f77b4", "green": "#2ca02c", "black": "#000000", "orange": "#ff7f0e",
    "purple": "#9467bd", "brown": "#8c564b", "pink": "#e377c2", "cyan": "#17becf", "olive": "#bcbd22",
    "grey": "#7f7f7f",
}
#: "#rrggbb" -> colour name.
NAMES: dict[str, str] = {code: name for name, code in COLOURS.items()}

#: The order in which variants without a colour of their own take the free colours.
ORDER: tuple[str, ...] = tuple(COLOURS[name] for name in (
    "red", "blue", "green", "black", "orange", "purple", "brown", "pink", "cyan", "olive", "grey"))
#: matplotlib line styles cycled with the campaign colours, so overlapping curves stay apart.
CAMPAIGN_LINE_STYLES: tuple[str, ...] = ("-", "--", "-.", ":")

_HEX = re.compile(r"^#[0-9a-fA-F]{6}$")


def colour_name(code: str) -> str:
    """The name of a palette colour, else the code itself."""
    return NAMES.get(code, code)


def parse_colour(text: str) -> str:
    """A colour as a scenario writes it (a name of :data:`COLOURS` or ``#rrggbb``) as lowercase ``#rrggbb``.

    Raises:
        ValueError: neither a palette name nor ``#rrggbb``.
    """
    if text in COLOURS:
        return COLOURS[text]
    if _HEX.match(text):
        return text.lower()
    raise ValueError(f"{text!r} is not a colour: use #rrggbb or one of {', '.join(COLOURS)}")


def assign_colours(names: Iterable[str], pinned: Mapping[str, str] = {}) -> dict[str, str]:
    """One colour per name, in the order given (a scenario's declared order): a ``pinned`` colour (a name or
    ``#rrggbb``) as given, every other name the first colour of :data:`ORDER` that neither a pinned colour nor
    an earlier name has; once all are taken, :data:`ORDER` again, from the start."""
    names = list(names)
    taken = {parse_colour(pinned[n]) for n in names if n in pinned}
    free = [code for code in ORDER if code not in taken]
    colours: dict[str, str] = {}
    spare = 0
    for name in names:
        if name in pinned:
            colours[name] = parse_colour(pinned[name])
        elif free:
            colours[name] = free.pop(0)
        else:
            colours[name] = ORDER[spare % len(ORDER)]
            spare += 1
    return colours


def declared_colours(variants: Mapping[str, Mapping]) -> dict[str, str]:
    """The colour of every variant and monitor (``<variant>.<monitor>``) of a scenario's ``variants`` section
    as written (YAML mappings, in the file's order): :func:`assign_colours` over the variants, each followed by
    its monitors."""
    names: list[str] = []
    pinned: dict[str, str] = {}
    for name, variant in variants.items():
        names.append(name)
        if isinstance(variant, Mapping):
            if variant.get("colour") is not None:
                pinned[name] = str(variant["colour"])
            names.extend(f"{name}.{monitor}" for monitor in (variant.get("monitors") or {}))
    return assign_colours(names, pinned)
