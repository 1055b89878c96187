"""The index of the papers' equations in the code (docs/reference/equations.md) is current.

The page is generated from the code's own references: every docstring (module, class,
function or method) under ``src/redservo`` that cites ``CM01 eq. N`` or ``MC05 eq. N`` (or a
range, ``eqs. 27-29``, or a list, ``eqs. 13-15, 18``) puts its object under each equation it
cites, with its signature, its first docstring paragraph and its file (no line numbers:
the page changes only when a citing docstring or signature does). After
changing such a docstring, regenerate it with ``python tests/test_equation_index.py --write``.
"""

from __future__ import annotations

import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SRC = ROOT / "src" / "redservo"
PAGE = ROOT / "docs" / "reference" / "equations.md"
PAPERS = {
    "CM01": "F. Chaumette, E. Marchand, *A redundancy-based iterative approach for avoiding "
    "joint limits: application to visual servoing*, IEEE T-RA 17(5), 2001.",
    "MC05": "N. Mansard, F. Chaumette, *Directional redundancy: a new approach of the "
    "redundancy formalism*, IEEE CDC-ECC 2005.",
}
CITE = re.compile(
    r"\b(CM01|MC05)[,:]?\s+eqs?\.\s*((?:\d+[a-z]?(?:\s*[-–]\s*\d+)?)(?:\s*,\s*\d+(?:\s*[-–]\s*\d+)?)*)"
)


def _numbers(text: str) -> list[int]:
    out: list[int] = []
    for part in text.split(","):
        bounds = [int(re.sub(r"\D", "", b)) for b in re.split(r"[-–]", part) if b.strip()]
        if len(bounds) == 2 and 0 < bounds[1] - bounds[0] < 40:
            out.extend(range(bounds[0], bounds[1] + 1))
        elif bounds:
            out.append(bounds[0])
    return out


def _objects() -> list[tuple[str, str, int, str, str]]:
    """``(qualified name, file, line, signature, docstring)`` of every documented object."""
    found = []
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(ROOT).as_posix()
        parts = path.relative_to(SRC.parent).with_suffix("").parts
        mod = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        doc = ast.get_docstring(tree)
        if doc:
            found.append((mod, rel, 1, "module", doc))

        def walk(node: ast.AST, prefix: str, rel: str = rel) -> None:
            for child in ast.iter_child_nodes(node):
                if isinstance(child, ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
                    name = f"{prefix}.{child.name}"
                    d = ast.get_docstring(child)
                    if d:
                        if isinstance(child, ast.ClassDef):
                            sig = f"class {child.name}"
                        else:
                            sig = f"def {child.name}({ast.unparse(child.args)})"
                        found.append((name, rel, child.lineno, sig, d))
                    if isinstance(child, ast.ClassDef):
                        walk(child, name)

        walk(tree, mod)
    return found


def render() -> str:
    index: dict[tuple[str, int], list[str]] = {}
    objects: dict[str, tuple[str, int, str, str]] = {}
    for name, rel, line, sig, doc in _objects():
        cited = {(p, n) for p, nums in CITE.findall(doc) for n in _numbers(nums)}
        for key in cited:
            index.setdefault(key, []).append(name)
        if cited:
            objects[name] = (rel, line, sig, doc)
    anchor = {name: f"code-{i}" for i, name in enumerate(sorted(objects))}
    out = [
        "# Equations of the papers in the code",
        "",
        "Where the code implements or uses each equation of the two papers, found from the "
        "references in its docstrings (generated: `python tests/test_equation_index.py "
        "--write`; a test keeps this page current). Each name links to the object's signature, "
        "the first paragraph of its docstring and its file, below. The equations "
        "themselves are written out in [Formulas](../formulas.md).",
        "",
    ]
    for paper, title in PAPERS.items():
        out += [f"## {paper}", "", title, "", "| eq. | in the code |", "|---:|---|"]
        for p, n in sorted(k for k in index if k[0] == paper):
            names = sorted(set(index[(p, n)]))
            links = ", ".join(f"[`{m.removeprefix('redservo.')}`](#{anchor[m]})" for m in names)
            out.append(f"| {n} | {links} |")
        out.append("")
    out += ["## The code", ""]
    for name in sorted(objects):
        rel, line, sig, doc = objects[name]
        first = doc.strip().split("\n\n")[0].replace("\n", " ")
        out += [
            f'<a id="{anchor[name]}"></a>',
            "",
            f"**`{name}`**, `{rel}`",
            "",
            "```text",
            sig if len(sig) < 300 else sig[:297] + "...",
            "```",
            "",
            f"> {first}",
            "",
        ]
    return "\n".join(out).rstrip() + "\n"


def test_the_equation_index_is_current() -> None:
    assert PAGE.read_text(encoding="utf-8") == render(), (
        "docs/reference/equations.md is stale: run python tests/test_equation_index.py --write"
    )


def test_the_index_finds_the_equations_a_newcomer_looks_for() -> None:
    text = render()
    for paper, eq in (("CM01", 11), ("MC05", 18), ("CM01", 25), ("CM01", 3), ("MC05", 30)):
        section = text.split(f"## {paper}")[1].split("\n## ")[0]
        assert re.search(rf"^\| {eq} \| \[", section, re.M), f"{paper} eq. {eq} is not indexed"


def test_ranges_and_lists_are_expanded() -> None:
    assert _numbers("27-29") == [27, 28, 29]
    assert _numbers("13-15, 18, 21") == [13, 14, 15, 18, 21]
    assert _numbers("8") == [8]


if __name__ == "__main__":
    if "--write" in sys.argv:
        PAGE.write_text(render(), encoding="utf-8")
        print(f"wrote {PAGE}")
