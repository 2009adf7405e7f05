"""Large arrays reuse the memory the process already holds (glibc's allocator).

A batch is solved in parts, each of which allocates and frees the same large arrays (the
period's terms and their factors, 30–100 MB a part; the histories, up to 4.4 MB a case).
glibc maps every allocation above its mmap threshold (at most 32 MB) afresh and returns it to
the system when freed, so each part faults in fresh zeroed pages again: on the benchmark
sweep (100 cases of 8 elements at 1,280 steps per revolution, full histories) that system
time was 1–12 ms per case beside 5–7 ms of computing, and on a default-study chunk 250,000
page faults. Served from the heap and kept there instead, the pages are faulted once per
process: measured (2026-11-27, one process, six consecutive calls) the sweep's median went
from 11.5 to 5.8 ms per case with the system time of the later calls at 0, and a
crank-rocker chunk of 500 cases from 6.7 to 4.8 s (35,000 faults).

NumPy's advice to back arrays of 4 MB and more with transparent huge pages is turned off
with it: where the kernel compacts memory to find them on a fault (``defrag`` ``madvise``,
this machine's default), the first touch of a heap grown by brk cost 50–90 µs a fault, and
the sweep's first call took 12–19 ms per case with the advice against 8–11 without it (three
fresh processes each; later calls 5.3–6.0 ms either way, the same computing time).

The process then keeps up to :data:`KEPT_BYTES` of freed memory instead of returning it at
once; ``CED_MALLOC=system`` leaves the allocator and NumPy's advice as they are. Elsewhere
than on glibc (macOS, musl) nothing changes.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import os

import numpy as np

__all__ = ["keep_freed_memory", "KEPT_BYTES"]

#: mallopt parameters (glibc's malloc.h).
_M_TRIM_THRESHOLD, _M_MMAP_MAX = -1, -4
#: Freed memory at the top of the heap above which glibc returns it to the system: 1 GiB,
#: above a default-study chunk job's peak (0.5–0.6 GB).
KEPT_BYTES = 1 << 30

_applied: bool | None = None


def keep_freed_memory() -> bool:
    """Have glibc serve large allocations from the heap and keep what is freed, and NumPy
    not advise huge pages (once per process; later calls return the first one's result).

    Returns
    -------
    bool
        Whether the allocator was set so: False with ``CED_MALLOC=system``, off glibc, or
        where ``mallopt`` refused.
    """
    global _applied
    if _applied is None:
        _applied = _set_allocator()
    return _applied


def _glibc() -> bool:
    """Whether the process runs on glibc (its confstr says so; elsewhere it is refused)."""
    try:
        return (os.confstr("CS_GNU_LIBC_VERSION") or "").startswith("glibc")
    except (AttributeError, ValueError, OSError):
        return False


def _set_allocator() -> bool:
    if os.environ.get("CED_MALLOC", "") == "system" or not _glibc():
        return False
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6")
        mallopt = libc.mallopt
    except (OSError, AttributeError):
        return False
    mallopt.argtypes, mallopt.restype = (ctypes.c_int, ctypes.c_int), ctypes.c_int
    # Trim threshold first: with mmap off but the default threshold, every free of a large
    # array at the top of the heap would hand it back to the system at once.
    if not (mallopt(_M_TRIM_THRESHOLD, KEPT_BYTES) and mallopt(_M_MMAP_MAX, 0)):
        return False
    advise = getattr(getattr(getattr(np, "_core", None), "multiarray", None),
                     "_set_madvise_hugepage", None)
    if advise is not None:
        advise(False)
    return True
