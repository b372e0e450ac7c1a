"""What a study hands to the report: its text, tables and figures, and the numbers behind them."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

__all__ = ["Figure", "Section", "Table"]


@dataclass
class Table:
    """A table whose cells are already rendered strings.

    Parameters
    ----------
    caption : str
        One line above the table.
    columns : list of str
        Header cells.
    rows : list of list of str
        Body cells, each row as long as ``columns``; numbers rendered by
        :func:`validation.formatting.format_number` from the study's data.
    """

    caption: str
    columns: list[str]
    rows: list[list[str]]


@dataclass
class Figure:
    """A figure file written by the study into the report's figures folder.

    Parameters
    ----------
    file : str
        File name inside ``figures/``.
    caption : str
        One line under the figure.
    """

    file: str
    caption: str


@dataclass
class Section:
    """One study's part of the report.

    Parameters
    ----------
    study : str
        Name of the study.
    title : str
        Section heading.
    summary : dict
        JSON-able numbers the text, tables and figures are drawn from; saved to
        ``data/<study>.json`` beside the per-case records.
    paragraphs : list of str
        Text rendered from ``summary`` by a template in ``validation/templates/``.
    tables : list of Table
    figures : list of Figure
    template : str, optional
        Name of the text template, ``validation/templates/sections/<template>.md.j2``; the
        study's name by default.
    """

    study: str
    title: str
    summary: dict
    paragraphs: list[str] = field(default_factory=list)
    tables: list[Table] = field(default_factory=list)
    figures: list[Figure] = field(default_factory=list)
    template: str | None = None

    def to_json(self) -> dict:
        """The section as plain JSON-able data."""
        return asdict(self)
