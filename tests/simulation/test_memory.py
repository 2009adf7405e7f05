"""ced.simulation.memory: freed arrays are reused without faulting in fresh pages."""
import os
import subprocess
import sys

import pytest

from ced.simulation.memory import _glibc

SCRIPT = """
import resource, numpy as np
from ced.simulation.memory import keep_freed_memory
applied = keep_freed_memory()
assert keep_freed_memory() is applied  # once per process
multiarray = np._core.multiarray
multiarray._set_madvise_hugepage(False)  # count 4 KiB faults whatever the kernel's THP
a = np.ones(8 << 20)  # 64 MiB: above glibc's largest mmap threshold
del a
before = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
a = np.ones(8 << 20)
print(applied, resource.getrusage(resource.RUSAGE_SELF).ru_minflt - before)
"""


def _run(**env) -> tuple[bool, int]:
    out = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True,
                         timeout=300, check=True, env={**os.environ, **env}).stdout.split()
    return out[0] == "True", int(out[1])


@pytest.mark.skipif(not _glibc(), reason="glibc's allocator only")
def test_a_freed_array_is_reused_without_page_faults():
    applied, faults = _run()
    assert applied
    assert faults < 100  # the second 64 MiB array is the first one's pages
    applied, faults = _run(CED_MALLOC="system")
    assert not applied
    assert faults > 10_000  # mapped afresh: 16,384 pages of 4 KiB faulted in again


def test_solve_batch_sets_the_allocator(monkeypatch):
    import ced.simulation.simulate as simulation

    calls = []
    monkeypatch.setattr(simulation, "keep_freed_memory", lambda: calls.append(1))
    monkeypatch.setattr(simulation, "_solve_part", lambda *a: {})
    monkeypatch.setattr(simulation, "cases_per_solve", lambda scene: 10)

    class Batch:
        size, scenes = 1, [{}]

    simulation.solve_batch(Batch())
    assert calls == [1]
