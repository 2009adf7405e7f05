import numpy as np
import pytest

from ced.rigid import kinematics as kin
from ced.fem.coupling import build_layout, projection
from ced.problem.mechanism import topology

FD8 = np.array([1 / 280, -4 / 105, 1 / 5, -4 / 5, 0, 4 / 5, -1 / 5, 4 / 105, -1 / 280])
BEAM = 9  # a 2-element beam: nodes (u, v, θ) × 3
BEAM_ENDS = ((0, 1), (6, 7))


def _layout(kind, flexible):
    topo = topology(kind)
    sizes = {n: BEAM if flexible[n] else 3 for n in topo.links}
    ends = {n: BEAM_ENDS if flexible[n] else ((0, 1), (0, 1)) for n in topo.links}
    slider = "C" if kind == "slider_crank" else None
    return build_layout(topo, flexible, sizes, ends, (2,), slider_joint=slider)


def _motion(kind, times):
    n = times.shape[0]
    m = kin.input_motion(times, np.full(n, 40.0), np.full(n, 0.3))
    if kind == "four_bar":
        return kin.four_bar([0.5], [0.1], [0.45], [0.35], m, [1.0])
    return kin.slider_crank([0.15], [0.3], [0.02], m, [1.0])


CASES = [
    ("four_bar", {"crank": False, "coupler": True, "rocker": False}),
    ("four_bar", {"crank": True, "coupler": True, "rocker": True}),
    ("four_bar", {"crank": True, "coupler": False, "rocker": False}),
    ("four_bar", {"crank": False, "coupler": False, "rocker": True}),
    ("slider_crank", {"crank": False, "rod": True}),
    ("slider_crank", {"crank": True, "rod": False}),
]


def _P(layout, motion):
    return projection(layout, motion.lengths, motion.link_angle, motion.link_angular_velocity,
                      motion.link_angular_acceleration)


@pytest.mark.parametrize("kind, flexible", CASES)
def test_projection_satisfies_joint_constraints(kind, flexible):
    layout = _layout(kind, flexible)
    times = np.linspace(0.0, 0.15, 13)[None]
    motion = _motion(kind, times)
    P = _P(layout, motion)[0, 0]  # (step, nz, nfree)
    rng = np.random.default_rng(0)
    y = rng.normal(size=(layout.ny,))
    z = layout.expand(P, np.broadcast_to(y, P.shape[:1] + y.shape).copy())
    topo = layout.topology
    joint = {j: z[:, off : off + 2] for j, off in layout.joint_offsets.items()}
    for j in topo.ground_joints:
        assert np.abs(joint[j]).max() < 1e-14
    if kind == "slider_crank":
        assert np.abs(joint["C"][:, 1]).max() < 1e-14  # guide parallel to x
    for i, name in enumerate(topo.links):
        first, second = topo.links[name]
        th = motion.link_angle[0, :, i]
        e = np.stack([np.cos(th), np.sin(th)], -1)
        n = np.stack([-np.sin(th), np.cos(th)], -1)
        local = lambda U: np.stack([np.sum(e * U, -1), np.sum(n * U, -1)], -1)  # noqa: E731
        block = z[:, layout.link_offsets[name] : layout.link_offsets[name] + layout.link_sizes[name]]
        if flexible[name]:
            (u0, v0), (u1, v1) = BEAM_ENDS
            assert np.allclose(block[:, [u0, v0]], local(joint[first]), atol=1e-13)
            assert np.allclose(block[:, [u1, v1]], local(joint[second]), atol=1e-13)
        else:
            L = motion.lengths[0, i]
            assert np.allclose(block[:, :2], local(joint[first]), atol=1e-13)
            far = block[:, :2] + np.stack([0 * block[:, 2], L * block[:, 2]], -1)
            assert np.allclose(far, local(joint[second]), atol=1e-13)  # inextensible, rigid
    # The driven input link is clamped at its ground pivot.
    crank = z[:, layout.link_offsets["crank"] : layout.link_offsets["crank"] + 3]
    assert np.abs(crank[:, 2] if flexible["crank"] else crank).max() < 1e-14


@pytest.mark.parametrize("kind, flexible", CASES)
def test_projection_derivatives_match_finite_differences(kind, flexible):
    layout = _layout(kind, flexible)
    dt = 1e-5
    t0 = 0.037
    times = (t0 + dt * np.arange(-4, 5))[None]
    P = _P(layout, _motion(kind, times))
    value = P[0, 0]
    fd1 = np.tensordot(FD8, value, axes=(0, 0)) / dt
    fd2 = np.tensordot(FD8, P[1, 0], axes=(0, 0)) / dt
    scale1 = np.abs(P[1, 0, 4]).max() + 1e-12
    scale2 = np.abs(P[2, 0, 4]).max() + 1e-12
    assert np.abs(fd1 - P[1, 0, 4]).max() < 1e-7 * scale1 + 1e-9
    assert np.abs(fd2 - P[2, 0, 4]).max() < 1e-7 * scale2 + 1e-9


def test_layout_dof_counts():
    # Reference four-bar with rigid crank and rocker: the rocker's rotation (one coordinate at
    # C) plus the coupler's interior DOFs (9 − 4 end translations).
    layout = _layout("four_bar", CASES[0][1])
    assert layout.ny == 1 + (BEAM - 4)
    # All links rigid: no elastic freedom at all.
    rigid = _layout("four_bar", {"crank": False, "coupler": False, "rocker": False})
    assert rigid.ny == 0


@pytest.mark.parametrize("flexible_links", [("coupler2",), ("coupler", "rocker2"), ("crank",)])
def test_watt_ii_projection_keeps_rigid_links_rigid_and_points_on_them(flexible_links):
    """Six-bar: every rigid link inextensible (closed rigid loops included), the joint E at a
    point of the rigid ternary rocker moving with it, and Ṗ, P̈ the time derivatives of P."""
    from ced.problem.scene import load_scene
    from ced.response.batch import make_batch
    from ced.response.model import build_model, terms_at
    from tests.rigid.test_dyads import WATT_II

    links = {n: {"flexible": n in flexible_links}
             for n in ("crank", "coupler", "coupler2", "rocker2")}
    batch = make_batch([load_scene({"mechanism": WATT_II, "links": links})])
    model = build_model(batch)
    layout, topo = model.layout, model.layout.topology
    dt, t0 = 1e-5, 0.037
    times = (t0 + dt * np.arange(-4, 5))[None]
    _, P = terms_at(model, times)
    jet = projection(layout, batch.link_lengths, *(
        getattr(batch.rigid_motion(times), k) for k in
        ("link_angle", "link_angular_velocity", "link_angular_acceleration")), model.points)
    assert np.array_equal(jet[0], P)
    fd1 = np.tensordot(FD8, jet[0, 0], axes=(0, 0)) / dt
    assert np.abs(fd1 - jet[1, 0, 4]).max() < 1e-7 * np.abs(jet[1, 0, 4]).max() + 1e-9
    y = np.random.default_rng(1).normal(size=(9, layout.ny))
    z = layout.expand(P[0], y)
    U = {j: z[:, off:off + 2] for j, off in layout.joint_offsets.items()}
    motion = batch.rigid_motion(times)
    for i, name in enumerate(topo.links):
        th = motion.link_angle[0, :, i]
        e = np.stack([np.cos(th), np.sin(th)], -1)
        n = np.stack([-np.sin(th), np.cos(th)], -1)
        first, second = topo.links[name]
        if not layout.flexible[name]:
            assert np.abs(np.sum(e * (U[second] - U[first]), -1)).max() < 1e-12, name
        if name == "rocker":
            phi = np.sum(n * (U[second] - U[first]), -1) / batch.link_lengths[0, i]
            x, yy = model.points["E"][0]
            expected = U[first] + phi[:, None] * (x * n - yy * e)
            assert np.allclose(U["E"], expected, atol=1e-12)
    assert layout.ny == len(layout.free_coordinates) + len(layout.interior_dofs)


def _both_paths(monkeypatch, *args):
    from ced.fem import coupling
    out = []
    for compiled in (True, False):
        monkeypatch.setattr(coupling, "COMPILED", compiled)
        out.append(projection(*args))
    return out


@pytest.mark.parametrize("kind, flexible", CASES)
@pytest.mark.parametrize("guide", [None, 0.3])
def test_compiled_projection_is_the_numpy_one_bit_for_bit(monkeypatch, kind, flexible, guide):
    layout = _layout(kind, flexible)
    motion = _motion(kind, np.linspace(0.0, 0.15, 13)[None])
    guides = {"C": np.array([guide])} if guide is not None and kind == "slider_crank" else None
    compiled, numpy = _both_paths(monkeypatch, layout, motion.lengths, motion.link_angle,
                                  motion.link_angular_velocity,
                                  motion.link_angular_acceleration, None, guides)
    assert np.array_equal(compiled, numpy)
    _assert_zero_outside_projection_rows(layout, compiled, motion.lengths, motion.link_angle,
                                         motion.link_angular_velocity,
                                         motion.link_angular_acceleration, None, guides)


def _assert_zero_outside_projection_rows(layout, P, *args):
    """P (…, nz, nfree) is zero, +0.0, in every row but layout.projection_rows; given the
    arguments of ``projection``, its compact jet is those rows, then two zero rows, by both
    paths."""
    others = np.setdiff1d(np.arange(layout.nz), layout.projection_rows)
    rest = P[..., others, :]
    assert not rest.any() and not np.signbit(rest).any()
    if not args:
        return
    from ced.fem import coupling
    rows, default = len(layout.projection_rows), coupling.COMPILED
    for compiled in (True, False):
        coupling.COMPILED = compiled
        try:
            compact = projection(layout, *args, compact=True)
        finally:
            coupling.COMPILED = default
        assert np.array_equal(compact[..., :rows, :], P[..., layout.projection_rows, :])
        assert compact.shape[-2] == rows + 2 and not compact[..., rows:, :].any()


@pytest.mark.parametrize("flexible_links", [("coupler2",), ("coupler", "rocker2"), ("crank",),
                                            ("coupler", "coupler2", "rocker2"),
                                            ("crank", "coupler", "coupler2", "rocker2")])
def test_compiled_watt_ii_projection_is_the_numpy_one_bit_for_bit(monkeypatch, flexible_links):
    """The point E of the ternary rocker and the rigid loops' owned coordinates, several
    cases and steps."""
    from ced.problem.scene import load_scene
    from ced.response.batch import make_batch
    from ced.response.model import build_model
    from tests.rigid.test_dyads import WATT_II

    links = {n: {"flexible": n in flexible_links}
             for n in ("crank", "coupler", "coupler2", "rocker2")}
    batch = make_batch([load_scene({"mechanism": WATT_II, "links": links,
                                    "drive": {"speed": w}}) for w in (10.0, 37.0, 90.0)])
    model = build_model(batch)
    motion = batch.rigid_motion(batch.step_size[:, None] * np.arange(0.0, 40.0, 1.7)[None])
    compiled, numpy = _both_paths(monkeypatch, model.layout, batch.link_lengths,
                                  motion.link_angle, motion.link_angular_velocity,
                                  motion.link_angular_acceleration, model.points)
    assert np.array_equal(compiled, numpy)
    _assert_zero_outside_projection_rows(model.layout, compiled, batch.link_lengths,
                                         motion.link_angle, motion.link_angular_velocity,
                                         motion.link_angular_acceleration, model.points)


@pytest.mark.parametrize("name", ["watt_ii", "stephenson_iii", "press", "shaper", "cylinder"])
def test_projection_is_zero_outside_its_rows(name):
    """The period's terms keep P's rows Layout.projection_rows only: every other row is
    zero at every step, for linkages of dyads with points, sliders and RPR sleeves too."""
    from ced.problem.scene import load_scene
    from ced.response.batch import make_batch
    from ced.response.model import build_model, terms_at
    from tests.rigid.test_dyads import MECHANISMS

    batch = make_batch([load_scene({"mechanism": MECHANISMS[name], "drive": {"speed": w}})
                        for w in (10.0, 37.0)])
    model = build_model(batch)
    _, P = terms_at(model, batch.step_size[:, None] * np.arange(0.0, 40.0, 1.7)[None])
    _assert_zero_outside_projection_rows(model.layout, P)
    assert len(model.layout.projection_rows) < model.layout.nz
