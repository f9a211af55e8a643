"""The methods' equations are written as mathematics in their docstrings, once, and render on the site.

Every docstring and ``#:`` comment of :mod:`ftc_mj.methods` (what the methods reference and the API reference
show) writes its symbols and laws as ``:math:`` or ``.. math::``: outside mathematics, code and literal
blocks no plain-text equation is left (``x1_hat``, ``e_dot``, ``x1~``, ``M^-1``, ``sign(s)``, ``dz/dt``,
``|e|``, ``Psi``, ``<=``, ...), and neither in the tutorials' prose nor on the methods-at-a-glance page
(``$...$`` there), nor on any other hand-written page of the site (explanation, results, reference,
getting started: the same check, plus velocities, plain gain indices and functions spelled out: ``M qdd``,
``k1``, ``tanh(``). Every built-in method's page section shows at least one equation and cites where it comes
from (an equation number or a book's section), and every piece of mathematics converts to MathML with no
command left as text.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
METHODS = ROOT / "ftc_mj" / "methods"
sys.path.insert(0, str(ROOT / "docs" / "_gen"))
reference = pytest.importorskip("reference")
pytest.importorskip("latex2mathml")

#: Plain-text notation that the docstrings write as mathematics instead: a symbol with a hat, tilde or dot
#: spelled out, a state's name, a power, a sign, a derivative, an absolute value, a Greek letter spelled out,
#: a comparison, a reference trajectory's name.
PLAIN = {
    "spelled decoration": r"\b\w+_(?:hat|tilde|dot|ddot|bar)\b",
    "tilde suffix": r"\b[a-z]\d?~",
    "state name": r"\bx[123]\b",
    "power": r"\w\)?\^[\w(\-{]",
    "sign": r"\bsign\(",
    "derivative": r"\bd\w*/dt\b",
    "absolute value": r"\|[^|\s`][^|`]*[^|\s`]\||\|\w\|",
    "Greek spelled out": r"\b(?:Psi|Gamma|Delta|Lambda|Xi|zeta|lambda|alpha|beta|gamma|kappa|rho|omega|sigma|"
                         r"phi|mu|tau|nu|epsilon)(?:_?\w)?\b(?!-binomial)",  # the beta-binomial law is a name
    "comparison": r"<=|>=|!=",
    "reference trajectory": r"\bx{1,2}d*_d\b",
    "integral": r"\bintegral_",
    "function": r"\b(?:sqrt|exp|clip|sat)\(",
}
PLAIN_RE = re.compile("|".join(f"(?P<{re.sub(r'[^a-z]', '_', name)}>{pattern})" for name, pattern in PLAIN.items()))


def _prose(text: str) -> str:
    """``text`` without its mathematics, code, literal blocks and units in brackets: what is left is prose."""
    text = re.sub(r":math:`[^`]*`", " ", text)
    lines, out, skip_indent = text.splitlines(), [], None
    for line in lines:
        indent = len(line) - len(line.lstrip())
        if skip_indent is not None:
            if not line.strip() or indent > skip_indent:
                continue
            skip_indent = None
        if re.match(r"\s*\.\. math::\s*$", line) or line.rstrip().endswith("::"):
            skip_indent = indent
            line = line.rstrip()[:-2] if line.rstrip().endswith("::") and ".. math::" not in line else ""
        out.append(line)
    text = "\n".join(out)
    text = re.sub(r"``[^`]*``|`[^`]*`", " ", text)
    text = re.sub(r"^\s*\|(?:-+\|)+\s*$", " ", text, flags=re.MULTILINE)  # a Markdown table's rule
    text = re.sub(r"\[[^\]\n]*\]", " ", text)  # units, [rad/s^2]
    text = re.sub(r"^\s+\w+(?:, \w+)*:(?=\s)", " ", text, flags=re.MULTILINE)  # the names of a Google section
    return re.sub(r":(?:class|func|meth|mod|data|attr|exc|obj):", " ", text)


def _texts(path: Path) -> list[tuple[str, str]]:
    """(where, text) of every docstring and every ``#:`` comment block of a module."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = ast.get_docstring(node, clean=True)
            if doc:
                found.append((f"{path.relative_to(ROOT)}: {getattr(node, 'name', 'module')}", doc))
    comment: list[str] = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if line.strip().startswith("#:"):
            comment.append(line.strip()[2:])
        elif comment:
            found.append((f"{path.relative_to(ROOT)}:{number - 1}: #:", "\n".join(comment)))
            comment = []
    return found


def _all_texts() -> list[tuple[str, str]]:
    return [item for path in sorted(METHODS.rglob("*.py")) for item in _texts(path)]


def plain_equations(text: str) -> list[str]:
    """The plain-text notation left in ``text``'s prose, each with its line."""
    hits = []
    for line in _prose(text).splitlines():
        for match in PLAIN_RE.finditer(line):
            hits.append(f"{match.group(0)!r} in: {line.strip()}")
    return hits


def test_the_check_finds_plain_text_equations_and_passes_prose():
    """The check itself: the methods' docstrings as they were (plain text) fail, their conversion and prose
    about the same things pass."""
    for plain in ("dx1_hat/dt = x2_hat + k1 |x1_tilde|^(1/2) sign(x1_tilde)", "with x1~ = x1 - x1_hat",
                  "u = -M(x1) (u_eq + u_c + u_sw)", "K_hat' = rho |s|", "e = x1 - x_d and e_dot = x2 - xd_d",
                  "the gains 3 omega_o, 3 omega_o^2, omega_o^3", "only while |s| >= epsilon",
                  "d_hat = z + p(qd), dz/dt = -L z", "Levant's k1 = 1.5 L^(1/2)", "tau = sat(v)"):
        assert plain_equations(plain), plain
    for fine in (r"with :math:`\tilde x_1 = x_1 - \hat x_1`, the estimate ``luaf_hat`` (the signal ``residual``)",
                 ".. math::\n\n    \\dot z = k_2 \\operatorname{sign}(\\tilde x_2)\n\nafter it, Table 2.2's gains",
                 "its pyproject.toml::\n\n    my_observer = \"pkg:Obs\"\n\nthen | ``smc`` | (3.46) | any |",
                 "Levant 2003, eqs. (8)-(9); the TOSMO (3.11) with the LUaF estimate (3.15), e.g. Fig. 2.8"):
        assert not plain_equations(fine), (fine, plain_equations(fine))


def test_no_plain_text_equation_is_left_in_the_methods_docstrings():
    texts = _all_texts()
    assert len(texts) > 150
    left = [f"{where}: {hit}" for where, text in texts for hit in plain_equations(text)]
    assert not left, "\n".join(left)


def _math(text: str) -> list[str]:
    """Every piece of mathematics in a docstring, as the site renders it (``\\( \\)``, ``\\[ \\]``)."""
    md = reference._rst_to_md(text)
    return re.findall(r"\\\((.*?)\\\)", md, re.DOTALL) + re.findall(r"\\\[(.*?)\\\]", md, re.DOTALL)


def test_every_equation_converts_to_mathml_without_a_command_left_as_text():
    from latex2mathml.converter import convert

    count = 0
    for where, text in _all_texts():
        for tex in _math(text):
            count += 1
            assert tex.count("{") == tex.count("}"), f"{where}: unbalanced braces in {tex}"
            sizes = len(re.findall(r"\\left\b", tex)), len(re.findall(r"\\right\b", tex))
            assert sizes[0] == sizes[1], f"{where}: \\left without \\right in {tex}"
            mathml = convert(tex)
            assert not re.search(r">\\[A-Za-z]+<", mathml), f"{where}: an unknown command in {tex}"
            assert "<mi>}</mi>" not in mathml and "<mi>{</mi>" not in mathml, f"{where}: {tex}"
    assert count > 300


#: An equation number of the dissertation or a paper ("(5.6)", "eqs. (8)-(9)"), or a book's section.
CITATION = re.compile(r"\(\d+\.\d+\)|\beqs?\. \(\d+\)|\bsection \d+\.\d+")


@pytest.mark.parametrize("kind", ["observers", "controllers"])
def test_every_method_shows_an_equation_and_cites_its_source(kind):
    import importlib
    import inspect

    registry = importlib.import_module(f"ftc_mj.methods.{kind}").BUILTIN
    assert len(registry) >= 10
    for name, cls in registry.items():
        shown = (inspect.getdoc(cls) or "") + "\n\n" + (inspect.getdoc(sys.modules[cls.__module__]) or "")
        assert _math(shown), f"{name}: no equation on its section of the methods page"
        assert CITATION.search(shown), f"{name}: no equation number or section cited"


def _markdown_prose(text: str) -> str:
    """A page's prose: without its code blocks, mathematics, links' targets and units (``kg m^2``)."""
    text = re.sub(r"```.*?```", " ", text, flags=re.DOTALL)
    text = re.sub(r"\$\$.*?\$\$", " ", text, flags=re.DOTALL)
    text = re.sub(r"\$[^$\n]+\$", " ", text)
    text = re.sub(r"\]\([^)]*\)", "]", text)
    text = re.sub(r"^\s*\|(?:\s*:?-+:?\s*\|)+\s*$", " ", text, flags=re.MULTILINE)  # a table's rule, aligned
    return re.sub(r"\b(?:kg m|rad/s|m/s|rad|1/s)\^\d", " ", text)


def test_the_tutorials_and_the_methods_at_a_glance_write_their_equations_as_mathematics():
    pages = [*sorted((ROOT / "docs" / "tutorials").glob("*.md")), ROOT / "docs" / "explanation" / "methods.md"]
    assert len(pages) >= 6
    left = [f"{page.name}: {hit}" for page in pages for hit in plain_equations(_markdown_prose(page.read_text()))]
    assert not left, "\n".join(left)
    assert plain_equations(_markdown_prose("a law u = -M(x1) (u_eq + u_sw) in [kg m^2]"))
    assert not plain_equations(_markdown_prose("a law $u = -M(x_1) u_{sw}$ in kg m^2\n```\nqd_hat = x^2\n```"))


#: Notation the pages write as mathematics beside :data:`PLAIN` (the docstrings name their configuration's
#: fields ``k1``, ``qd`` in prose, the pages in code font): a velocity or acceleration spelled out, a gain
#: with a plain index, a function of the formulas.
PAGE_PLAIN = re.compile(r"\bq(?:d|dd|ddd)\b|\b[kp]\d\b|\b(?:tanh|sin|cos|tan|log|ln)\(")

#: Pages that a command writes as it is, checked where they are generated: the benchmark's leaderboard
#: (``ftc-mj bench``) and the tuning reports (``ftc-mj tune``).
GENERATED = ("results/benchmark-v2-full.md", "results/tuning/*/report.md")


def _page_plain_equations(text: str) -> list[str]:
    """The plain-text notation left in a page's prose, each with its line."""
    prose = _markdown_prose(text)
    hits = plain_equations(prose)
    for line in _prose(prose).splitlines():
        hits += [f"{match.group(0)!r} in: {line.strip()}" for match in PAGE_PLAIN.finditer(line)]
    return hits


def _hand_written_pages() -> list[Path]:
    docs = ROOT / "docs"
    generated = {path for pattern in GENERATED for path in docs.glob(pattern)}
    return [page for page in sorted(docs.rglob("*.md")) if page not in generated]


def test_the_check_of_the_pages_finds_their_old_plain_text():
    """The pages' plain text as it was fails, and what replaced it passes: the check can fail."""
    for old in ("Plant terms, following (3.1) M qdd + C qd + G + F + tau_d = tau and (3.7)",
                "Levant's k1 = 1.5 L^(1/2), k2 = 1.1 L", "with Gamma x1~ feeding the quantisation error",
                "| super-twisting: |s|^1 instead of |s|^(1/2) |   |   | yes |",
                "| momentum: C^T qd - G as G - C^T qd |", "F = o + b qd + c tanh(50 qd) per joint",
                "NaN, inf, |q| above `divergence.max_position`", "| Gamma | 5 | 22.2 |",
                "the DO goes past the truth (max |x2~|)", "K_d = 2 sqrt(K_p): a double pole",
                "the 5-sigma thresholds", "L = 22 (k1 = 7.04, k2 = 24.2)", "On a fresh machine with Python >= 3.11"):
        assert _page_plain_equations(old), old
    for new in (r"Plant terms, following (3.1) $M \ddot q + C \dot q + G + F + \tau_d = \tau$ and (3.7)",
                r"Levant's $k_1 = 1.5 L^{1/2}$, $k_2 = 1.1 L$", r"with $\Gamma \tilde x_1$ feeding the error",
                r"| super-twisting: $\lvert s \rvert^{1}$ instead of $\lvert s \rvert^{1/2}$ |   |   | yes |",
                "|---|---:|---:|\n| `qd_hat`, `k1` | the field `tanh` |", "the $5\\sigma$ thresholds"):
        assert not _page_plain_equations(new), (new, _page_plain_equations(new))


def test_every_hand_written_page_writes_its_equations_as_mathematics():
    pages = _hand_written_pages()
    names = {page.relative_to(ROOT / "docs").as_posix() for page in pages}
    assert {"results/reproduction.md", "results/arms.md", "explanation/assumptions.md", "index.md"} <= names
    assert "results/benchmark-v2-full.md" not in names and len(pages) >= 30
    left = [f"{page.relative_to(ROOT)}: {hit}" for page in pages for hit in _page_plain_equations(page.read_text())]
    assert not left, "\n".join(left)
