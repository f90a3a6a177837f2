"""Named layouts of flat discrete states: a block's state is one vector (a Drake discrete state), and
its parts are addressed by name, never by offset arithmetic."""


def layout_slices(layout) -> dict:
    """The index of each part of ``layout``, a sequence of (name, size) in state order: an int for a
    part of size 1, a slice otherwise."""
    slices, start = {}, 0
    for name, size in layout:
        slices[name] = slice(start, start + size) if size > 1 else start
        start += size
    return slices


def layout_size(layout) -> int:
    """The state's length: the sum of the parts' sizes."""
    return sum(size for _, size in layout)


def layout_indices(layout) -> dict:
    """The state index of each element of each part of ``layout`` ((name, size) in state order): an int
    for a part of size 1, a tuple of ints otherwise (for states kept as Python lists, where a slice is
    a copy)."""
    indices, start = {}, 0
    for name, size in layout:
        indices[name] = tuple(range(start, start + size)) if size > 1 else start
        start += size
    return indices
