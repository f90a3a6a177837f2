"""A readable block diagram: Drake's Graphviz text (GetGraphvizString) with the signals named and the
blocks grouped by rate.

- A Demultiplexer's outputs (diagrams/split.py: one Python block's output vector sliced in C++) read
  y0, y1, ... in Drake's text; each is named here after the input ports it feeds (or the diagram output it
  is exported as), up to two names, or UNREAD.
- The blocks with a periodic discrete update are grouped in a dashed frame per period ("every T_N = 2 ms",
  "every T_C = 20 ms"); blocks without one (the slicers, feedthrough arithmetic) stay outside.
"""

from __future__ import annotations

import collections
import re

NODE = re.compile(
    r"^(?P<id>s\d+) \[shape=none, border=0, label=<\n<TABLE[^\n]*\n<TR><TD[^\n]*\n"
    r"<B>(?P<kind>[^<]*)</B><BR/>\nname=(?P<name>[^\n]*)\n(?P<body>.*?)\n>\];",
    re.M | re.S,
)
PORT = re.compile(r'<TD PORT="(?P<port>[uy]\d+)" BORDER="1"[^>]*>(?P<label>[^<]*)</TD>')
EDGE = re.compile(r"^(?P<src>s\d+):(?P<out>y\d+):e -> (?P<dst>s\w+):(?P<into>\w+):w", re.M)
EXPORTED = re.compile(r'<TD BORDER="1" PORT="(?P<port>\d+)">(?P<label>[^<]*)</TD>')
UNREAD = "(not read)"
"""The name of a slice that feeds nothing (a block's state, which only its own update reads)."""
MAX_NAMES = 2
"""A slice that feeds more inputs than this is named after the first of them, with '...'."""


def drawn_blocks(dot: str) -> dict:
    """{node id: (kind, name, {port: label})} of the subsystems Drake drew."""
    return {
        m["id"]: (m["kind"], m["name"], {p["port"]: p["label"] for p in PORT.finditer(m["body"])})
        for m in NODE.finditer(dot)
    }


def _exported_outputs(dot: str) -> dict:
    """{node id of the diagram's output table: {port: exported name}}."""
    tables = {}
    for m in re.finditer(r"^(?P<id>s\d+out) \[shape=none, label=<(?P<body>.*?)>\];", dot, re.M | re.S):
        tables[m["id"]] = {p["port"]: p["label"] for p in EXPORTED.finditer(m["body"])}
    return tables


def signal_names(dot: str) -> dict:
    """{(demultiplexer node id, output port): name}: each slice named after what it feeds."""
    nodes, exported = drawn_blocks(dot), _exported_outputs(dot)
    feeds = collections.defaultdict(list)
    for m in EDGE.finditer(dot):
        if nodes.get(m["src"], ("",))[0] != "Demultiplexer":
            continue
        if m["dst"] in nodes:
            label = nodes[m["dst"]][2].get(m["into"], m["into"])
        else:
            label = exported.get(m["dst"], {}).get(m["into"], m["into"])
        if label not in feeds[(m["src"], m["out"])]:
            feeds[(m["src"], m["out"])].append(label)
    names = {}
    for key, labels in feeds.items():
        shown = sorted(labels)[:MAX_NAMES]
        names[key] = " / ".join(shown) + (" / ..." if len(labels) > MAX_NAMES else "")
    return names


def _rename_slices(dot: str, names: dict) -> str:
    """Drake's text with each demultiplexer output's label replaced by its name."""

    def rename(match):
        node = match.group(0)
        node_id = match["id"]

        def port(p):
            key = (node_id, p["port"])
            if p["port"].startswith("y"):
                name = names.get(key, UNREAD)
                return p.group(0).replace(f">{p['label']}</TD>", f">{name}</TD>")
            return p.group(0)

        return PORT.sub(port, node) if match["kind"] == "Demultiplexer" else node

    return NODE.sub(rename, dot)


def rate_groups(diagram, dot: str) -> dict:
    """{period (s): [node ids]} of the diagram's subsystems with a periodic discrete update."""
    by_name = {name: node_id for node_id, (_, name, _) in drawn_blocks(dot).items()}
    groups = collections.defaultdict(list)
    for system in diagram.GetSystems():
        attribute = system.GetUniquePeriodicDiscreteUpdateAttribute()
        node_id = by_name.get(system.get_name())
        if attribute is not None and node_id is not None:
            groups[attribute.period_sec()].append(node_id)
    return dict(groups)


def rate_label(period: float, rates) -> str:
    """'every T_N = 2 ms', 'every T_C = 20 ms' for the ``rates``' periods (SampleRates), else 'every
    P ms'."""
    name = {rates.T_N: "T_N = ", rates.T_C: "T_C = "}.get(period, "")
    return f"every {name}{1000.0 * period:g} ms"


def readable_dot(diagram, dot: str, rates) -> str:
    """``dot`` (diagram.GetGraphvizString()) with the demultiplexers' slices named (signal_names) and the
    periodic blocks framed by rate (rate_groups), each frame named by rate_label with ``rates``."""
    dot = _rename_slices(dot, signal_names(dot))
    groups = rate_groups(diagram, dot)
    if not groups:
        return dot
    frames = []
    for k, period in enumerate(sorted(groups)):
        members = "; ".join(sorted(groups[period], key=lambda s: int(s[1:])))
        frames.append(
            f'subgraph cluster_rate_{k} {{\nlabel="{rate_label(period, rates)}"\nstyle=dashed\n'
            f"color=gray40\n{members};\n}}"
        )
    opening = re.search(r"^subgraph cluster\d+subsystems \{\n", dot, re.M)  # the frames go inside it
    if opening is None:
        return dot
    return dot[: opening.end()] + "\n".join(frames) + "\n" + dot[opening.end() :]
