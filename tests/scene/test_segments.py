"""Shadow rays given by direction and length (``RayCaster.occluded_along``, what the direct
light's pairs cast) against the closed form of a segment crossing a square, and against the
same segments given by their two ends."""

from __future__ import annotations

import numpy as np

from lumijax.scene import GlazedCaster, RayCaster

# a 2 × 2 m square in the plane z = 0, centred on the origin
SQUARE = np.array([[[-1, -1, 0], [1, -1, 0], [1, 1, 0]], [[-1, -1, 0], [1, 1, 0], [-1, 1, 0]]],
                  float)


def _segments(n: int = 4000, seed: int = 5):
    rng = np.random.default_rng(seed)
    o = np.column_stack([rng.uniform(-2, 2, (n, 2)), rng.uniform(-1.5, -0.2, n)])
    t = np.column_stack([rng.uniform(-2, 2, (n, 2)), rng.uniform(0.2, 1.5, n)])
    return o, t


def _along(o, t):
    d = t - o
    length = np.linalg.norm(d, axis=1)
    return d / length[:, None], length


def test_a_segment_is_blocked_where_it_crosses_the_square():
    o, t = _segments()
    caster = RayCaster(SQUARE + [500.0, -300.0, 10.0])  # away from the origin: re-centred
    shift = np.array([500.0, -300.0, 10.0])
    d, length = _along(o, t)
    got = caster.occluded_along(o + shift, d, length)
    s = -o[:, 2] / (t[:, 2] - o[:, 2])  # where the segment meets z = 0
    x, y = (o[:, :2] + s[:, None] * (t[:, :2] - o[:, :2])).T
    inside = (np.abs(x) < 1) & (np.abs(y) < 1)
    edge = np.minimum(np.abs(np.abs(x) - 1), np.abs(np.abs(y) - 1)) < 1e-5  # float32 there
    assert np.array_equal(got[~edge], inside[~edge])
    assert 0.3 < inside.mean() < 0.7  # both kinds of segment are tested


def test_ends_and_direction_with_length_are_the_same_segment():
    o, t = _segments()
    d, length = _along(o, t)
    caster = RayCaster(SQUARE)
    assert np.array_equal(caster.occluded_along(o, d, length), caster.occluded(o, t))
    np.testing.assert_array_equal(caster.transmission_along(o, d, length),
                                  caster.transmission(o, t))
    # a segment shorter than twice the nudge is never blocked, as from its ends
    assert not caster.occluded_along(np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]),
                                     np.array([0.0]))[0]
    assert caster.occluded_along(np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)).shape == (0,)


def test_a_glazed_caster_passes_its_panes_along_a_direction_too():
    o, t = _segments(500)
    d, length = _along(o, t)
    # the square is a pane of τ 0.8; a second, opaque square at z = 0.1 covers x > 0.5
    opaque = SQUARE * [0.25, 1, 1] + [0.75, 0, 0.1]
    caster = GlazedCaster(np.concatenate([SQUARE, opaque]), [0.8, 0.8, 0.0, 0.0])
    np.testing.assert_allclose(caster.transmission_along(o, d, length),
                               caster.transmission(o, t), rtol=1e-12)
    got = caster.transmission_along(o, d, length)
    assert np.any(got == 0) and np.any((got > 0) & (got < 1)) and np.any(got == 1)
    assert np.array_equal(caster.occluded_along(o, d, length), caster.occluded(o, t))
