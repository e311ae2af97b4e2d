"""Reads the Markdown the project's docstrings use where reST differs.

Docstrings here draw block diagrams in Markdown code fences (```) and lay out tables as
Markdown pipe tables, which read well in the source and in `help()`. reST has neither: a
fence is an unterminated inline literal and a table is a line block. Before autodoc parses a
docstring, this turns each fence into a literal block and each pipe table (a header row, a
`| --- |` rule, body rows) into a `list-table`, and separates a code span from a letter that
follows it (`name`s). Everything else is left to reST.
"""

from __future__ import annotations

import re

from sphinx.util import logging

logger = logging.getLogger(__name__)

FENCE = re.compile(r"^(\s*)```")
TABLE_ROW = re.compile(r"^\s*\|.*\|\s*$")
TABLE_RULE = re.compile(r"^\s*\|(\s*:?-{3,}:?\s*\|)+\s*$")
# A code span directly followed by a letter (`RgbdSensor`s): Markdown reads it, reST needs an
# escaped space between the two.
CODE_THEN_WORD = re.compile(r"(?<![`\w])(`[^`\n]+`)(?=\w)")


def _cells(row: str) -> list[str]:
    # A cell may hold a literal | written \| (reST reads that escape too).
    return [cell.strip() for cell in re.split(r"(?<!\\)\|", row.strip()[1:-1])]


def _fence(lines: list[str], start: int, out: list[str]) -> int:
    """Appends the fence at `start` as a literal block; returns the index after its end."""
    indent = FENCE.match(lines[start]).group(1)
    end = start + 1
    while end < len(lines) and not FENCE.match(lines[end]):
        end += 1
    if end == len(lines):
        raise ValueError(f"a ``` code fence opened on line {start + 1} is never closed")
    if out and out[-1].strip():
        out.append("")
    out += [f"{indent}::", ""]
    out += [f"{indent}    {line}" if line.strip() else "" for line in lines[start + 1 : end]]
    out.append("")
    return end + 1


def _table(lines: list[str], start: int, out: list[str]) -> int:
    """Appends the pipe table at `start` as a list-table; returns the index after it."""
    indent = re.match(r"\s*", lines[start]).group(0)
    header = _cells(lines[start])
    end = start + 2
    rows = [header]
    while end < len(lines) and TABLE_ROW.match(lines[end]):
        rows.append(_cells(lines[end]))
        end += 1
    for row in rows:
        if len(row) != len(header):
            raise ValueError(
                f"a table row has {len(row)} cells, its header {len(header)}: {row} "
                "(write a literal | inside a cell as \\|)"
            )
    if out and out[-1].strip():
        out.append("")
    out += [f"{indent}.. list-table::", f"{indent}   :header-rows: 1", ""]
    for row in rows:
        out.append(f"{indent}   * - {row[0]}".rstrip())
        out += [f"{indent}     - {cell}".rstrip() for cell in row[1:]]
    out.append("")
    return end


def markdown_to_rest(lines: list[str]) -> list[str]:
    """The docstring's lines with its fences and pipe tables in reST."""
    out: list[str] = []
    i = 0
    while i < len(lines):
        if FENCE.match(lines[i]):
            i = _fence(lines, i, out)
        elif TABLE_ROW.match(lines[i]) and i + 1 < len(lines) and TABLE_RULE.match(lines[i + 1]):
            i = _table(lines, i, out)
        else:
            out.append(CODE_THEN_WORD.sub(r"\1\\ ", lines[i]))
            i += 1
    return out


def _process_docstring(app, what, name, obj, options, lines: list[str]) -> None:
    try:
        lines[:] = markdown_to_rest(lines)
    except ValueError as error:
        logger.warning(f"docstring of {name}: {error}", type="markdown_docstrings")


def setup(app):
    # Before napoleon (priority 500) reads the sections.
    app.connect("autodoc-process-docstring", _process_docstring, priority=400)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
