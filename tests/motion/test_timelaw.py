"""Time laws: coefficients as the seeds tabulate them, boundary conditions, LSPB, errors."""

import math

import numpy as np
import pytest

from labkit.exceptions import ShapeError, TrajectoryError
from labkit.motion import (
    LawName,
    TimeLaw,
    cubic_law,
    linear_law,
    lspb_law,
    make_law,
    minimum_duration,
    quintic_law,
    time_grid,
)

# seed 000, section IV: cubic Cartesian move in 5 s sampled at 0.1 s
U0 = np.array([0.0, 0.18, -0.094])
UF = np.array([0.1, 0.15, -0.2])


def test_seed000_cubic_coefficients_per_axis():
    law = cubic_law(U0, UF, 5.0)
    a = law.coefficients[0]  # (4, 3): a0..a3 per axis
    D = UF - U0
    np.testing.assert_allclose(a[0], U0, atol=1e-15)
    np.testing.assert_allclose(a[1], 0.0, atol=1e-15)
    np.testing.assert_allclose(a[2], 3 / 25 * D, rtol=1e-12)  # 3 / tf^2 (uf - u0)
    np.testing.assert_allclose(a[3], -2 / 125 * D, rtol=1e-12)  # -2 / tf^3 (uf - u0)
    np.testing.assert_allclose(a[2], [0.012, -0.0036, -0.01272], rtol=1e-12)
    np.testing.assert_allclose(a[3], [-0.0016, 0.00048, 0.001696], rtol=1e-12)


def test_seed000_peak_speed_0_0446_is_the_published_0_045_at_two_figures():
    """The seed reports 0.045 m/s at t = 2.5 s: the true peak 1.5 |uf - u0| / tf = 0.0446 m/s rounds to it."""
    law = cubic_law(U0, UF, 5.0)
    t = time_grid(0.0, 5.0, 0.1)
    assert t.size == 51
    speed = np.linalg.norm(law.velocity(t), axis=-1)
    dist = np.linalg.norm(UF - U0)
    assert dist == pytest.approx(0.14878, abs=1e-5)
    assert speed.max() == pytest.approx(1.5 * dist / 5.0, rel=1e-12)
    assert speed.max() == pytest.approx(0.04463, abs=1e-5)
    assert f"{speed.max():.2g}" == "0.045"  # the published value, two significant figures
    assert t[np.argmax(speed)] == pytest.approx(2.5)
    # the seed's "gradient of the acceleration graph, -0.0143": |jerk| = 12 D / tf^3
    jerk = np.linalg.norm(law.jerk(1.0))
    assert jerk == pytest.approx(0.0143, abs=5e-5)
    np.testing.assert_allclose(law.position(5.0), UF, atol=1e-15)


def test_seed003_joint_cubic_coefficients():
    law = cubic_law([0.0, 0.0, 1.57], [-0.8, 0.8, 0.8], 5.0)
    a = law.coefficients[0]
    np.testing.assert_allclose(a[0], [0.0, 0.0, 1.57])
    np.testing.assert_allclose(a[1], 0.0, atol=1e-15)
    np.testing.assert_allclose(a[2], [-0.096, 0.096, -0.0924], rtol=1e-12)
    np.testing.assert_allclose(a[3], [0.0128, -0.0128, 0.01232], rtol=1e-12)
    table = law.coefficient_table(["q1", "q2", "q3"])
    assert list(table.columns) == ["t_start", "t_end", "a0", "a1", "a2", "a3"]
    assert table.loc[(1, "q3"), "a2"] == pytest.approx(-0.0924)


@pytest.mark.parametrize("builder", ["cubic", "quintic"])
def test_boundary_conditions(builder, rng):
    q0, qf = rng.normal(size=4), rng.normal(size=4)
    v0, vf = rng.normal(size=4), rng.normal(size=4)
    T, t0 = 2.5, 1.0
    if builder == "cubic":
        law = cubic_law(q0, qf, T, v0=v0, vf=vf, t0=t0)
    else:
        a0, af = rng.normal(size=4), rng.normal(size=4)
        law = quintic_law(q0, qf, T, v0=v0, vf=vf, a0=a0, af=af, t0=t0)
        np.testing.assert_allclose(law.ppoly(t0, 2), a0, atol=1e-10)
        np.testing.assert_allclose(law.ppoly(t0 + T, 2), af, atol=1e-10)
    np.testing.assert_allclose(law.position(t0), q0, atol=1e-12)
    np.testing.assert_allclose(law.position(t0 + T), qf, atol=1e-12)
    np.testing.assert_allclose(law.ppoly(t0, 1), v0, atol=1e-12)
    np.testing.assert_allclose(law.ppoly(t0 + T, 1), vf, atol=1e-12)
    assert (law.t0, law.tf, law.duration) == (1.0, 3.5, 2.5)


def test_coefficients_reproduce_the_law(rng):
    law = quintic_law(rng.normal(size=3), rng.normal(size=3), 3.0, v0=0.2, af=-0.1, t0=0.5)
    a = law.coefficients[0]  # (6, 3)
    t = np.linspace(0.5, 3.5, 17)
    tau = (t - 0.5)[:, None]
    poly = sum(a[j] * tau**j for j in range(6))
    np.testing.assert_allclose(poly, law.position(t), atol=1e-12)


def test_quintic_rest_to_rest_is_10_15_6():
    law = quintic_law(0.0, 1.0, 1.0)
    np.testing.assert_allclose(law.coefficients[0], [0, 0, 0, 10, -15, 6], atol=1e-12)
    assert float(law.acceleration(0.0)) == pytest.approx(0.0, abs=1e-12)
    assert float(law.velocity(0.5)) == pytest.approx(15 / 8)


def test_shapes_scalar_vector_batched():
    s = cubic_law(0.0, 1.0, 1.0)
    assert s.shape == () and np.ndim(s.position(0.3)) == 0
    assert s.position(np.linspace(0, 1, 7)).shape == (7,)
    b = cubic_law(np.zeros((2, 3)), np.ones((2, 3)), 1.0)
    assert b.shape == (2, 3)
    assert b.velocity(np.zeros(5)).shape == (5, 2, 3)
    assert quintic_law(np.zeros((2, 3)), np.ones(3), 1.0).shape == (2, 3)  # broadcast


def test_holds_end_values_outside_the_interval():
    law = cubic_law([0.0, 1.0], [2.0, -1.0], 2.0, v0=[1.0, 0.0])
    np.testing.assert_allclose(law.position([-1.0, 5.0]), [[0.0, 1.0], [2.0, -1.0]])
    np.testing.assert_allclose(law.velocity([-1.0, 5.0]), 0.0)
    np.testing.assert_allclose(law.acceleration(5.0), 0.0)


def test_lspb_default_blend_is_a_third():
    law = lspb_law([0.0, 1.0], [3.0, -2.0], 3.0)
    assert law.name is LawName.LSPB
    np.testing.assert_allclose(law.breaks, [0.0, 1.0, 2.0, 3.0])
    np.testing.assert_allclose(law.velocity(1.5), [1.5, -1.5])  # 1.5 x the mean speed
    np.testing.assert_allclose(law.position(3.0), [3.0, -2.0], atol=1e-12)
    t = np.linspace(0, 3, 301)
    v = law.velocity(t)
    assert np.max(np.abs(np.diff(v, axis=0))) < 0.05  # continuous velocity
    for b in law.breaks[1:-1]:  # position and velocity continuous at the blends
        np.testing.assert_allclose(law.ppoly(b - 1e-12), law.ppoly(b + 1e-12), atol=1e-9)
        np.testing.assert_allclose(law.ppoly(b - 1e-12, 1), law.ppoly(b + 1e-12, 1), atol=1e-9)


def test_lspb_bounds_and_errors():
    law = lspb_law(0.0, 1.0, 2.0, v_max=0.8)
    assert law.peak(1) == pytest.approx(0.8)
    law = lspb_law(0.0, 1.0, 2.0, a_max=4.0)
    assert law.peak(2) == pytest.approx(4.0)
    tri = lspb_law(0.0, 1.0, 2.0, v_max=5.0)  # cannot cruise that fast: triangular profile
    assert tri.n_segments == 2 and tri.peak(1) == pytest.approx(1.0)
    with pytest.raises(TrajectoryError, match="v_max too low.*minimum duration"):
        lspb_law(0.0, 1.0, 2.0, v_max=0.4)
    with pytest.raises(TrajectoryError, match="a_max too low"):
        lspb_law(0.0, 1.0, 2.0, a_max=0.5)
    with pytest.raises(TrajectoryError, match="at most one"):
        lspb_law(0.0, 1.0, 2.0, v_max=1.0, a_max=3.0)
    with pytest.raises(TrajectoryError, match="blend_time"):
        lspb_law(0.0, 1.0, 2.0, blend_time=1.5)


def test_make_law_names_and_errors():
    assert make_law("trapezoid", 0.0, 1.0, 3.0).name is LawName.LSPB
    assert make_law(LawName.QUINTIC, 0.0, 1.0, 3.0).degree == 5
    assert make_law("linear", 0.0, 2.0, 4.0).velocity(1.0) == pytest.approx(0.5)
    with pytest.raises(ValueError, match="'cubic', 'quintic', 'lspb', 'linear'"):
        make_law("septic", 0.0, 1.0, 1.0)
    with pytest.raises(TrajectoryError, match="positive finite duration"):
        cubic_law(0.0, 1.0, 0.0)
    with pytest.raises(ShapeError, match="one shape"):
        cubic_law([0.0, 1.0], [0.0, 1.0, 2.0], 1.0)
    with pytest.raises(ShapeError, match="finite"):
        cubic_law(np.nan, 1.0, 1.0)


def test_minimum_duration_matches_peaks():
    D, v, a = 0.8, 0.5, 2.0
    T = minimum_duration(D, v_max=v, a_max=a, law="cubic")
    law = cubic_law(0.0, D, T)
    assert max(law.peak(1) / v, law.peak(2) / a) == pytest.approx(1.0, rel=1e-6)
    T = minimum_duration(D, v_max=v, a_max=a, law="quintic")
    law = quintic_law(0.0, D, T)
    assert max(law.peak(1) / v, law.peak(2) / a) == pytest.approx(1.0, rel=1e-5)
    T = minimum_duration(D, v_max=v, a_max=a, law="lspb")
    assert T == pytest.approx(D / v + v / a)
    assert minimum_duration(0.1, v_max=1.0, a_max=1.0, law="lspb") == pytest.approx(2 * math.sqrt(0.1))
    assert minimum_duration([0.0, 0.0], v_max=1.0) == 0.0
    assert minimum_duration(1.0) == 0.0  # unbounded


def test_linear_and_repr():
    law = linear_law([0.0, 1.0], [1.0, 3.0], 2.0)
    assert isinstance(law, TimeLaw) and law.degree == 1
    np.testing.assert_allclose(law.velocity(1.0), [0.5, 1.0])
    assert "linear" in repr(law)


def test_time_grid():
    np.testing.assert_allclose(time_grid(0.0, 5.0, 0.1)[-1], 5.0)
    t = time_grid(0.0, 1.0, 0.3)
    np.testing.assert_allclose(t, [0.0, 0.3, 0.6, 0.9, 1.0])
    with pytest.raises(TrajectoryError, match="positive time step"):
        time_grid(0.0, 1.0, 0.0)
