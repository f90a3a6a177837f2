"""What a section of ``slipnav results`` is (studies/results_page.py writes the page): its Section entry,
the Context its measure gets, SectionSkipped, and the markdown it is written in (tables, numbers, the
mean and worst over seeds).

A section's measure takes a Context and returns markdown: one short present-tense sentence of what it
measures, then one or more tables. Its figures come from the studies' own functions (studies/,
scenarios/), called as the study commands call them; their printed reports go to ``Context.report``
(the page keeps the figures, not the report).
"""

from __future__ import annotations

import dataclasses as dc
import io
import math
import sys
import textwrap
from collections.abc import Callable
from pathlib import Path as FilePath

import numpy as np

WRAP = 110
"""Column at which the page's prose is wrapped (its tables are not: each row stays one line)."""


class SectionSkipped(Exception):
    """A section that cannot be measured here (e.g. its dataset is absent): the message, a full sentence,
    is written in the page in place of the figures."""


@dc.dataclass
class Context:
    """What a section's measure gets.

    Attributes:
        seeds: the seeds to run, 0 .. seeds - 1 (None: the section takes no seeds).
        workers: the sweep engine's local worker processes (studies/engine.py; None: one per core, 0:
            in this process).
        datasets: the folder of the recorded datasets (docs/robot-logs.md).
        stream: where progress goes (stderr).
        report: where the studies' printed reports go (kept out of the page).
    """

    seeds: int | None = None
    workers: int | None = None
    datasets: FilePath = FilePath("datasets")
    stream: object = dc.field(default_factory=lambda: sys.stderr)
    report: io.StringIO = dc.field(default_factory=io.StringIO)


@dc.dataclass(frozen=True)
class Section:
    """One section of the page.

    Attributes:
        name: what ``--only`` selects and the HTML marker names (``<!-- section: NAME -->``).
        title: the section's heading.
        doc: its topic document in docs/ (e.g. ``navigation.md``).
        measure: Context -> markdown (module docstring).
        seeds: the default number of seeds (None: the section takes none; ``--seeds`` does not apply).
        study: the study commands whose figures the section states, ``{seeds}`` standing for the seeds
            (each a ``slipnav`` command line).
        on_demand: measured only when ``--only`` names it (a long section); a full run keeps its text.
        fixed: what the stamp says of the seeds where the section takes none (e.g. "seed 0").
    """

    name: str
    title: str
    doc: str
    measure: Callable[[Context], str]
    seeds: int | None = None
    study: tuple[str, ...] = ()
    on_demand: bool = False
    fixed: str = "no seeds"


def paragraph(text: str) -> str:
    """``text`` as one paragraph wrapped at WRAP columns (no word, no code span broken)."""
    return textwrap.fill(" ".join(text.split()), WRAP, break_long_words=False, break_on_hyphens=False)


def table(header, rows) -> str:
    """A markdown table: ``header`` a sequence of column titles, ``rows`` sequences of cells (str)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(cell) for cell in row) + " |" for row in rows]
    return "\n".join(lines)


def number(value, digits: int = 2, unit: str = "") -> str:
    """``value`` with ``digits`` decimals and ``unit``; "—" where it is None or not finite."""
    if value is None or not math.isfinite(float(value)):
        return "—"
    return f"{float(value):.{digits}f}{unit}"


def mean_worst(values, digits: int = 2, unit: str = "") -> str:
    """The mean over the seeds and the worst (largest) in brackets, NaN left out: "0.14 % (0.21)"; "—"
    where no value is finite."""
    values = np.asarray(values, float)
    if not np.isfinite(values).any():
        return "—"
    return f"{np.nanmean(values):.{digits}f}{unit} ({np.nanmax(values):.{digits}f})"


def seeds_text(seeds: int | None) -> str:
    """ "seeds 0–9", "seed 0", or "no seeds" (None)."""
    if seeds is None:
        return "no seeds"
    return "seed 0" if seeds == 1 else f"seeds 0–{seeds - 1}"
