"""Path functions: values, gradients and Hessians against finite differences and geometry."""

import numpy as np
import pytest

from eaplan_drake.flight.paths import DESCRIPTOR_SIZE, Circle, Line, PathFunction

RNG = np.random.default_rng(7)


def _fd_gradient(path, p, h=1e-6):
    return np.array([(path.value(p + h * e) - path.value(p - h * e)) / (2 * h) for e in np.eye(2)])


@pytest.mark.parametrize(
    "path",
    [
        Circle((-45.0, 146.0), 70.0, s=-1, k_e=0.05),
        Line((-115.0, 146.0), (1.0, 0.0), s=1, k_e=0.05),
        Line((3.0, 4.0), (1.0, 2.0), s=-1, k_e=0.05),
    ],
)
def test_gradient_and_hessian_match_finite_differences(path):
    for p in RNG.uniform(-200, 200, size=(20, 2)):
        np.testing.assert_allclose(path.gradient(p), _fd_gradient(path, p), rtol=1e-6, atol=1e-6)
        fd_h = np.column_stack(
            [(path.gradient(p + 1e-4 * e) - path.gradient(p - 1e-4 * e)) / 2e-4 for e in np.eye(2)]
        )
        np.testing.assert_allclose(path.hessian(p), fd_h, atol=1e-9)


def test_circle_is_normalised_signed_distance_on_the_path():
    c = Circle((10.0, -5.0), 70.0, k_e=0.05)
    for theta in np.linspace(0, 2 * np.pi, 13):
        p = np.array([10.0, -5.0]) + 70.0 * np.array([np.cos(theta), np.sin(theta)])
        assert abs(c.value(p)) < 1e-9
        assert np.linalg.norm(c.gradient(p)) == pytest.approx(1.0, abs=1e-12)
        # 1 m outside is φ ≈ +1 m (to first order).
        assert c.value(
            p * 0 + np.array([10.0, -5.0]) + 71.0 * np.array([np.cos(theta), np.sin(theta)])
        ) == pytest.approx(1.0, abs=0.01)
    assert c.center == pytest.approx([10.0, -5.0])
    assert c.radius == pytest.approx(70.0)


def test_direction_conventions():
    # s = +1 on a circle is clockwise: at the rightmost point the tangent points to −y.
    c = Circle((0.0, 0.0), 10.0, s=1, k_e=0.05)
    t = c.tangent([10.0, 0.0])
    assert t[1] < 0 and abs(t[0]) < 1e-12
    # s = +1 on φ = x − x0 travels towards −y.
    line = Line((5.0, 0.0), (1.0, 0.0), s=1, k_e=0.05)
    assert line.tangent([5.0, 3.0])[1] == pytest.approx(-1.0)


def test_descriptor_round_trip_and_normalisation():
    c = Circle((1.0, 2.0), 30.0, s=-1, k_e=0.05)
    d = c.descriptor()
    assert d.shape == (DESCRIPTOR_SIZE,)
    assert PathFunction.FromDescriptor(d) == c
    # An un-normalised circle (the authors' form (x − 1)² + (y − 2)² − 900) normalises to ours.
    raw = PathFunction(a=1.0, b=(-2.0, -4.0), c=1.0 + 4.0 - 900.0, s=-1, k_e=0.05)
    n = raw.normalised()
    np.testing.assert_allclose(n.descriptor(), d, atol=1e-12)
    raw_line = PathFunction(a=0.0, b=(3.0, 0.0), c=-15.0, k_e=0.05)
    assert raw_line.normalised().value([5.0, 9.0]) == pytest.approx(0.0)
    assert np.linalg.norm(raw_line.normalised().gradient([0, 0])) == pytest.approx(1.0)


def test_bad_input_is_a_clear_error():
    with pytest.raises(ValueError, match="radius"):
        Circle((0, 0), -1.0, k_e=0.05)
    with pytest.raises(ValueError, match="normal"):
        Line((0, 0), (0.0, 0.0), k_e=0.05)
    with pytest.raises(ValueError, match="direction"):
        PathFunction(a=0.0, b=(1.0, 0.0), c=0.0, s=0.5, k_e=0.05)
    with pytest.raises(ValueError, match="finite"):
        PathFunction(a=np.nan, b=(1.0, 0.0), c=0.0, k_e=0.05)
    with pytest.raises(ValueError, match="entries"):
        PathFunction.FromDescriptor([1, 2, 3])
    with pytest.raises(TypeError, match="k_e"):  # no default gain: the scenario's k_e is given
        Line((0, 0), (1.0, 0.0))


@pytest.mark.parametrize(
    "coefficients, message",
    [
        (dict(a=float("nan"), b=(1.0, 0.0), c=0.0), "coefficients must be finite"),
        (dict(a=0.0, b=(1.0, float("inf")), c=0.0), "coefficients must be finite"),
        (dict(a=0.0, b=(0.0, 0.0), c=0.0), "a line needs a non-zero normal b"),
        (dict(a=0.0, b=(1.0, 0.0), c=0.0, s=0.5), r"s \(direction\) must be \+1 or -1"),
    ],
)
def test_a_path_function_refuses_bad_coefficients_in_one_line(coefficients, message):
    with pytest.raises(ValueError, match=message) as e:
        PathFunction(**coefficients, k_e=1.0)
    assert "\n" not in str(e.value)
