"""The manual stays true to the code (issue 36).

* ``docs/cli.md`` is what ``make docs`` generates from the Typer app now
  (``typer gyrocomp.cli utils docs``, the title read from the Makefile);
* every command and every option has help (the source of that page);
* every relative link of ``README.md``, ``docs/`` and ``benchmarks/`` points
  at a file that exists and, with ``#anchor``, at a heading of it (GitHub's
  slugs);
* every equation the code cites is in ``docs/equations.md`` beside its function;
* the README stays a first screen: at most 250 lines.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
import typer
from typer.testing import CliRunner

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md"), *(ROOT / "benchmarks").glob("*.md")])


def test_cli_reference_is_generated_from_the_app(tmp_path):
    import typer.cli

    title = re.search(r"^CLI_DOCS_TITLE := '(.*)'$", (ROOT / "Makefile").read_text(), re.M).group(1)
    out = tmp_path / "cli.md"
    result = CliRunner().invoke(typer.cli.app, ["gyrocomp.cli", "utils", "docs", "--name", "gyrocomp", "--title", title, "--output", str(out)])
    assert result.exit_code == 0, result.output
    assert (ROOT / "docs" / "cli.md").read_text(encoding="utf-8") == out.read_text(encoding="utf-8"), "docs/cli.md is stale: run `make docs`"


def test_every_command_and_option_has_help():
    from gyrocomp.cli import app

    missing = []

    def walk(command, path):
        if not (command.help or "").strip():
            missing.append(" ".join(path))
        missing.extend(f"{' '.join(path)} {p.name}" for p in command.params if not (getattr(p, "help", None) or "").strip())
        for name, sub in getattr(command, "commands", {}).items():
            walk(sub, [*path, name])

    walk(typer.main.get_command(app), ["gyrocomp"])
    assert missing == []


def slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: link text kept, lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading.strip().lower())
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(page: Path) -> set[str]:
    seen: dict[str, int] = {}
    found = set()
    for line in _prose(page.read_text(encoding="utf-8")):
        match = re.match(r"^#{1,6}\s+(.*?)\s*#*\s*$", line)
        if match:
            base = slug(match.group(1))
            n = seen.get(base, 0)
            seen[base] = n + 1
            found.add(base if n == 0 else f"{base}-{n}")
    return found


def links(page: Path) -> list[tuple[int, str]]:
    """``(line, target)`` of every Markdown link and image outside code."""
    found = []
    for number, line in enumerate(_prose(page.read_text(encoding="utf-8")), 1):
        line = re.sub(r"`[^`]*`", "", line)
        found.extend((number, m.group(1)) for m in re.finditer(r"\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)", line))
    return found


def broken(page: Path, root: Path = ROOT) -> list[str]:
    out = []
    for number, target in links(page):
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # https:, mailto:
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            out.append(f"{page.relative_to(root)}:{number}: {target} (no such file)")
        elif anchor and (dest.suffix != ".md" or anchor not in anchors(dest)):
            out.append(f"{page.relative_to(root)}:{number}: {target} (no such heading)")
    return out


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_and_anchors_resolve(page):
    assert broken(page) == []


def test_the_link_check_sees_a_broken_file_and_anchor(tmp_path):
    (tmp_path / "a.md").write_text("# Top `level`: one\n\n## Two, three\n\nsee [b](b.md), [x](#two-three), [y](#top-level-one)\n")
    (tmp_path / "b.md").write_text("# B\n\n```\n[not a link](nowhere.md)\n```\n[gone](c.md) [bad](a.md#four) [ok](a.md#two-three) [web](https://example.org/x.md)\n")
    assert broken(tmp_path / "a.md", tmp_path) == []
    assert broken(tmp_path / "b.md", tmp_path) == ["b.md:6: c.md (no such file)", "b.md:6: a.md#four (no such heading)"]


def _prose(text: str) -> list[str]:
    """The lines of a Markdown text, those inside fenced code blocks blanked (line numbers kept)."""
    out, fenced = [], False
    for line in text.splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
            out.append("")
        else:
            out.append("" if fenced else line)
    return out


CITATION = re.compile(r"\b[Ee]qs?\.\s*\(?((?:C\.)?\d+(?:\.\d+)?)\)?((?:\s*(?:[–-]|,|and)\s*\(?(?:C\.)?\d+(?:\.\d+)?\)?)*)")


def citations() -> set[tuple[str, str]]:
    """``(dotted name of the function, class or module, equation number)`` for every equation the package cites."""
    found = set()
    for path in sorted((ROOT / "gyrocomp").rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        module = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
        tree = ast.parse(path.read_text(encoding="utf-8"))
        scopes = []

        def visit(node, prefix):
            for child in ast.iter_child_nodes(node):
                if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                    name = f"{prefix}.{child.name}"
                    scopes.append((child.lineno, child.end_lineno, name))
                    visit(child, name)
                else:
                    visit(child, prefix)

        visit(tree, module)
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            for match in CITATION.finditer(line):
                inside = [s for s in scopes if s[0] <= number <= s[1]]
                where = min(inside, key=lambda s: s[1] - s[0])[2] if inside else module
                for eq in [match.group(1), *re.findall(r"(?:C\.)?\d+(?:\.\d+)?", match.group(2) or "")]:
                    found.add((where, eq))
    return found


def _numbers(cell: str) -> set[str]:
    """Equation numbers of a table cell, ranges such as (4)–(11) expanded."""
    out = set(re.findall(r"(?:C\.)?\d+(?:\.\d+)?", cell))
    for a, b in re.findall(r"\((\d+)\)[–-]\((\d+)\)", cell):
        out.update(str(k) for k in range(int(a), int(b) + 1))
    return out


def test_every_cited_equation_is_mapped_to_its_function():
    rows = [line.split("|") for line in (ROOT / "docs" / "equations.md").read_text(encoding="utf-8").splitlines() if line.startswith("| ")]
    mapped = {(name, eq) for row in rows for name in re.findall(r"`([\w.]+)`", row[-2]) for eq in _numbers(row[1])}
    missing = sorted(c for c in citations() if c not in mapped)
    assert missing == [], "add these to docs/equations.md: " + ", ".join(f"{w} eq. ({e})" for w, e in missing)


def test_readme_is_a_first_screen():
    assert len((ROOT / "README.md").read_text(encoding="utf-8").splitlines()) <= 250
