"""The report generator: ``data/*.json`` in, ``report.md`` and ``report.html`` out.

Every number in the report is rendered from the JSON files by the templates in
``validation/templates/`` (through :func:`validation.formatting.format_number`); nothing in
the text is typed by hand.
"""

from __future__ import annotations

import base64
import json
from pathlib import Path

import jinja2

from validation.formatting import format_number
from validation.section import Section

__all__ = ["render_paragraphs", "write_report"]

TEMPLATES = Path(__file__).resolve().parent / "templates"


def _markdown_cell(text) -> str:
    """A table cell for GitHub markdown: pipes escaped."""
    return str(text).replace("|", "\\|")


def _environment(autoescape: bool, trim_blocks: bool = True) -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(TEMPLATES),
        autoescape=autoescape,
        undefined=jinja2.StrictUndefined,
        trim_blocks=trim_blocks,
        lstrip_blocks=trim_blocks,
        keep_trailing_newline=True,
    )
    env.filters["num"] = format_number
    env.filters["md_cell"] = _markdown_cell
    return env


def render_paragraphs(section: Section) -> list[str]:
    """The section's text: its template rendered with its summary, split at blank lines."""
    name = section.template or section.study
    # block tags keep their newlines here, so a blank line always separates paragraphs
    env = _environment(False, trim_blocks=False)
    text = env.get_template(f"sections/{name}.md.j2").render(s=section.summary)
    paragraphs = [" ".join(block.split()) for block in text.split("\n\n")]
    return [p for p in paragraphs if p]


def _embedded_png(path: Path) -> str:
    return "data:image/png;base64," + base64.b64encode(path.read_bytes()).decode("ascii")


def write_report(out: Path, study_names: list[str]) -> tuple[Path, Path]:
    """Render ``report.md`` and ``report.html`` in ``out`` from ``out/data``.

    Parameters
    ----------
    out : Path
        Report folder holding ``data/campaign.json``, ``data/<study>.json``, ``figures/``.
    study_names : list of str
        Sections in report order; a study without a data file is left out.

    Returns
    -------
    (Path, Path)
        The markdown and HTML files.
    """
    out = Path(out)
    campaign = json.loads((out / "data" / "campaign.json").read_text(encoding="utf-8"))
    sections = []
    for name in study_names:
        path = out / "data" / f"{name}.json"
        if path.is_file():
            sections.append(json.loads(path.read_text(encoding="utf-8")))
    for section in sections:
        for figure in section["figures"]:
            figure["embedded"] = _embedded_png(out / "figures" / figure["file"])
    context = {"campaign": campaign, "sections": sections}
    markdown = out / "report.md"
    markdown.write_text(
        _environment(False).get_template("report.md.j2").render(**context), encoding="utf-8"
    )
    html = out / "report.html"
    html.write_text(
        _environment(True).get_template("report.html.j2").render(**context), encoding="utf-8"
    )
    return markdown, html
