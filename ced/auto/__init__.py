"""Automatic choices and the accuracy they promise.

Modules: :mod:`~ced.auto.effects` (``effects: auto``: which effects matter, from
dimensionless estimates), :mod:`~ced.auto.discretization` (``discretization: auto``:
elements and steps from measured refinement ladders), :mod:`~ced.auto.error_estimate`
(each case's ``error_estimate`` from companion solutions).

Solutions are obtained through an injected ``solve`` callable (from
:mod:`ced.simulation`), so this layer never calls the layer above it.

Imports: :mod:`ced.response`, :mod:`ced.fem`, :mod:`ced.rigid`, :mod:`ced.problem`.
"""
