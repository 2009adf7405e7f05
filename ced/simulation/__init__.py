"""``ced.simulate``: scenes in, one CF-described xarray dataset out.

Modules: :mod:`~ced.simulation.simulate` (normalize, resolve the automatic choices, group
into batches, solve, isolate failing cases) and :mod:`~ced.simulation.dataset` (the
registry of output variables and the CF dataset built from the arrays).

Imports: :mod:`ced.auto` and everything below it.
"""
