"""Optional numba compilation of the hot pure functions (``pip install -e '.[fast]'``; issue 20).

The arithmetic stays readable Python: ``compiled(f)`` returns ``numba.njit(cache=True)(f)`` when numba
imports and the environment variable ``SLIPNAV_NUMBA`` is not ``0``, else ``f`` itself; ``jitable(f)``
returns ``f`` unchanged for Python callers and, with numba, lets compiled functions call it
(``numba.extending.register_jitable``). Neither uses fastmath, so the compiled functions round as
Python does (no reordering, no fused multiply-add): a run is the same with and without numba
(tests/test_compiled.py). The compiled functions are cached on disk (numba's ``cache=True``, in
sources_cache_dir unless NUMBA_CACHE_DIR is set), so a process pays numba's compile (some seconds) once
per state of the sources.

``element_view(array)`` is what the compiled functions index a flat state through: the array itself
when ENABLED, else a ``memoryview`` of it, whose elements read as Python floats and whose slices are
views too (element access and arithmetic on numpy's scalars cost several times those on floats; the
arithmetic rounds the same). Functions that take such a view index it element by element (no slice
assignment of a scalar, no numpy functions).

``ENABLED`` tells whether the compiled versions are in use; ``pure(f)`` is the Python function behind
``f`` (itself without numba), for tests that compare the two. ``record_maker(cls)`` turns the plain
tuple of parameters a compiled function takes into its named tuple, cheaply on both sides.
"""

import hashlib
import os
import pathlib
import tempfile

SOURCES = pathlib.Path(__file__).resolve().parent
"""systems/: the compiled functions and every jitable function they call."""


def sources_cache_dir(sources: pathlib.Path = SOURCES) -> str:
    """numba's cache directory for this state of ``sources``: numba's own cache checks the modification
    time of the file that defines a compiled function only, not of the jitable functions it calls from
    other modules, so each state of the sources compiles into a directory of its own (under the system's
    temporary directory, slipnav-numba/<the sources' SHA-256, 16 hex digits>)."""
    digest = hashlib.sha256()
    for path in sorted(sources.rglob("*.py")):
        digest.update(path.read_bytes())
    return os.path.join(tempfile.gettempdir(), "slipnav-numba", digest.hexdigest()[:16])


ENABLED = False
if os.environ.get("SLIPNAV_NUMBA", "1").strip() not in ("0", "false", "no", "off"):
    try:
        import numba
        from numba.extending import overload, register_jitable

        ENABLED = True
        if not os.environ.get("NUMBA_CACHE_DIR"):  # the user's choice stands
            numba.config.CACHE_DIR = sources_cache_dir()
    except ImportError:  # the optional extra is not installed: pure Python
        pass


def compiled(function):
    """``function`` compiled by numba (nopython, cached, no fastmath) when ENABLED, else itself."""
    if not ENABLED:
        return function
    return numba.njit(cache=True)(function)


def jitable(function):
    """``function`` itself, callable from compiled functions when ENABLED."""
    if not ENABLED:
        return function
    return register_jitable(function)


def pure(function):
    """The Python function behind a ``compiled`` one (the function itself when it is not compiled)."""
    return getattr(function, "py_func", function)


def record_maker(record_class):
    """A function ``values -> record_class(*values)``: the named tuple of a plain tuple (the form in which
    parameters cross numba's boundary fastest). Python callers build it with ``record_class._make`` (one
    tuple.__new__: a quarter of the constructor's cost for HealthConstants' 85 fields), compiled
    functions with the constructor (numba has no ``_make``)."""

    def make(values):
        return record_class._make(values)

    if ENABLED:

        @overload(make)
        def _compiled_make(values):
            return lambda values: record_class(*values)

    return make


def _itself(array):
    return array


element_view = register_jitable(_itself) if ENABLED else memoryview
