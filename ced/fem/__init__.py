"""Finite elements of the flexible links and their coupling through the joints.

Modules: :mod:`~ced.fem.elements` (one link formulation per module), :mod:`~ced.fem.jets`
(time derivatives of rotations), :mod:`~ced.fem.coupling` (DOF layout and the exact
time-varying joint projection), :mod:`~ced.fem.effect_terms` (the terms each named effect
adds to M, C, K, F), :mod:`~ced.fem.component_modes` (Craig–Bampton reduction),
:mod:`~ced.fem.eigenproblem` (natural frequencies of the frozen system),
:mod:`~ced.fem.recovery` (deflection, strain and stress at the stations).

Imports: :mod:`ced.problem` only (the rigid motion enters as arrays).
"""
