"""What is asked: the scene, its materials and mechanism, and the words ced answers in.

Modules: :mod:`~ced.problem.errors` (``SceneError`` and the value checks that raise it),
:mod:`~ced.problem.materials` (material library, section properties),
:mod:`~ced.problem.mechanism` (linkage topology, Grashof families, input limits, assembly
and transmission criteria), :mod:`~ced.problem.linkage` (linkages built from dyads: their
description, checks, topology and the four-bar, slider-crank and six-bar presets), :mod:`~ced.problem.scene` (parse, validate and normalize a
scene), :mod:`~ced.problem.status` (the status flags of a case).

Imports: nothing of ced (the bottom layer); numpy and PyYAML only.
"""
