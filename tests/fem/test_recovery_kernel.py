"""The compiled recovery (ced.fem.recovery_kernel) against the numpy path
(ced.fem.recovery.link_fields and peaks), to round-off."""
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from ced.fem.recovery import deflection, link_fields, peaks
from ced.fem.recovery_kernel import FIELDS, OPERATORS, recover


def _reference(qz, first_row, operators, stations, height, E, qz_static=None):
    """What ced.response.elastic did before the kernel: link_fields and peaks link by link,
    zeros for rigid links, the fields cast to float32 as stored."""
    ncase, nstep = qz.shape[:2]
    nlink, nst = len(operators), len(stations)
    out = {name: np.zeros((ncase, nstep, nlink, nst), np.float32) for name in FIELDS}
    out["stress"] = np.zeros((ncase, nstep, nlink, nst, 2), np.float32)
    for key in ("peak_deflection", "peak_stress", "static_peak_deflection"):
        out[key] = np.zeros((ncase, nlink))
    for i, (r0, ops) in enumerate(zip(first_row, operators)):
        if ops is None:
            continue
        rows = slice(r0, r0 + ops["v"].shape[-1])
        ops = {k: np.broadcast_to(op, (ncase,) + op.shape[-2:]) for k, op in ops.items()}
        link = link_fields(qz[..., rows], ops, stations, height[:, i], E[:, i])
        for name in FIELDS + ("stress",):
            out[name][:, :, i] = link[name]
        out["peak_deflection"][:, i] = peaks(link["deflection"][:, :, None])[:, 0]
        out["peak_stress"][:, i] = peaks(np.abs(link["stress"]).max(axis=-1)[:, :, None])[:, 0]
        if qz_static is not None:
            static = deflection(qz_static[..., rows], ops["v"], stations)
            out["static_peak_deflection"][:, i] = peaks(static[:, :, None])[:, 0]
    if qz_static is None:
        del out["static_peak_deflection"]
    return out


def _assert_agree(got, want, exact=False):
    assert set(got) == set(want)
    for name, value in want.items():
        assert got[name].shape == value.shape and got[name].dtype == value.dtype, name
        nan = np.isnan(value)
        assert np.array_equal(np.isnan(got[name]), nan), name
        if exact:
            np.testing.assert_array_equal(got[name], value, err_msg=name)
        elif value.dtype == np.float32:  # float32 of float64 values equal to round-off
            spacing = np.spacing(np.abs(value)).astype(float)
            assert (np.abs(got[name].astype(float) - value) <= spacing)[~nan].all(), name
        else:
            scale = np.nanmax(np.abs(value), axis=0, keepdims=True)
            assert (np.abs(got[name] - value) <= 1e-13 * scale)[~nan].all(), name


def _random_links(rng, ncase, nst, sizes, per_case=True):
    """Random operators for links of ``sizes`` DOFs (0: a rigid link), their first rows in z
    and nz (with a few rows of joint DOFs between links)."""
    operators, first_row, row = [], [], 2
    for n in sizes:
        first_row.append(row)
        if n == 0:
            operators.append(None)
            row += 3
            continue
        shape = (ncase, nst, n) if per_case else (nst, n)
        operators.append({name: rng.standard_normal(shape) for name in OPERATORS})
        row += n + 1
    return operators, first_row, row


def _identity_link(nst):
    """Operators that read each field straight from q = (v, curvature, axial strain, u) at the
    stations: the history of every field is chosen by q, and every sum is exact."""
    eye = np.eye(4 * nst)
    return {name: eye[k * nst:(k + 1) * nst][None] for k, name in enumerate(OPERATORS)}


@pytest.mark.parametrize("fields", [True, False])
@pytest.mark.parametrize("per_case", [True, False])
def test_random_links_with_a_rigid_one_agree_with_numpy(fields, per_case):
    rng = np.random.default_rng(1)
    ncase, nstep, nst = 3, 41, 7
    operators, first_row, nz = _random_links(rng, ncase, nst, (0, 6, 0, 4), per_case)
    t = np.linspace(0.0, 1.0, nstep)[None, :, None]
    # smooth histories (interior peaks) plus noise (peaks anywhere)
    qz = (np.sin(2 * np.pi * (3 * t + rng.random((ncase, 1, nz))))
          + 0.3 * rng.standard_normal((ncase, nstep, nz)))
    qz_static = rng.standard_normal((ncase, nstep, nz))
    stations = np.linspace(0.0, 1.0, nst)
    height = rng.uniform(0.001, 0.01, (ncase, 4))
    E = rng.uniform(7e10, 2e11, (ncase, 4))
    got = recover(qz, first_row, operators, stations, height, E, fields, qz_static)
    want = _reference(qz, first_row, operators, stations, height, E, qz_static)
    if not fields:
        want = {k: v for k, v in want.items() if k.startswith(("peak", "static"))}
    _assert_agree(got, want)
    assert (got["peak_stress"][:, [0, 2]] == 0).all() and (got["peak_stress"][:, 1] > 0).all()
    if fields:
        assert (got["stress"][:, :, [0, 2]] == 0).all()
    assert "static_peak_deflection" not in recover(qz, first_row, operators, stations, height,
                                                   E, fields)


def _identity_case(v, curvature, axial, u=None):
    """qz (1, step, 4 station) of one identity link from (step, station) histories."""
    u = np.zeros_like(v) if u is None else u
    return np.concatenate([v, curvature, axial, u], axis=-1)[None]


@pytest.mark.parametrize("where", ["first step", "last step", "interior"])
@pytest.mark.parametrize("station", [0, 2, 4])
def test_peak_at_the_ends_of_the_history_and_of_the_link(where, station):
    """Stress peak at the first or last step (the sample itself) or in between (raised to the
    parabola's vertex), at an end station or the middle; the deflection, zero at the ends of
    the link by construction, peaks at the middle."""
    nst, nstep = 5, 12
    t = np.arange(nstep, dtype=float)
    shape = {"first step": -t, "last step": t, "interior": -(t - 6.3) ** 2}[where]
    axial = np.full((nstep, nst), 1e-5)
    axial[:, station] = 2e-4 + 1e-6 * shape
    v = np.zeros((nstep, nst))
    v[:, 2] = 1e-3 * np.cos(0.4 * t)  # the largest at step 0, its parabola clipped
    curvature = 1e-3 * np.sin(0.3 * t)[:, None] * np.ones(nst)
    qz = _identity_case(v, curvature, axial)
    args = ([0], [_identity_link(nst)], np.linspace(0.0, 1.0, nst), np.array([[0.004]]),
            np.array([[2e11]]))
    got, want = recover(qz, *args), _reference(qz, *args)
    _assert_agree(got, want, exact=True)  # the identity operators' sums are exact
    k = int(np.argmax(np.abs(want["stress"][0, :, 0, station]).max(axis=-1)))
    assert k == {"first step": 0, "last step": nstep - 1, "interior": 6}[where]
    sample = np.abs(2e11 * (axial[k, station] + np.array([1, -1]) * 0.002 * curvature[k, 0]))
    if where == "interior":
        assert got["peak_stress"][0, 0] > sample.max()
    else:
        assert got["peak_stress"][0, 0] == pytest.approx(sample.max(), rel=1e-15)


@pytest.mark.parametrize("value", [0.0, 3e-3])
def test_flat_histories(value):
    """A zero or constant history: the peak is the sample (the parabola is flat: no rise)."""
    nst, nstep = 3, 8
    flat = np.full((nstep, nst), value)
    qz = _identity_case(flat, flat, flat, flat)
    args = ([0], [_identity_link(nst)], np.linspace(0.0, 1.0, nst), np.array([[0.01]]),
            np.array([[1e11]]))
    got = recover(qz, *args, qz_static=qz)
    _assert_agree(got, _reference(qz, *args, qz_static=qz), exact=True)
    assert got["peak_stress"][0, 0] == 1e11 * (value + 0.005 * value)
    assert got["peak_deflection"][0, 0] == 0.0  # a constant v is a rigid translation


@pytest.mark.parametrize("nstep", [1, 2, 3])
def test_too_few_steps_for_a_parabola(nstep):
    rng = np.random.default_rng(5)
    operators, first_row, nz = _random_links(rng, 2, 3, (5, 0, 3))
    qz = rng.standard_normal((2, nstep, nz))
    args = (first_row, operators, np.linspace(0.0, 1.0, 3), np.full((2, 3), 0.005),
            np.full((2, 3), 2e11))
    _assert_agree(recover(qz, *args, qz_static=qz), _reference(qz, *args, qz_static=qz))


def test_a_nan_makes_the_peak_nan_as_numpy_does():
    rng = np.random.default_rng(2)
    operators, first_row, nz = _random_links(rng, 2, 5, (4, 0, 4))
    qz = rng.standard_normal((2, 9, nz))
    qz[0, 4, first_row[0]] = np.nan  # link 0 of case 0 only
    args = (first_row, operators, np.linspace(0.0, 1.0, 5), np.full((2, 3), 0.005),
            np.full((2, 3), 2e11))
    got = recover(qz, *args, qz_static=qz)
    _assert_agree(got, _reference(qz, *args, qz_static=qz))
    assert np.isnan(got["peak_stress"][0, 0]) and np.isfinite(got["peak_stress"][1]).all()
    assert np.isfinite(got["peak_stress"][0, 1:]).all()


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), nstep=st.integers(1, 30), nst=st.integers(2, 6),
       sizes=st.lists(st.integers(0, 5), min_size=1, max_size=4),
       smooth=st.booleans())
def test_any_layout_agrees_with_numpy(seed, nstep, nst, sizes, smooth):
    rng = np.random.default_rng(seed)
    ncase = int(rng.integers(1, 4))
    operators, first_row, nz = _random_links(rng, ncase, nst, sizes)
    if smooth:
        t = np.linspace(0.0, 1.0, nstep)[None, :, None]
        # Not periodic on the step grid: samples a period apart would tie to round-off, and
        # which of them is the first largest (at an end, or interior and raised) would then
        # depend on the order of the sums.
        frequency = rng.uniform(0.3, 1.7, (1, 1, nz))
        qz = np.cos(2 * np.pi * (frequency * t + rng.random((ncase, 1, nz))))
    else:
        qz = rng.standard_normal((ncase, nstep, nz))
    nlink = len(sizes)
    args = (first_row, operators, np.linspace(0.0, 1.0, nst),
            rng.uniform(0.001, 0.01, (ncase, nlink)), rng.uniform(7e10, 2e11, (ncase, nlink)))
    _assert_agree(recover(qz, *args, qz_static=2.0 * qz), _reference(qz, *args, 2.0 * qz))
