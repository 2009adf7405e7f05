"""Rigid motion of a batch of linkages (thesis II.1–II.2).

Modules: :mod:`~ced.rigid.kinematics` (closed-form positions with branch tracking,
velocities, accelerations), :mod:`~ced.rigid.dyads` (the same for any linkage built from
dyads, six-bars included) and :mod:`~ced.rigid.inverse_dynamics` (joint forces and input
torque by Newton–Euler, mass properties, power balance); :mod:`~ced.rigid.speed_family`
shares one solution among cases that differ in their speed alone.

Imports: :mod:`ced.problem` only.
"""
