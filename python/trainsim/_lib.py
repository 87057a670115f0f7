"""Loading libtrainsim_c (the C interface, include/trainsim.h) with ctypes.

The library is looked for, in order: the file named by the environment variable
TRAINSIM_LIBRARY; libtrainsim_c.so inside this package (the CMake build's staged
package, a pip install); the library a `cmake --install` put beside this package
(_install.py); the system's library path (ldconfig).
"""
import ctypes
import ctypes.util
import os

from ._errors import TrainsimError

OK, ERR_INPUT, ERR_IO, ERR_NUMERIC, ERR_INTERNAL, ERR_INTERRUPTED, ERR_ARGUMENT = range(7)
RUN_SERIES, RUN_EVENTS = 1, 2
(METRICS, METRIC_UNITS, SERIES, SERIES_UNITS, EVENT_COLUMNS, ELEMENTS, NODES, SWEEP_PARAMETERS,
 SAMPLES, EVENTS, SWEEP_RUNS, EVENT_KINDS) = range(1, 13)


def _candidates():
    env = os.environ.get("TRAINSIM_LIBRARY")
    if env:
        yield env
        return
    here = os.path.dirname(os.path.abspath(__file__))
    yield os.path.join(here, "libtrainsim_c.so")
    try:
        from . import _install  # written by cmake --install
        yield _install.LIBRARY
    except ImportError:
        pass
    found = ctypes.util.find_library("trainsim_c")
    if found:
        yield found


def _load():
    tried = []
    for path in _candidates():
        if os.path.sep in path and not os.path.exists(path):
            tried.append(path + " (absent)")
            continue
        try:
            # PyDLL: calls hold the GIL, so Python threads never enter the library at
            # once (its module variables and HDF5 are not thread-safe)
            return ctypes.PyDLL(path), path
        except OSError as exc:
            tried.append(f"{path} ({exc})")
    raise ImportError(
        "trainsim: cannot find the shared library libtrainsim_c.so; tried: "
        + (", ".join(tried) or "nothing")
        + ". Build trainsim (bash scripts/setup.sh) and install the package from the build tree "
        "(pip install --no-build-isolation build/python), or set TRAINSIM_LIBRARY to the library's path.")


lib, path = _load()

_p = ctypes.c_void_p
_s = ctypes.c_char_p
_z = ctypes.c_size_t
_dp = ctypes.POINTER(ctypes.c_double)
_signatures = {
    "trainsim_new": (_p, []),
    "trainsim_free": (None, [_p]),
    "trainsim_library_version": (_s, []),
    "trainsim_error_code": (ctypes.c_int, [_p]),
    "trainsim_error_message": (_z, [_p, _s, _z]),
    "trainsim_read_file": (ctypes.c_int, [_p, _s]),
    "trainsim_read_text": (ctypes.c_int, [_p, _s, _s]),
    "trainsim_set": (ctypes.c_int, [_p, _s, _s]),
    "trainsim_set_real": (ctypes.c_int, [_p, _s, ctypes.c_double]),
    "trainsim_clear": (ctypes.c_int, [_p]),
    "trainsim_run": (ctypes.c_int, [_p, ctypes.c_int, _s]),
    "trainsim_count": (ctypes.c_int, [_p, ctypes.c_int, ctypes.POINTER(_z)]),
    "trainsim_name": (ctypes.c_int, [_p, ctypes.c_int, _z, _s, _z, ctypes.POINTER(_z)]),
    "trainsim_metric": (ctypes.c_int, [_p, _s, _dp]),
    "trainsim_metrics": (ctypes.c_int, [_p, _dp, _z]),
    "trainsim_series": (ctypes.c_int, [_p, _dp, _z]),
    "trainsim_events": (ctypes.c_int, [_p, _dp, _z]),
    "trainsim_sweep_values": (ctypes.c_int, [_p, _dp, _z]),
    "trainsim_session_start": (ctypes.c_int, [_p, _s]),
    "trainsim_session_set_torque": (ctypes.c_int, [_p, _s, ctypes.c_double]),
    "trainsim_session_set_input": (ctypes.c_int, [_p, _s, ctypes.c_double]),
    "trainsim_session_advance": (ctypes.c_int, [_p, ctypes.c_double]),
    "trainsim_session_state": (ctypes.c_int, [_p, _dp, _dp, _dp, _z]),
    "trainsim_session_save": (ctypes.c_int, [_p, ctypes.POINTER(ctypes.c_int)]),
    "trainsim_session_restore": (ctypes.c_int, [_p, ctypes.c_int]),
}
for _name, (_res, _args) in _signatures.items():
    _f = getattr(lib, _name)
    _f.restype = _res
    _f.argtypes = _args


def message(handle):
    n = lib.trainsim_error_message(handle, None, 0)
    buf = ctypes.create_string_buffer(n + 1)
    lib.trainsim_error_message(handle, buf, n + 1)
    return buf.value.decode("utf-8", "replace")


def check(code, handle):
    """Raise TrainsimError with the handle's message when `code` is not 0."""
    if code != OK:
        raise TrainsimError(message(handle), code)


def encode(text):
    return os.fsencode(text) if isinstance(text, os.PathLike) else str(text).encode("utf-8")


def count(handle, what):
    n = _z(0)
    check(lib.trainsim_count(handle, what, ctypes.byref(n)), handle)
    return n.value


def names(handle, what):
    out = []
    length = _z(0)
    buf = ctypes.create_string_buffer(256)
    for i in range(count(handle, what)):
        check(lib.trainsim_name(handle, what, i, buf, len(buf), ctypes.byref(length)), handle)
        if length.value >= len(buf):
            buf = ctypes.create_string_buffer(length.value + 1)
            check(lib.trainsim_name(handle, what, i, buf, len(buf), None), handle)
        out.append(buf.value.decode("utf-8"))
    return out


def values(handle, function, n, out=None):
    """Call a values function (trainsim_metrics, ...) into a new (or given) float64 array."""
    import numpy as np
    if out is None:
        out = np.empty(n, dtype=np.float64)
    check(function(handle, out.ctypes.data_as(_dp), out.size), handle)
    return out
