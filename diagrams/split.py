"""Slicing a Python block's one output vector into named signals in C++ (pydrake's Demultiplexer), so
that a slice costs no Python callback per sample."""

from pydrake.systems.framework import DiagramBuilder, OutputPort
from pydrake.systems.primitives import Demultiplexer


def split_port(builder: DiagramBuilder, port: OutputPort, layout, name: str) -> dict:
    """Demultiplex ``port`` by ``layout`` ((name, size) pairs, in order, covering the whole vector) in a
    Demultiplexer named ``name``; returns the output port of each named slice."""
    sizes = [size for _, size in layout]
    if sum(sizes) != port.size():
        raise ValueError(f"{name}: the layout covers {sum(sizes)} of {port.size()} elements")
    demux = builder.AddSystem(Demultiplexer(sizes))
    demux.set_name(name)
    builder.Connect(port, demux.get_input_port(0))
    return {part: demux.get_output_port(i) for i, (part, _) in enumerate(layout)}
