"""``linalg.cross_along``: the cross product along any axis of broadcast stacks of 3-vectors."""

import numpy as np
import pytest

from torqueopt.linalg import cross_along


@pytest.mark.parametrize("axis", [0, 1, 2])
def test_cross_along_equals_numpy_cross_on_any_axis(axis):
    rng = np.random.default_rng(3)
    shape = [4, 5, 6]
    shape[axis] = 3
    a, b = rng.normal(size=shape), rng.normal(size=shape)
    expected = np.moveaxis(np.cross(np.moveaxis(a, axis, -1), np.moveaxis(b, axis, -1)), -1, axis)
    np.testing.assert_allclose(cross_along(a, b, axis), expected, rtol=0, atol=1e-14)


def test_cross_along_broadcasts_and_is_antisymmetric():
    rng = np.random.default_rng(4)
    stack, vector = rng.normal(size=(7, 3, 5)), rng.normal(size=(7, 3, 1))
    product = cross_along(stack, vector, 1)
    assert product.shape == (7, 3, 5)
    np.testing.assert_array_equal(product, -cross_along(vector, stack, 1))
    np.testing.assert_allclose(np.einsum("bik,bik->bk", product, stack), 0.0, atol=1e-14)
