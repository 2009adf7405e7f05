"""From normalized scenes to batched case parameters: family, drive, time grid, mass properties.

A *batch* is a set of cases that share a structure (mechanism type, number of steps, output
stations, discretization), so that every array has leading dimensions (case, step) and the
solvers run vectorized across cases.
"""
from __future__ import annotations

import dataclasses
import marshal
import math
from dataclasses import dataclass, field

import numpy as np

from ..problem.linkage import bar_ends, describe, four_bar_loops
from ..problem.mechanism import classify, input_limits, topology
from ..rigid import dyads, kinematics
from ..rigid import inverse_dynamics as newton_euler
from ..rigid import speed_family
from ..rigid.inverse_dynamics import BodyProperties, InverseDynamics

__all__ = ["Batch", "make_batch", "structure_key", "case_family", "loop_families", "step_count",
           "MOTION_TURNS", "REPEAT_TOLERANCE"]

#: Input turns after which the rigid motion of a case may repeat: one, or two where it
#: passes a change point once a turn (and so changes assembly branch once a turn).
MOTION_TURNS = (1, 2)
#: Largest difference, in link angle (rad) and in joint position (relative to the longest
#: link), between two configurations counted as the same. Round-off moves a configuration
#: near a change point by ~sqrt(ε) (the assembly's square root there: at most 1.8e-7 rad over
#: the default study's change points); the two branches differ by O(1) rad, and
#: by ~sqrt(step) ≥ 2.5e-3 rad one step from the change point (10⁶ steps a turn).
REPEAT_TOLERANCE = 1e-5


def case_family(scene: dict) -> str:
    """Family of the scene's mechanism (Grashof class, ``slider_crank`` or ``single_link``).

    Parameters
    ----------
    scene : dict
        A normalized scene.

    Returns
    -------
    str
        The family name.
    """
    mech = scene["mechanism"]
    if mech["type"] in ("four_bar", "watt_ii", "stephenson_iii"):
        # A six-bar is named by its first loop, the one that decides how the input moves.
        return classify(mech["ground"], mech["crank"], mech["coupler"], mech["rocker"])
    return mech["type"]


def loop_families(scene: dict) -> list[str]:
    """Grashof family of each four-bar loop of the scene's mechanism, first loop first.

    Parameters
    ----------
    scene : dict
        A normalized scene of type ``four_bar``, ``watt_ii`` or ``stephenson_iii``.

    Returns
    -------
    list of str
        :func:`ced.problem.mechanism.classify` of each loop
        (:func:`ced.problem.linkage.four_bar_loops`).
    """
    return [classify(*loop) for loop in four_bar_loops(scene["mechanism"])]


def step_count(scene: dict) -> int:
    """Number of time steps of a scene: revolutions × steps per revolution (each input period
    2π/Ω divided evenly; the step size is :attr:`Batch.step_size`).

    Parameters
    ----------
    scene : dict
        A normalized scene (its ``time.revolutions`` and ``time.steps_per_revolution``).

    Returns
    -------
    int
        Number of time steps.
    """
    t = scene["time"]
    return int(round(t["revolutions"] * t["steps_per_revolution"]))


def structure_key(scene: dict) -> tuple:
    """Scenes with equal keys can be solved in one vectorized batch.

    Parameters
    ----------
    scene : dict
        A normalized scene.

    Returns
    -------
    tuple
        Mechanism type, step count, output sampling and stations, discretization, flexible links,
        effects, time block and modal block.
    """
    n_steps = step_count(scene)
    disc = scene["discretization"]
    mech = scene["mechanism"]
    # Linkages of one type batch together only with the same dyad structure (names, kinds).
    shape = (mech["type"] if mech["type"] != "linkage" else
             repr(topology(mech)) + repr([d["kind"] for d in mech["dyads"]]))
    return (
        shape,
        n_steps,
        scene["outputs"]["every"],
        scene["outputs"]["stations"],
        repr(disc),
        tuple(link["flexible"] for link in scene["links"].values()),
        repr(scene["effects"]),
        repr(scene["time"]),
        repr(scene.get("modal")),
    )


@dataclass
class Batch:
    """Per-case parameters of a batch of structurally identical scenes."""

    scenes: list[dict]
    families: list[str]
    mechanism_type: str
    n_steps: int
    step_size: np.ndarray  # (case,) s
    speed: np.ndarray  # (case,) rad/s
    initial_angle: np.ndarray  # (case,) rad: θ0, or θ_mid for an oscillating input
    amplitude: np.ndarray  # (case,) rad, NaN for a rotating input
    branch: np.ndarray  # (case,) ±1
    lengths: dict[str, np.ndarray] = field(default_factory=dict)  # mechanism block, m
    bodies: BodyProperties | None = None
    gravity: np.ndarray | None = None  # (case, 2) m/s²
    #: Dyad description of each case (:func:`ced.problem.linkage.describe`) of a linkage of
    #: dyads, made once per batch (the rigid motion of every terms evaluation reads them);
    #: None for the types with their own kinematics.
    descriptions: list[dict] | None = None
    #: The rigid motion at the steps 0 … k of the step grid, (k, motion), kept by
    #: :meth:`rigid_motion` for the later calls at steps of the grid.
    _on_grid: tuple | None = field(default=None, repr=False, compare=False)
    #: The Newton–Euler systems of that motion solved, by (inertia, gravity bytes): kept by
    #: :meth:`rigid_forces` for the later calls at steps of the grid.
    _forces_on_grid: dict = field(default_factory=dict, repr=False, compare=False)
    #: :attr:`motion_turns`, once found.
    _turns: np.ndarray | None = field(default=None, repr=False, compare=False)
    #: The cases' :class:`ced.rigid.speed_family.SpeedFamilies` once found (False: not yet;
    #: None: their steps are not the same phases of the input).
    _families: object = field(default=False, repr=False, compare=False)
    #: The families' motion at unit speed at the steps 0 … k of the step grid, by k.
    _unit_on_grid: dict = field(default_factory=dict, repr=False, compare=False)

    @property
    def size(self) -> int:
        return len(self.scenes)

    @property
    def topology(self):
        return topology(self.scenes[0]["mechanism"])

    @property
    def link_lengths(self) -> np.ndarray:
        """(case, link) m, from each link's first joint to its second."""
        if self.mechanism_type not in _LENGTH_KEYS:
            return np.stack([self.lengths[name] for name in self.topology.links], axis=1)
        single = self.mechanism_type == "single_link"
        return np.stack([self.lengths["length" if single else name]
                         for name in self.topology.links], axis=1)

    @property
    def motion_turns(self) -> np.ndarray:
        """(case,) int: the input turns after which each case's rigid motion repeats, the
        first of :data:`MOTION_TURNS` whose grid motion (:meth:`rigid_motion`) is back at its
        start.

        A four-bar at a change point with its crank or ground shortest (or a rotating kite)
        passes the change point once a turn, straight through, onto the other assembly
        branch: its motion repeats only every two turns. The motion is compared at steps 0
        and 1 with the steps one (two) turns on, link angles modulo 2π and joint positions,
        to :data:`REPEAT_TOLERANCE`: step 1 as well, since a start on the change point itself
        is the same configuration on either branch. The motion is tracked from the start as
        the grid motion is, over one turn and a step (two, where some case has not repeated
        after one). A batch whose assembly solution cannot change repeats every turn (nothing
        is solved). Dyad linkages are compared alike.

        Raises
        ------
        ValueError
            A case's motion repeats after none of :data:`MOTION_TURNS`.
        """
        if self._turns is None:
            self._turns = self._repeat_turns()
        return self._turns

    def _repeat_turns(self) -> np.ndarray:
        """:attr:`motion_turns`, solved."""
        turns = np.ones(self.size, np.int64)
        if not self._may_switch_branch():
            return turns
        per_turn = self.scenes[0]["time"]["steps_per_revolution"]
        undecided = np.ones(self.size, bool)
        for count in MOTION_TURNS:
            later = count * per_turn
            # Solved apart, kept only where that changes no bit (_keep_one_turn): the kept
            # motion's length sets the neighbours its last step's interpolated velocities are
            # taken from (a singular step), and a one-turn case's results stay those of the
            # motion over one turn.
            grid = self._solve_motion(self.step_size[:, None] * np.arange(later + 2)[None, :])
            back = _same_configuration(grid, self.link_lengths, later)
            turns[undecided & back] = count
            undecided &= ~back
            if not undecided.any():
                if count == 1:
                    self._keep_one_turn(grid, per_turn)
                return turns
        raise ValueError(f"the rigid motion of case(s) {np.flatnonzero(undecided).tolist()} "
                         f"does not repeat after {' or '.join(map(str, MOTION_TURNS))} input "
                         f"turns")

    def _keep_one_turn(self, grid: kinematics.RigidMotion, per_turn: int) -> None:
        """Keep the repeat test's ``grid`` (steps 0 … per_turn + 1) as the grid motion
        (:meth:`_grid_motion`) where its steps are, bit for bit, those of the motion solved
        over one turn: a linkage of dyads, no step singular anywhere in ``grid`` and every RRR
        dyad on its starting solution at every step.

        Each step of a dyad's placement is then its own: only the interpolated rates of a
        singular step read later steps, and only a change of solution depends on whether the
        branches meet at the extra step (:func:`ced.rigid.kinematics.track_branch`). A
        six-bar batch so solves its motion once instead of twice (~1.3 ms a part).

        Parameters
        ----------
        grid : RigidMotion
            The motion at the steps 0 … per_turn + 1 of the step grid (case, step, …).
        per_turn : int
            Steps per input turn.
        """
        if (self._on_grid is not None or self.mechanism_type in _LENGTH_KEYS
                or grid.singular.any()):
            return
        descriptions = self.descriptions or [describe(s["mechanism"]) for s in self.scenes]
        for k, dyad in enumerate(descriptions[0]["dyads"]):
            if dyad["kind"] != "RRR":
                continue
            start = np.array([0 if d["dyads"][k]["branch"] == "open" else 1
                              for d in descriptions])  # as dyads._rrr starts
            if np.any(grid.branch[dyad["links"][0]] != start[:, None]):
                return
        self._on_grid = (per_turn + 1, grid)  # k ≥ per_turn: _grid_motion's contract

    @property
    def period_steps(self) -> int:
        """Steps of the batch's period: :attr:`motion_turns` × steps per revolution, the
        same for every case (:func:`ced.simulation.simulate.solve_batch` solves the cases of
        each number of turns apart).

        Raises
        ------
        ValueError
            The cases' motions repeat after different numbers of turns.
        """
        turns = np.unique(self.motion_turns)
        if len(turns) > 1:
            raise ValueError(f"the cases repeat after {turns.tolist()} input turns: "
                             f"solve each number of turns as its own batch")
        return int(turns[0]) * self.scenes[0]["time"]["steps_per_revolution"]

    def link_property(self, link: str, group: str, key: str) -> np.ndarray:
        """A ``material`` or ``section`` value of ``link`` for every case, (case,); e.g.
        ``link_property("coupler", "material", "E")`` in Pa."""
        return np.array([s["links"][link][group][key] for s in self.scenes], float)

    def time(self) -> np.ndarray:
        """(case, step) s."""
        return self.step_size[:, None] * np.arange(self.n_steps + 1)[None, :]

    def rigid_motion(self, times: np.ndarray | None = None) -> kinematics.RigidMotion:
        """Rigid motion on the step grid, or at arbitrary ``times`` (case, n) s.

        ``times`` on the step grid (every step or some of them, in any window: the rigid
        outputs' period, the period's terms sampled or evaluated chunk by chunk) are read from
        the motion of the steps 0 … k (at least one input period), solved once per batch and
        kept. So every evaluation follows the one continuous motion from the start: where the
        assembly's two branches meet (a change point) it passes straight through, whereas a
        window solved on its own would start again on the scene's branch (the motion of a
        window after the change point was the other branch's, up to π off in the link
        angles). Away from the grid (modal phases, collocation points) the times are solved
        on the branches that motion takes at the steps around them (:meth:`_off_grid`).
        """
        times = self.time() if times is None else times
        steps = self._grid_steps(times)
        if steps is None:
            return self._off_grid(times)
        return kinematics.at_steps(self._grid_motion(int(steps[-1])), steps)

    def _grid_motion(self, last: int) -> kinematics.RigidMotion:
        """The motion of the steps 0 … k, k ≥ ``last`` and at least one input period, solved
        from the start once and kept (solved again, longer, when a later step is asked for)."""
        if self._on_grid is None or last > self._on_grid[0]:
            last = max(last, self.scenes[0]["time"]["steps_per_revolution"])
            grid = np.arange(last + 1)
            self._on_grid = (last, self._solve_motion(self.step_size[:, None] * grid[None, :]))
        return self._on_grid[1]

    def _off_grid(self, times: np.ndarray) -> kinematics.RigidMotion:
        """The motion at times off the step grid, each on the assembly solution the grid's
        motion takes around it (:func:`ced.rigid.kinematics.branch_between`), so that it does
        not depend on which other times are asked for with it.

        Solved as a sequence of their own, the times tracked their own branch, and a sequence
        that sampled a change point coarsely (the modal analysis's 12 phases against 128 steps
        per revolution) could come out on the other configuration past it. A time past the
        kept motion lengthens it; one before the start (the quasi-static start's −h)
        continues its first step backwards. A batch whose assembly solutions cannot change
        (no change-point four-bar, no RRR dyad) is solved as given: it has one solution.
        """
        if not self._may_switch_branch():
            return self._solve_motion(times)
        position = times / self.step_size[:, None]  # in steps, fractional
        lower = np.maximum(np.floor(position), 0.0).astype(np.int64)
        grid = self._grid_motion(int(lower.max()) + 1 if lower.size else 0)
        follow = kinematics.branch_between(grid, lower, position - lower)
        return self._solve_motion(times, follow)

    def _may_switch_branch(self) -> bool:
        """Whether the motion of some case can change assembly solution: a four-bar at a
        change point (S + L = P + Q) or a linkage with an RRR dyad (tracked wherever its
        solutions meet)."""
        if self.mechanism_type == "four_bar":
            return "change_point" in self.families
        if self.mechanism_type in _LENGTH_KEYS:
            return False
        descriptions = self.descriptions or [describe(self.scenes[0]["mechanism"])]
        return any(d["kind"] == "RRR" for d in descriptions[0]["dyads"])

    def rigid_forces(self, times: np.ndarray, inertia: bool = True,
                     gravity: np.ndarray | None = None,
                     motion: kinematics.RigidMotion | None = None) -> InverseDynamics:
        """Inverse dynamics (:func:`ced.rigid.inverse_dynamics.inverse_dynamics`) of the rigid
        motion at ``times`` (case, n) s.

        On the step grid the forces are P + Ω² Q of each case's speed family
        (:meth:`_family_forces`, :mod:`ced.rigid.speed_family`: its systems solved at unit
        speed once, the rigid outputs' period, and the forces at later steps read from them:
        the period's terms sampled or evaluated chunk by chunk). Away from the grid they are
        solved as given.

        Parameters
        ----------
        times : numpy.ndarray
            Times, s, shape (case, n).
        inertia : bool, optional
            Include the d'Alembert forces of the rigid motion.
        gravity : numpy.ndarray, optional
            Gravity per case, m/s², shape (case, 2); default the batch's.
        motion : RigidMotion, optional
            :meth:`rigid_motion` at ``times``, where the caller has it.
        """
        motion = self.rigid_motion(times) if motion is None else motion
        gravity = self.gravity if gravity is None else np.asarray(gravity, float)
        steps = self._grid_steps(times)
        families = None if steps is None else self._speed_families()
        per_case = np.broadcast_to(gravity, (self.size, 2))
        if (families is not None and self._on_grid is not None
                and self._on_grid[0] in self._unit_on_grid and _one_gravity(per_case, families)):
            forces = self._family_forces(self._on_grid[0], steps, families, per_case,
                                         bool(inertia))
            if forces is not None:
                return forces
        elif steps is not None and newton_euler.COMPILED:
            last, grid = self._on_grid
            key = (bool(inertia), gravity.tobytes())
            kept = self._forces_on_grid.get(key)
            if kept is None or kept[0] != last:  # none yet, or the grid motion was extended
                kept = (last, newton_euler.solutions(grid, self.bodies, gravity, inertia))
                self._forces_on_grid[key] = kept
            forces = newton_euler.forces_at(kept[1], motion, steps)
            if forces is not None:
                return forces
        return newton_euler.inverse_dynamics(motion, self.bodies, gravity, inertia=inertia)

    def _family_forces(self, last: int, steps: np.ndarray,
                       families: speed_family.SpeedFamilies, gravity: np.ndarray,
                       inertia: bool) -> InverseDynamics | None:
        """The forces at ``steps`` of the grid, P + Ω² Q of each case's family
        (:mod:`ced.rigid.speed_family`): the families' systems at unit speed solved for
        gravity alone (P) and for the d'Alembert forces alone (Q). The compiled path solves
        them once over the grid motion and keeps them (read at ``steps``:
        :func:`ced.rigid.inverse_dynamics.forces_at`); ``CED_KERNEL=numpy`` solves them at
        ``steps``, the same bits. None where they are zero or cannot be read at ``steps``."""
        unit = self._unit_on_grid[last]
        bodies = speed_family.bodies_at_cases(self.bodies, families.nodes)
        g = np.ascontiguousarray(gravity[families.nodes])
        loads = ((g, False) if g.any() else None, (np.zeros_like(g), True) if inertia else None)
        if not any(loads):
            return None
        at = kinematics.at_steps(unit, steps)
        if not newton_euler.COMPILED:
            parts = [None if load is None else
                     newton_euler.inverse_dynamics(at, bodies, load[0], inertia=load[1])
                     for load in loads]
            return speed_family.combined_forces(*parts, families, self.speed)
        key = (inertia, gravity.tobytes(), "families")
        kept = self._forces_on_grid.get(key)
        if kept is None or kept[0] != last:
            kept = (last, *(None if load is None else newton_euler.solutions(unit, bodies, *load)
                            for load in loads))
            self._forces_on_grid[key] = kept
        parts = [None if k is None else newton_euler.forces_at(k, at, steps) for k in kept[1:]]
        if any(k is not None and p is None for k, p in zip(kept[1:], parts)):
            return None
        return speed_family.combined_forces(*parts, families, self.speed)

    def _speed_families(self) -> speed_family.SpeedFamilies | None:
        """The cases grouped by everything of their rigid problem but the speed
        (:mod:`ced.rigid.speed_family`), whose motion and forces on the step grid are solved
        at unit speed and scaled; None where the steps of the cases are not the same phases
        of the input (they are: the steps per revolution are part of :func:`structure_key`)."""
        if self._families is False:
            phase_step = self.speed * self.step_size  # 2π/N for every case
            self._families = (speed_family.speed_families(self._rigid_keys())
                              if np.allclose(phase_step, self._phase_step(), rtol=1e-12, atol=0)
                              else None)
        return self._families

    def _phase_step(self) -> float:
        """The input's phase per step, 2π/N rad (N steps per revolution)."""
        return 2.0 * math.pi / self.scenes[0]["time"]["steps_per_revolution"]

    def _rigid_keys(self) -> list[bytes]:
        """Per case, the bytes of everything its rigid motion and forces depend on but the
        speed: drive, assembly branch, mechanism (lengths, dyads), masses and gravity."""
        columns = [self.initial_angle, self.amplitude, self.branch.astype(float)]
        columns += [self.lengths[name] for name in sorted(self.lengths)]
        if self.gravity is not None:
            columns.append(self.gravity)
        if self.bodies is not None:
            columns += [getattr(self.bodies, f.name) for f in dataclasses.fields(self.bodies)
                        if getattr(self.bodies, f.name) is not None]
        table = np.ascontiguousarray(np.column_stack(
            [np.asarray(c, float).reshape(self.size, -1) for c in columns]))
        described = self.descriptions or [None] * self.size
        return [row.tobytes() + marshal.dumps(d) for row, d in zip(table, described)]

    def _grid_steps(self, times: np.ndarray) -> np.ndarray | None:
        """The steps k (n,) with ``times`` exactly step_size × k in every case, ascending from
        0 or more; None if they are not."""
        if times.ndim != 2 or not times.size:
            return None
        steps = np.rint(times[0] / self.step_size[0])
        if (steps[0] < 0 or np.any(np.diff(steps) <= 0)
                or not np.array_equal(times, self.step_size[:, None] * steps[None, :])):
            return None
        return steps.astype(np.int64)

    def _solve_motion(self, times: np.ndarray,
                      follow: dict | None = None) -> kinematics.RigidMotion:
        """The motion at ``times`` (case, n) s, its assembly solutions tracked along them
        from the scenes' branches, or given by ``follow``
        (:func:`ced.rigid.kinematics.branch_between`).

        On the step grid (steps 0 … k), every case takes its speed family's motion at unit
        speed, scaled (:mod:`ced.rigid.speed_family`), solved once per k and kept."""
        families = None if follow is not None else self._speed_families()
        steps = None if families is None else self._grid_steps(times)
        if steps is None or steps[0] != 0 or len(steps) != steps[-1] + 1:
            return self._solve_cases(slice(None), times, follow)
        last = int(steps[-1])
        unit = self._unit_on_grid.get(last)
        if unit is None:
            phases = self._phase_step() * np.arange(last + 1, dtype=float)
            nodes = families.nodes
            unit = self._solve_cases(nodes, np.repeat(phases[None, :], len(nodes), axis=0),
                                     None, np.ones(len(nodes)))
            self._unit_on_grid[last] = unit
        return speed_family.scaled_motion(unit, families, self.speed, times)

    def _solve_cases(self, cases: slice | np.ndarray, times: np.ndarray,
                     follow: dict | None, speed: np.ndarray | None = None
                     ) -> kinematics.RigidMotion:
        """:meth:`_solve_motion` of ``cases`` at their ``times`` (case of ``cases``, n), each
        case solved, at its own speed or at ``speed`` (rad/s, one per case of ``cases``)."""
        speed = self.speed[cases] if speed is None else speed
        motion = kinematics.input_motion(times, speed, self.initial_angle[cases],
                                         self.amplitude[cases])
        L = {name: value[cases] for name, value in self.lengths.items()}
        if self.mechanism_type == "four_bar":
            return kinematics.four_bar(
                L["ground"], L["crank"], L["coupler"], L["rocker"], motion,
                self.branch[cases], None if follow is None else follow["coupler"])
        if self.mechanism_type == "slider_crank":
            return kinematics.slider_crank(L["crank"], L["rod"], L["offset"], motion,
                                           self.branch[cases])
        if self.mechanism_type == "single_link":
            return kinematics.single_link(L["length"], motion)
        descriptions = self.descriptions or [describe(s["mechanism"]) for s in self.scenes]
        if not isinstance(cases, slice):
            descriptions = [descriptions[c] for c in cases]
        return dyads.linkage(descriptions, motion, follow)


def _one_gravity(gravity: np.ndarray, families: speed_family.SpeedFamilies) -> bool:
    """Whether each case's ``gravity`` (case, 2) is its family's first case's (a caller may
    give another gravity than the batch's, which the families were found with)."""
    return bool(np.array_equal(gravity, gravity[families.nodes[families.family]]))


def _same_configuration(motion: kinematics.RigidMotion, lengths: np.ndarray,
                        later: int) -> np.ndarray:
    """(case,) bool: the configurations at steps ``later`` and ``later + 1`` of ``motion``
    are those of steps 0 and 1 (link angles modulo 2π in rad, joint positions relative to the
    longest link in ``lengths`` (case, link) m, to :data:`REPEAT_TOLERANCE`)."""
    now, then = [0, 1], [later, later + 1]
    turned = motion.link_angle[:, then] - motion.link_angle[:, now]
    angle = np.abs(np.angle(np.exp(1j * turned))).max(axis=(1, 2))
    moved = np.abs(motion.joint_position[:, then] - motion.joint_position[:, now])
    position = moved.max(axis=(1, 2, 3)) / lengths.max(axis=1)
    # A motion that is not finite is not told apart here: the run's check of non-finite
    # results fails that case (ced.simulation.simulate), not the whole batch.
    undefined = ~np.isfinite(angle + position)
    return undefined | ((angle <= REPEAT_TOLERANCE) & (position <= REPEAT_TOLERANCE))


_LENGTH_KEYS = {
    "four_bar": ("ground", "crank", "coupler", "rocker"),
    "slider_crank": ("crank", "rod", "offset"),
    "single_link": ("length",),
}


def _link_length(description: dict, link: str) -> float:
    """Distance from the link's first joint to its second in a dyad description, m."""
    if description["input"]["link"] == link:
        return description["input"]["length"]
    for dyad in description["dyads"]:
        if link in dyad["links"]:
            return dyad["lengths"][dyad["links"].index(link)]
    raise KeyError(link)


def _drive(scene: dict, family: str) -> tuple[float, float]:
    """(initial angle, amplitude) of the input: rotation from θ0, or θ_mid + A sin(Ωt) with A a
    fraction of the feasible half-range for rocker-input families (docs/theory.md)."""
    drive, mech = scene["drive"], scene["mechanism"]
    if mech["type"] not in ("four_bar", "watt_ii", "stephenson_iii"):
        return drive["initial_angle"], math.nan
    limits = input_limits(mech["ground"], mech["crank"], mech["coupler"], mech["rocker"])
    if limits.full_rotation:
        return drive["initial_angle"], math.nan
    return limits.mid, drive["amplitude"] * limits.half_range


def _body_properties(scenes: list[dict], lengths: dict[str, np.ndarray],
                     descriptions: list[dict] | None = None) -> BodyProperties:
    """Link mass ρAL and centroidal inertia mL²/12 + ρL·I_section (the section term is the
    in-plane second moment, e.g. m h²/12 for a rectangle of in-plane height h); a linkage of
    dyads from its ``descriptions`` (:func:`_linkage_bodies`)."""
    if scenes[0]["mechanism"]["type"] not in _LENGTH_KEYS:
        return _linkage_bodies(scenes, lengths, descriptions)
    topo = topology(scenes[0]["mechanism"]["type"])
    mass = np.zeros((len(scenes), len(topo.links)))
    inertia = np.zeros_like(mass)
    point = np.zeros((len(scenes), len(topo.joints)))
    slider = np.zeros(len(scenes))
    for c, scene in enumerate(scenes):
        mech = scene["mechanism"]
        for i, name in enumerate(topo.links):
            link = scene["links"][name]
            L = mech["length"] if mech["type"] == "single_link" else mech[name]
            rho = link["material"]["rho"]
            mass[c, i] = rho * link["section"]["area"] * L
            inertia[c, i] = mass[c, i] * L * L / 12.0 + rho * L * link["section"]["second_moment"]
        for k, joint in enumerate(topo.joints):
            point[c, k] = scene["point_masses"].get(joint, 0.0)
        slider[c] = mech.get("slider_mass", 0.0)
    return BodyProperties(mass, inertia, point, slider)


def _linkage_bodies(scenes: list[dict], lengths: dict[str, np.ndarray],
                    descriptions: list[dict]) -> BodyProperties:
    """Mass properties of the links of linkages of dyads: each link is its bars
    (:func:`ced.problem.linkage.ternary_bars`), uniform rods of the link's section welded at
    its first joint; each bar of length ℓ has mass ρAℓ, centroid at mid-bar and centroidal
    inertia ρAℓ³/12 + ρℓ I_section; the link's sums by the parallel-axis theorem. Slider
    blocks and RPR sleeves take the masses (and a sleeve its inertia) of their dyads.

    Every case at once, link by link (:func:`ced.problem.linkage.bar_ends`: a bar not made in
    a case weighs nothing there): the per-case loop cost a six-bar batch ~0.1 ms a case."""
    topo = topology(scenes[0]["mechanism"])
    ncase = len(scenes)
    mass = np.zeros((ncase, len(topo.links)))
    inertia = np.zeros_like(mass)
    centre = np.zeros((ncase, len(topo.links), 2))
    for i, name in enumerate(topo.links):
        rho, area, second_moment = (
            np.array([s["links"][name][group][key] for s in scenes], float)[:, None]
            for group, key in (("material", "rho"), ("section", "area"),
                               ("section", "second_moment")))
        ends, made = bar_ends(descriptions, name, lengths[name])
        bar = np.hypot(ends[..., 0], ends[..., 1])  # (case, bar)
        m = np.where(made, rho * area * bar, 0.0)
        mid = 0.5 * ends
        mass[:, i] = m.sum(axis=1)
        centre[:, i] = (m[:, None, :] @ mid)[:, 0] / mass[:, i, None]
        offset = np.sum((mid - centre[:, i, None]) ** 2, axis=2)
        own = np.where(made, m * bar**2 / 12.0 + rho * bar * second_moment, 0.0)
        inertia[:, i] = np.sum(own + m * offset, axis=1)
    point = np.array([[s["point_masses"].get(joint, 0.0) for joint in topo.joints]
                      for s in scenes], float).reshape(ncase, len(topo.joints))
    dyads_of = [{d["links"][1]: d for d in description["dyads"]}
                for description in descriptions]
    slider = np.array([[dyads[name]["slider_mass"] for name in topo.sliders]
                       for dyads in dyads_of], float).reshape(ncase, len(topo.sliders))
    if not topo.sleeves:
        return BodyProperties(mass, inertia, point, slider, centre)
    sleeve = np.array([[(dyads[name]["sleeve_mass"], dyads[name]["sleeve_inertia"])
                        for name in topo.sleeves] for dyads in dyads_of], float)
    return BodyProperties(mass, inertia, point, slider, centre, sleeve[..., 0], sleeve[..., 1])


def make_batch(scenes: list[dict]) -> Batch:
    """Collect the per-case parameters of structurally identical normalized scenes.

    Parameters
    ----------
    scenes : list of dict
        Normalized scenes with equal :func:`structure_key`.

    Returns
    -------
    Batch
        Per-case arrays (leading ``case`` axis): lengths in m, speed in rad/s, step size in s,
        initial angle and amplitude in rad, body properties and gravity in m/s².
    """
    kind = scenes[0]["mechanism"]["type"]
    families = [case_family(s) for s in scenes]
    drives = [_drive(s, f) for s, f in zip(scenes, families)]
    if kind in _LENGTH_KEYS:
        lengths = {key: np.array([s["mechanism"][key] for s in scenes], float)
                   for key in _LENGTH_KEYS[kind]}
        descriptions = None
    else:  # a linkage of dyads: every link's length, first joint to second
        descriptions = [describe(s["mechanism"]) for s in scenes]
        lengths = {name: np.array([_link_length(d, name) for d in descriptions])
                   for name in topology(scenes[0]["mechanism"]).links}
    speed = np.array([s["drive"]["speed"] for s in scenes], float)
    steps_per_revolution = np.array([s["time"]["steps_per_revolution"] for s in scenes], float)
    return Batch(
        scenes=scenes,
        families=families,
        mechanism_type=kind,
        n_steps=step_count(scenes[0]),
        step_size=2.0 * math.pi / speed / steps_per_revolution,
        speed=speed,
        initial_angle=np.array([d[0] for d in drives]),
        amplitude=np.array([d[1] for d in drives]),
        branch=np.array(
            [1.0 if s["mechanism"].get("branch", "open") == "open" else -1.0 for s in scenes]),
        lengths=lengths,
        bodies=_body_properties(scenes, lengths, descriptions),
        gravity=np.array(
            [s["gravity"] if "gravity" in s["effects"] else (0.0, 0.0) for s in scenes], float),
        descriptions=descriptions,
    )
