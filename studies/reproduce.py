"""The papers' figures recreated on our robots: ``slipnav reproduce [--out DIR] [--quick]``.

Seyr & Jakubek Figs. 4-8 and Indiveri, Nüchter & Lingemann Figs. 2, 5-9, each in default mode and in
paper mode (scenarios/paper.py), from a handful of closed-loop runs of the built-in scenarios and two
variants built here (the circle with its wheels in the air, Indiveri Fig. 5). Every figure function
returns a ``Reproduced``: the matplotlib Figure, the paper's caption, its quantitative claim, what we
measured (computed from the runs) and the command that makes the underlying run. ``reproduce`` writes
``DIR/reproduce/index.html`` (the figures beside caption, claim and measurement, and the claims table),
the PNGs (``<key>-<mode>.png``), the animations of Seyr's corner and square and Indiveri's long path
(``<run>-<mode>.html``, scenarios/animation.py), ``reproduce.json`` (the same as data) and
``lifted_circle.yaml``.
"""

from __future__ import annotations

import html
import json
import shutil
import sys
import time
from pathlib import Path as FilePath

from slipnav.scenarios.animation import write_animation
from slipnav.scenarios.block_diagrams import export_diagram
from slipnav.scenarios.config import load_scenario
from slipnav.scenarios.paper import paper_mode
from slipnav.scenarios.plots import save_figure_atomically
from slipnav.studies.reproduce_indiveri import (
    indiveri_fig2,
    indiveri_fig5,
    indiveri_fig6,
    indiveri_fig7,
    indiveri_fig8,
    indiveri_fig9,
)
from slipnav.studies.reproduce_measures import (
    AT_V_M,
    EXCESSIVE_SLIP,
    Reproduced,
    following_time,
    percent_errors,
    saturation_fractions,
    speed_switches,
)
from slipnav.studies.reproduce_runs import lifted_circle_yaml, make_runs
from slipnav.studies.reproduce_seyr import (
    seyr_fig4,
    seyr_fig5,
    seyr_fig6,
    seyr_fig7,
    seyr_fig8,
    slip_control_effect,
)

MODES = ("default", "paper")
SEYR_POSITION_ERROR_PCT = 2.5
"""Seyr §VII: about 2.5 % position error with reference to the absolute trajectory length."""
ANIMATED = {"corner": "Seyr's corner", "square": "Seyr's square", "long_path": "Indiveri's long path"}
"""Runs of the set the page links as animations (``<run>-<mode>.html``), with their names on the page."""


# -- the page ----------------------------------------------------------------------------------------


def figures_for(runs: dict, mode: str, mixing) -> list[Reproduced]:
    """Every recreated figure of one mode from its runs (make_runs)."""
    a = runs["long_path"].arrays
    return [
        seyr_fig4(mixing, mode),
        seyr_fig5(runs["corner"], mode),
        seyr_fig6(runs["corner"], mode),
        seyr_fig7(runs["square"], mode),
        seyr_fig8(runs["corner"], runs["square"], mode),
        indiveri_fig2(
            float(a["V_m"]),
            0.5 * float(a["track_width"]),
            (("long path, I(24)", runs["long_path"]), ("circle, I(24)", runs["circle"])),
            mode,
        ),
        indiveri_fig5(runs["lifted"], mode),
        indiveri_fig6(
            {
                "odometry": runs["circle_odometry"],
                "gyrodometry": runs["circle_gyrodometry"],
                "fused": runs["circle"],
            },
            mode,
        ),
        indiveri_fig7(runs["long_path"], runs["long_path_constant"], mode),
        indiveri_fig8(runs["circle"], runs["circle_constant"], mode),
        indiveri_fig9(runs["long_path"], runs["long_path_constant"], mode),
    ]


def claims(runs_by_mode: dict) -> list[dict]:
    """The claims table: per claim the paper's statement, our measurement per mode, the figure and the
    command."""
    rows = []
    measured = {}
    for mode, runs in runs_by_mode.items():
        measured.setdefault("position", {})[mode] = position_claim(runs["corner"], runs["square"])
        ec = slip_control_effect(runs["corner"], runs["corner_no_sc"])
        es = slip_control_effect(runs["square"], runs["square_no_sc"])
        measured.setdefault("slip_control", {})[mode] = (
            f"with vs without slip control: corner: peak |alpha| {ec['alpha_on']:.1f} vs "
            f"{ec['alpha_off']:.1f} deg, fused {_on_off(ec)}, {ec['time_on']:.2f} vs {ec['time_off']:.2f} s; "
            f"square: slip ratio > {EXCESSIVE_SLIP} for {es['slip_time_on']:.2f} vs "
            f"{es['slip_time_off']:.2f} s, fused {_on_off(es)}, {es['time_on']:.2f} vs {es['time_off']:.2f} s"
        )
        b, k = runs["long_path"], runs["long_path_constant"]
        measured.setdefault("speed_law", {})[mode] = (
            f"{following_time(b):.1f} s vs {following_time(k):.1f} s "
            f"({100 * following_time(b) / following_time(k):.0f} % of the time); true path error RMS "
            f"{100 * b.summary['path_error_rms_m']:.1f} vs {100 * k.summary['path_error_rms_m']:.1f} cm, max "
            f"{100 * b.summary['path_error_max_m']:.1f} vs {100 * k.summary['path_error_max_m']:.1f} cm"
        )
        one, _ = saturation_fractions(runs["circle"])
        measured.setdefault("saturation", {})[mode] = (
            f"a wheel at >= {AT_V_M:g} V_m {100 * one:.0f} % of the circle's following time, "
            f"{speed_switches(runs['circle'])} switches of I(24)"
        )
    some = next(iter(runs_by_mode.values()))
    rows.append(
        dict(
            claim="Seyr §VII: about 2.5 % position error w.r.t. the trajectory length",
            measured=measured["position"],
            figure="seyr-fig8",
            command=f"{some['corner'].command}; {some['square'].command}",
        )
    )
    rows.append(
        dict(
            claim="Seyr §VI-VII: slip control reduces the step size in slip and limits excessive slip to "
            "short intervals",
            measured=measured["slip_control"],
            figure="seyr-fig6",
            command=f"{some['corner'].command} [--no-slip-control]; "
            f"{some['square'].command} [--no-slip-control]",
        )
    )
    rows.append(
        dict(
            claim="Indiveri §IV-C: the bounded speed law I(24) drives the long path in about 50 % of the "
            "time (its cost: path error)",
            measured=measured["speed_law"],
            figure="indiveri-fig9",
            command=f"{some['long_path'].command} [--speed-law constant]",
        )
    )
    rows.append(
        dict(
            claim="Indiveri §IV-B: on the circle one wheel is always at the maximal input",
            measured=measured["saturation"],
            figure="indiveri-fig8",
            command=f"{some['circle'].command} [--speed-law constant]",
        )
    )
    return rows


def position_claim(corner, square) -> str:
    """Seyr's claim (about 2.5 % final position error) measured on the corner and the square three ways:
    the final error the paper states, and the RMS and the maximum along the run (% of the path), fused
    and odometry-only, with a verdict against 2.5 % for each."""
    errors = {
        (name, prefix): percent_errors(run, prefix)
        for name, run in (("corner", corner), ("square", square))
        for prefix in ("est", "odo")
    }

    def pair(prefix, figure):
        corner_pct, square_pct = errors[("corner", prefix)][figure], errors[("square", prefix)][figure]
        return f"{corner_pct:.2f} % corner, {square_pct:.2f} % square"

    parts = []
    labels = {"final": "final (the paper's figure)", "rms": "RMS along the run", "max": "max along the run"}
    for figure, label in labels.items():
        worst = max(errors[("corner", "est")][figure], errors[("square", "est")][figure])
        verdict = "within" if worst <= SEYR_POSITION_ERROR_PCT else "above"
        parts.append(
            f"{label}: fused {pair('est', figure)}, {verdict} {SEYR_POSITION_ERROR_PCT:g} % "
            f"(odometry only {pair('odo', figure)})"
        )
    return "; ".join(parts)


def _on_off(effect: dict) -> str:
    """The fused error with vs without slip control, final / RMS / max (% of the path)."""
    on = "/".join(f"{effect[f'{key}_on']:.2f}" for key in ("pct", "rms_pct", "max_pct"))
    off = "/".join(f"{effect[f'{key}_off']:.2f}" for key in ("pct", "rms_pct", "max_pct"))
    return f"final/RMS/max {on} vs {off} %"


def write_animations(runs: dict, mode: str, out: FilePath) -> dict:
    """The runs of ANIMATED in ``mode`` as animations ``out/<run>-<mode>.html`` (scenarios/animation.py);
    returns {run: file name}."""
    return {
        name: write_animation(runs[name].arrays, out / f"{name}-{mode}.html", f"{name} ({mode} mode)").name
        for name in ANIMATED
    }


def _cell(text) -> str:
    return html.escape(str(text))


def write_page(
    out: FilePath,
    figures: dict,
    table: list[dict],
    wall: float,
    quick: bool,
    animations=None,
    diagram=None,
) -> FilePath:
    """index.html: the links to the animations ({mode: {run: file}}), the claims table, then per figure
    the PNGs of each mode beside caption, claim, measurement and command, and the navigation's block
    diagram (Seyr Fig. 3; ``diagram``: its file in ``out``, None: none) (written to a temporary file and
    renamed)."""
    modes = list(figures)
    parts = [
        "<!DOCTYPE html><html><head><meta charset='utf-8'><title>slipnav reproduce</title>",
        "<style>body{font-family:sans-serif;max-width:1500px;margin:auto}table{border-collapse:collapse}"
        "td,th{border:1px solid #bbb;padding:4px;vertical-align:top}img{max-width:100%}"
        ".cap{font-size:90%}</style></head><body>",
        "<h1>Seyr &amp; Jakubek and Indiveri et al. figures recreated on our robots</h1>",
        f"<p>Made by <code>slipnav reproduce{' --quick' if quick else ''}</code> in {wall:.0f} s. Modes: "
        f"{', '.join(modes)} (paper: the equations as printed, README Paper mode). Seed 0.</p>",
        _animation_links(animations or {}),
        "<h2>Claims</h2><table><tr><th>paper's claim</th>"
        + "".join(f"<th>measured, {m}</th>" for m in modes)
        + "<th>figure</th><th>command</th></tr>",
    ]
    for row in table:
        parts.append(
            f"<tr><td>{_cell(row['claim'])}</td>"
            + "".join(f"<td>{_cell(row['measured'].get(m, '-'))}</td>" for m in modes)
            + f"<td><a href='#{row['figure']}'>{row['figure']}</a></td>"
            + f"<td><code>{_cell(row['command'])}</code></td></tr>"
        )
    parts.append("</table>")
    first = figures[modes[0]]
    for i, fig in enumerate(first):
        parts.append(f"<h2 id='{fig.key}'>{_cell(fig.title)}</h2><table><tr>")
        for m in modes:
            f = figures[m][i]
            parts.append(f"<td><img src='{f.key}-{m}.png' alt='{f.key} {m}'><br>{m} mode</td>")
        parts.append(
            f"<td class='cap'><b>Paper's caption:</b> {_cell(fig.caption)}"
            f"<br><b>Claim:</b> {_cell(fig.claim)}"
        )
        for m in modes:
            f = figures[m][i]
            parts.append(
                f"<br><b>Measured ({m}):</b> {_cell(f.measured)}"
                f"<br><b>Command:</b> <code>{_cell(f.command)}</code>"
            )
        parts.append("</td></tr></table>")
    parts.append(_diagram_section(diagram))
    parts.append("</body></html>")
    path = out / "index.html"
    tmp = out / "index.html.tmp"
    tmp.write_text("\n".join(parts))
    tmp.replace(path)
    return path


def _diagram_section(diagram) -> str:
    """Seyr Fig. 3 as the navigation's Drake diagram: the image (an SVG) or a link to its Graphviz text."""
    if diagram is None:
        return ""
    name = _cell(FilePath(diagram).name)
    link = f"<a href='{name}'>{name}</a>"
    shown = f"<img src='{name}' alt='navigation diagram'>" if name.endswith(".svg") else link
    return (
        "<h2 id='seyr_fig3'>Seyr Fig. 3: the navigation as a Drake diagram</h2>"
        "<p class='cap'>Every block of the navigation (<code>slipnav diagram navigation</code>), the "
        "slices of each block's output named after what they feed, the blocks framed by their period "
        "(T_N, T_C).</p>"
        f"{shown}"
    )


def _animation_links(animations: dict) -> str:
    """One paragraph linking each animated run's pages, one per mode ('' without animations)."""
    if not animations:
        return ""
    runs = [
        f"{ANIMATED[name]}: "
        + ", ".join(f"<a href='{files[name]}'>{mode}</a>" for mode, files in animations.items())
        for name in ANIMATED
    ]
    return (
        "<p id='animations'>Animations (true and fused robot, wheel slip; one HTML file each): "
        + "; ".join(runs)
        + ".</p>"
    )


def reproduce(out_dir="runs", quick: bool = False, modes=MODES, stream=None) -> dict:
    """Make every run, figure, animation and the page: ``out_dir/reproduce/index.html``,
    ``<key>-<mode>.png``, ``<run>-<mode>.html`` (ANIMATED), ``lifted_circle.yaml``. Returns {"index": path,
    "figures": {mode: [Reproduced]}, "claims": rows,
    "wall_s": seconds}."""
    stream = stream or sys.stdout
    start = time.perf_counter()
    out = FilePath(out_dir) / "reproduce"
    out.mkdir(parents=True, exist_ok=True)
    yaml_path = out / "lifted_circle.yaml"
    tmp = out / "lifted_circle.yaml.tmp"
    tmp.write_text(lifted_circle_yaml())
    tmp.replace(yaml_path)
    figures, runs_by_mode, animations = {}, {}, {}
    for mode in modes:
        runs = make_runs(
            mode,
            quick,
            out,
            progress=lambda name, m, s: print(
                f"reproduce: {m} {name} ({s['wall_time_s']:.1f} s)", file=stream
            ),
        )
        runs_by_mode[mode] = runs
        animations[mode] = write_animations(runs, mode, out)
        scenario = load_scenario("corner")
        mixing = (paper_mode(scenario) if mode == "paper" else scenario).navigation.mixing
        figures[mode] = figures_for(runs, mode, mixing)
        for f in figures[mode]:
            save_figure_atomically(f.figure, out / f"{f.key}-{mode}.png")
            f.figure = None
        runs_by_mode[mode] = runs
    table = claims(runs_by_mode)
    wall = time.perf_counter() - start
    diagram = export_diagram("navigation", out / f"navigation.{'svg' if shutil.which('dot') else 'dot'}")
    index = write_page(out, figures, table, wall, quick, animations, diagram)
    record = {
        "quick": quick,
        "wall_s": wall,
        "figures": {
            m: {
                f.key: {
                    "png": f"{f.key}-{m}.png",
                    "caption": f.caption,
                    "claim": f.claim,
                    "measured": f.measured,
                    "command": f.command,
                    "numbers": f.numbers,
                }
                for f in figs
            }
            for m, figs in figures.items()
        },
        "claims": table,
        "animations": animations,
    }
    tmp = out / "reproduce.json.tmp"
    tmp.write_text(json.dumps(record, indent=1))
    tmp.replace(out / "reproduce.json")
    for row in table:
        print(f"claim: {row['claim']}", file=stream)
        for m, text in row["measured"].items():
            print(f"  {m}: {text}", file=stream)
    print(
        f"reproduce figures={sum(len(v) for v in figures.values())} wall_s={wall:.1f} index={index}",
        file=stream,
    )
    return {"index": index, "figures": figures, "claims": table, "wall_s": wall}
