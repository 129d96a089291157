"""Regions of a markdown file that a generator owns (tools/avr-cycle-table, tools/host-bench-table,
tools/bench-table).

A region is the text between two marker lines, which stay in place:

    <!-- begin generated: NAME (by tools/GENERATOR) -->
    ...replaced...
    <!-- end generated: NAME -->

The text in parentheses is free (it tells a reader which tool to run); NAME is what the tool looks for.
Markers are HTML comments, so the rendered page shows only the tables. Python 3 standard library only.
"""
import re
import sys


def _pattern(name):
    quoted = re.escape(name)
    return re.compile(r"(^<!-- begin generated: " + quoted + r"(?: [^\n]*)? -->\n)(.*?)(^<!-- end generated: "
                      + quoted + r" -->$)", re.MULTILINE | re.DOTALL)


def replace_regions(path, regions):
    """Replaces each region NAME of `path` with regions[NAME] (markdown text), or exits non-zero naming
    the region whose markers are missing or repeated. Writes the file only when every region is found."""
    with open(path, encoding="utf-8") as file:
        text = file.read()
    for name, body in regions.items():
        matches = list(_pattern(name).finditer(text))
        if len(matches) != 1:
            sys.exit(f"{path}: expected one region '<!-- begin generated: {name} ... -->' ... "
                     f"'<!-- end generated: {name} -->', found {len(matches)}")
        body = body if body.endswith("\n") else body + "\n"
        match = matches[0]
        text = text[:match.start(2)] + body + text[match.end(2):]
    with open(path, "w", encoding="utf-8") as file:
        file.write(text)
