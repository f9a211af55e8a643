"""The colours and line styles of every figure the package draws: a run's figures and its recording's viewer
(:func:`ftc_mj.outputs.layout.variant_styles`), a campaign's report figures and a tuning's convergence figure.

All colours are matplotlib's ``tab10`` plus black, named so that the viewer's legend and the recording's info
page can say "red: proposed". Each output assigns them to variants in its own order (:data:`RUN_ORDER`,
:data:`CAMPAIGN_ORDER`): a run's figures follow the dissertation (the proposed method red, TOSMO blue, SOSMO
green, then black), a campaign's report lists its reference variant first in blue.
"""

from __future__ import annotations

#: Colour name -> "#rrggbb".
COLOURS: dict[str, str] = {
    "red": "#d62728", "blue": "#1f77b4", "green": "#2ca02c", "black": "#000000", "orange": "#ff7f0e",
    "purple": "#9467bd", "brown": "#8c564b", "pink": "#e377c2", "cyan": "#17becf", "olive": "#bcbd22",
    "grey": "#7f7f7f",
}
#: "#rrggbb" -> colour name.
NAMES: dict[str, str] = {code: name for name, code in COLOURS.items()}

#: The variants' colours, in order, in a run's figures and its recording.
RUN_ORDER: tuple[str, ...] = tuple(COLOURS[name] for name in (
    "red", "blue", "green", "black", "orange", "purple", "brown", "pink", "cyan", "olive", "grey"))
#: The variants' colours, in order, in a campaign's report figures.
CAMPAIGN_ORDER: tuple[str, ...] = tuple(COLOURS[name] for name in (
    "blue", "red", "green", "purple", "orange", "brown", "pink", "grey"))
#: matplotlib line styles cycled with the campaign colours, so overlapping curves stay apart.
CAMPAIGN_LINE_STYLES: tuple[str, ...] = ("-", "--", "-.", ":")


def colour_name(code: str) -> str:
    """The name of a palette colour, else the code itself."""
    return NAMES.get(code, code)
