"""The site's mathematics: written once, in the docstrings (Sphinx's ``:math:`` role and ``.. math::``
directive) or in a page (``$...$``, ``$$...$$``), rendered to MathML when the site is built (no script, no
network): ``docs/_gen/reference.py``'s ``_rst_to_md`` and ``mathml``."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT / "docs" / "_gen"))
reference = pytest.importorskip("reference")
pytest.importorskip("latex2mathml")


def test_docstring_math_becomes_the_sites():
    text = reference._rst_to_md("so :math:`\\dot r = K_I (\\tau_f - r)` holds\n\n.. math::\n\n    r_k = K p_k\n\n"
                                "    z_{k+1} = z_k\n\nafter")
    assert "\\(\\dot r = K_I (\\tau_f - r)\\)" in text
    assert "\\[r_k = K p_k\\]" in text and "\\[z_{k+1} = z_k\\]" in text and text.rstrip().endswith("after")
    assert ".. math::" not in text and ":math:" not in text


def test_the_built_html_carries_mathml_not_tex():
    html = ('<p>x <span class="arithmatex">\\(a &lt; b_{k}\\)</span></p>'
            '<div class="arithmatex">\\[\\int_0^t r\\,ds\\]</div>')
    out = reference.mathml(html)
    assert out.count("<math") == 2 and 'display="inline"' in out and 'display="block"' in out
    assert "arithmatex" not in out and "\\(" not in out and "<mo>&#x0003C;</mo>" in out  # a < b as an operator


def test_the_momentum_observers_equations_are_written_as_math():
    from ftc_mj.methods.observers import momentum

    text = reference._rst_to_md(momentum.__doc__)
    assert text.count("\\[") >= 3 and text.count("\\(") >= 10
    assert "\\tau" in momentum.__doc__ and "\t" not in momentum.__doc__  # a raw docstring: no tab from \tau


def test_absolute_values_and_norms_are_fences_not_operators():
    """``\\lvert s \\rvert`` as an opening and a closing fence (latex2mathml alone writes two bare ``<mo>``, which
    a browser spaces as operators: ``| s |  =``), with or without a power; ``\\left\\lvert`` is left alone."""
    out = reference.mathml('<span class="arithmatex">\\(\\lvert s \\rvert^{1/2} \\le \\lVert \\hat s(0) \\rVert\\)</span>')
    assert out.count('form="prefix"') == 2 and out.count('form="postfix"') == 2
    assert "<mo>&#x0007C;</mo>" not in out and "\ue000" not in out and "\ue001" not in out
    assert out.index('form="prefix"') < out.index("<mi>s</mi>") < out.index('form="postfix"')
    stretchy = reference.mathml('<span class="arithmatex">\\(\\left\\lvert \\frac{a}{b} \\right\\rvert\\)</span>')
    assert "<mfrac>" in stretchy and 'stretchy="true"' in stretchy and "\ue000" not in stretchy
