"""The CCT's Planckian table is read from lumijax/data, not computed in every run (0.2-0.3 s of
a small study's run), and what is shipped is the formula's table
(``scripts/make_planckian_table.py`` writes it)."""

from __future__ import annotations

import numpy as np
import pytest

from lumijax.spectral import _cie


def test_shipped_table_is_the_formula():
    shipped, formula = _cie._planckian_table(), _cie.planckian_locus()
    assert shipped.shape == formula.shape and shipped.shape[1] == 3
    np.testing.assert_array_equal(shipped[:, 0], formula[:, 0])  # the temperature cascade
    np.testing.assert_allclose(shipped[:, 1:], formula[:, 1:], rtol=1e-14, atol=0)
    assert not shipped.flags.writeable


def test_cct_does_not_evaluate_planck_s_law(monkeypatch):
    # the formula's only expm1 is Planck's law: a CCT computed with it broken reads the table
    _cie._planckian_table.cache_clear()

    def refuse(*_a, **_k):
        raise AssertionError("Planck's law evaluated on the CCT's path")

    monkeypatch.setattr(np, "expm1", refuse)
    try:
        # CIE illuminant A's chromaticity: 2856 K (CIE 15:2004, table T.1: x 0.44757, y 0.40745)
        uv = _cie.xy_to_uv(np.array([0.44757, 0.40745]))
        assert float(_cie.uv_to_cct_ohno2013(uv)) == pytest.approx(2856.0, abs=3.0)
    finally:
        _cie._planckian_table.cache_clear()


def test_the_nearest_row_is_the_argmin_over_every_row():
    """Ohno's search compares only the run of rows within reach of the nearest of every 16th
    (cie._nearest_row): the same row as the argmin over all 6,849, first of equals included,
    for points on the rows themselves, near the locus and anywhere in the uv plane."""
    table = _cie._planckian_table()
    rng = np.random.default_rng(7)
    k = rng.integers(0, len(table), 3000)
    pts = np.vstack([table[k, 1:], table[k, 1:] + rng.normal(0, 0.01, (3000, 2)),
                     table[k, 1:] + rng.normal(0, 0.1, (3000, 2)),
                     rng.uniform([0.0, 0.0], [0.7, 0.6], (3000, 2))])
    every = np.argmin((table[None, :, 1] - pts[:, None, 0]) ** 2
                      + (table[None, :, 2] - pts[:, None, 1]) ** 2, axis=1)
    np.testing.assert_array_equal(_cie._nearest_row(table, pts), every)
