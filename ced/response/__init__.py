"""The time response of a batch of structurally identical cases.

Modules: :mod:`~ced.response.batch` (scenes → per-case arrays and the rigid motion),
:mod:`~ced.response.model` (the KED model M(t) q̈ + C(t) q̇ + K(t) q = F(t): built once,
evaluated at any time), :mod:`~ced.response.integrators` (the time-integration schemes and
the one marching loop), :mod:`~ced.response.periodic` (periodic steady state by shooting,
Floquet multipliers, resonance of the periodic state), :mod:`~ced.response.resonance` (forced
resonance: a load-carrying crank harmonic in a mode's band, whatever the start),
:mod:`~ced.response.frequencies` (natural frequencies over the cycle), :mod:`~ced.response.elastic` (the elastic response of a batch: start, march,
recovery, flags).

Imports: :mod:`ced.fem`, :mod:`ced.rigid`, :mod:`ced.problem`.
"""
