"""The spectra lumijax ships (``spectral._shipped``: Mallett 2019 sRGB basis, illuminants A, D50,
D65, FL11) against colour-science, the independent reference (imported in the tests only), and
the default study loading without colour."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from lumijax.spectral import Spectrum
from lumijax.spectral._shipped import (
    SHIPPED_EMISSION,
    mallett2019_basis,
    shipped_emission,
    srgb_decode,
)

colour = pytest.importorskip("colour")


def test_basis_is_colour_sciences():
    from colour.recovery import MSDS_BASIS_FUNCTIONS_sRGB_MALLETT2019 as ref

    wl, basis = mallett2019_basis()
    assert np.array_equal(wl, ref.wavelengths) and np.array_equal(basis, ref.values)
    assert basis.shape == (81, 3) and not basis.flags.writeable
    # the property the method rests on (Mallett & Yuksel 2019): the three spectra sum to 1
    np.testing.assert_allclose(basis.sum(axis=1), 1.0, atol=2e-5)  # published to 5 places


@pytest.mark.parametrize("display", sorted(SHIPPED_EMISSION))
def test_illuminants_are_colour_sciences(display):
    ref = colour.SDS_ILLUMINANTS[display]
    got = shipped_emission(display)
    assert got is not None
    assert np.array_equal(got[1], ref.wavelengths) and np.array_equal(got[2], ref.values)


def test_named_lookup_matches_the_colour_registry():
    # every spelling answered from the shipped file gives what the colour-science registry gives
    from lumijax.spectral._names import _lookup, _registry

    reg = _registry("emission")
    spellings = ["A", "a", "CIE A", "illuminant A", "CIE illuminant A", "D65", "d-65", "cie_d65",
                 "D50", "FL11", "F11", "fl 11", "illuminant F11"]
    for name in spellings:
        got = shipped_emission(name)
        assert got is not None, name
        display, loader, source = _lookup(reg, name)
        sd = loader()
        assert got[0] == display and got[3] == source, name
        assert np.array_equal(got[1], sd.wavelengths) and np.array_equal(got[2], sd.values), name
    # names not shipped fall through to colour-science and still work
    assert shipped_emission("LED-B3") is None and shipped_emission("D75") is None
    assert Spectrum.from_name("LED-B3").name == "LED-B3"
    assert shipped_emission("Ax") is None and shipped_emission("white") is None


def test_srgb_decode_is_colour_sciences():
    v = np.concatenate([np.linspace(0.0, 1.0, 1001), [0.0031308 * 12.92, 0.04045, 0.0404499]])
    assert np.array_equal(srgb_decode(v), colour.cctf_decoding(v, function="sRGB"))


@pytest.mark.parametrize("rgb", [(0.42, 0.40, 0.36), (0.8, 0.1, 0.05), (0.02, 0.5, 0.9),
                                 (0.0, 0.0, 0.0), (0.3, 0.3, 0.3)])
def test_from_srgb_matches_colour_mallett2019(rgb):
    from colour.recovery import RGB_to_sd_Mallett2019

    linear = colour.cctf_decoding(np.array(rgb), function="sRGB")
    ref = RGB_to_sd_Mallett2019(linear)
    got = Spectrum.from_srgb(rgb)
    assert np.array_equal(got.wavelengths_nm, ref.wavelengths)
    assert np.array_equal(got.values, np.clip(ref.values, 0.0, None))


def test_default_study_does_not_import_colour(tmp_path):
    code = textwrap.dedent("""
        import sys
        from importlib import resources
        import lumijax
        path = resources.files("lumijax") / "data" / "studies" / "default" / "study.toml"
        with resources.as_file(path) as p:
            lumijax.load_study(p)
        print("colour" in sys.modules)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         cwd=tmp_path, check=True)
    assert out.stdout.strip().splitlines()[-1] == "False"
