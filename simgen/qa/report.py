"""The QA report on disk: index.html (one self-contained file: every image embedded as a data URI,
so it can be mailed or attached to a ticket alone; opens without a server or script) and report.md
with the same verdicts, tables and images (linked to plots/*.png beside it).

index.html marks its <body> with data-images-loaded="N/M" once the page has loaded, N of its M
images decoded, so a headless browser can tell that every plot is there.
"""

from __future__ import annotations

import base64
import html
from dataclasses import dataclass
from pathlib import Path

from simgen.atomic import atomic_path
from simgen.qa.checks import Check, summary

STYLE = """
body { font-family: sans-serif; margin: 2em auto; max-width: 1200px; color: #222; }
table { border-collapse: collapse; margin: 1em 0; font-size: 0.9em; }
th, td { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: left; }
th { background: #eee; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.pass td.verdict { background: #c8efc8; } tr.FAIL td.verdict { background: #f5b8b8; font-weight: bold; }
tr.n\\/a td.verdict { background: #e8e8e8; }
.banner { font-size: 1.4em; padding: 0.5em 0.8em; border-radius: 4px; }
.banner.PASS { background: #c8efc8; } .banner.FAIL { background: #f5b8b8; }
img { max-width: 100%; border: 1px solid #ddd; margin: 0.5em 0; }
"""

IMAGES_LOADED = """<script>
window.addEventListener("load", function () {
  var images = Array.prototype.slice.call(document.images);
  var loaded = images.filter(function (i) { return i.complete && i.naturalWidth > 0; }).length;
  document.body.setAttribute("data-images-loaded", loaded + "/" + images.length);
});
</script>"""


@dataclass(frozen=True)
class Table:
    header: tuple[str, ...]
    rows: tuple[tuple[str, ...], ...]


@dataclass(frozen=True)
class Section:
    title: str
    text: str = ""
    images: tuple[tuple[str, str], ...] = ()  # (path relative to the report, caption)
    tables: tuple[Table, ...] = ()


@dataclass(frozen=True)
class Report:
    title: str
    subject: str  # one line: what was checked, against what
    checks: tuple[Check, ...]
    sections: tuple[Section, ...]


def verdict_table(checks: tuple[Check, ...]) -> Table:
    return Table(("verdict", "subject", "check", "measured", "limit"),
                 tuple((c.verdict, c.subject, c.name, c.measured, c.limit) for c in checks))


def _html_table(table: Table, verdicts: bool = False) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in table.header)
    rows = []
    for row in table.rows:
        cells = "".join(
            f'<td class="{"verdict" if verdicts and i == 0 else "" if verdicts or i == 0 else "num"}">'
            f"{html.escape(v)}</td>"
            for i, v in enumerate(row)
        )
        rows.append(f'<tr class="{html.escape(row[0]) if verdicts else ""}">{cells}</tr>')
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def _md_table(table: Table) -> str:
    lines = ["| " + " | ".join(table.header) + " |", "|" + " --- |" * len(table.header)]
    lines += ["| " + " | ".join(v.replace("|", "\\|") for v in row) + " |" for row in table.rows]
    return "\n".join(lines)


def data_uri(path: Path) -> str:
    """A PNG file as a `data:` URI."""
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def to_html(report: Report, out_dir: Path) -> str:
    """The page, its images (paths relative to `out_dir`) embedded."""
    verdict = summary(list(report.checks))
    parts = [
        "<!DOCTYPE html>", '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(report.title)}</title><style>{STYLE}</style></head>",
        '<body data-images-loaded="pending">',
        f"<h1>{html.escape(report.title)}</h1><p>{html.escape(report.subject)}</p>",
        f'<p class="banner {verdict.split(":")[0]}">{html.escape(verdict)}</p>',
        "<h2>Verdicts</h2>", _html_table(verdict_table(report.checks), verdicts=True),
    ]
    for section in report.sections:
        parts.append(f"<h2>{html.escape(section.title)}</h2>")
        if section.text:
            parts.append(f"<p>{html.escape(section.text)}</p>")
        for path, caption in section.images:
            parts.append(
                f'<figure><img src="{data_uri(out_dir / path)}" '
                f'alt="{html.escape(caption)}"><figcaption>{html.escape(caption)}</figcaption></figure>'
            )
        parts += [_html_table(t) for t in section.tables]
    parts += [IMAGES_LOADED, "</body></html>"]
    return "\n".join(parts) + "\n"


def to_markdown(report: Report) -> str:
    parts = [f"# {report.title}", report.subject, f"**{summary(list(report.checks))}**", "## Verdicts",
             _md_table(verdict_table(report.checks))]
    for section in report.sections:
        parts.append(f"## {section.title}")
        if section.text:
            parts.append(section.text)
        parts += [f"![{caption}]({path})" for path, caption in section.images]
        parts += [_md_table(t) for t in section.tables]
    return "\n\n".join(parts) + "\n"


def write_report(report: Report, out_dir: Path) -> None:
    """index.html and report.md in `out_dir` (the images are already there)."""
    for name, text in (("index.html", to_html(report, out_dir)), ("report.md", to_markdown(report))):
        with atomic_path(out_dir / name) as tmp:
            tmp.write_text(text, encoding="utf-8")
