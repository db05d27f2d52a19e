"""Tests for atmoscatter.colour: CIE XYZ integration and RGB conversion."""

from __future__ import annotations

import colour
import numpy as np
import pytest

import atmoscatter as ac

WL1 = np.arange(360.0, 831.0)  # the CIE 1931 table's own 1 nm grid


def test_equal_energy_spectrum_is_illuminant_E():
    # CIE illuminant E (equal energy) has x = y = 1/3 by construction of the CMFs
    XYZ = ac.spectral_to_XYZ(np.ones_like(WL1), WL1)
    xyY = ac.XYZ_to_xyY(XYZ)
    assert xyY[0] == pytest.approx(1 / 3, abs=1e-4)
    assert xyY[1] == pytest.approx(1 / 3, abs=1e-4)
    # photometric scale: Y = 683 lm/W · ∫ȳ dλ, ∫ȳ = 106.857 nm (CIE 1931, 1 nm, 360–830)
    assert XYZ[1] == pytest.approx(683.0 * 106.857, rel=1e-4)


def test_D65_chromaticity():
    # CIE D65 (colour-science SDS_ILLUMINANTS, 5 nm table): xy = (0.3127, 0.3290), CIE 15
    sd = colour.SDS_ILLUMINANTS["D65"]
    xyY = ac.XYZ_to_xyY(ac.spectral_to_XYZ(sd.values, sd.wavelengths))
    assert xyY[0] == pytest.approx(0.3127, abs=1e-4)
    assert xyY[1] == pytest.approx(0.3290, abs=1e-4)


def test_absolute_XYZ_agrees_with_colour_science():
    # colour.sd_to_XYZ(method='Integration', k=683) on the same 1 nm grid
    sd = colour.SDS_ILLUMINANTS["D65"].copy().align(colour.SpectralShape(360, 830, 1))
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    ref = colour.sd_to_XYZ(sd, cmfs=cmfs, method="Integration", k=683.0)
    np.testing.assert_allclose(ac.spectral_to_XYZ(sd.values, sd.wavelengths), ref, rtol=1e-5)


def test_spectral_to_XYZ_shapes_dtype_linearity():
    wl = np.linspace(380.0, 780.0, 81)
    v = np.random.default_rng(1).random((2, 3, 81))
    out = ac.spectral_to_XYZ(v, wl)
    assert out.shape == (2, 3, 3)
    np.testing.assert_allclose(ac.spectral_to_XYZ(2.0 * v, wl), 2.0 * out, rtol=1e-14)
    out32 = ac.spectral_to_XYZ(v.astype(np.float32), wl)
    assert out32.dtype == np.float32
    np.testing.assert_allclose(out32, out, rtol=1e-5)
    W = ac.cmf_weights(wl)
    assert W.shape == (81, 3)
    np.testing.assert_allclose(out, 683.0 * v @ W, rtol=1e-14)
    # NaN in one spectrum stays in that spectrum
    v2 = v.copy()
    v2[0, 0, 5] = np.nan
    o2 = ac.spectral_to_XYZ(v2, wl)
    assert np.all(np.isnan(o2[0, 0])) and np.all(np.isfinite(o2[1]))


def test_cmfs_zero_outside_table():
    W = ac.cmf_weights([100.0, 200.0, 900.0, 1000.0])
    assert np.all(W == 0.0)


@pytest.mark.parametrize("bad", [[550.0], [550.0, 500.0], [500.0, 500.0], [-1.0, 500.0], [np.nan, 500.0]])
def test_cmf_weights_bad_wavelengths(bad):
    with pytest.raises(ValueError, match="wavelengths"):
        ac.cmf_weights(bad)


def test_spectral_to_XYZ_length_mismatch():
    with pytest.raises(ValueError, match="wavelengths"):
        ac.spectral_to_XYZ(np.ones(5), np.linspace(400.0, 700.0, 6))


def test_xyY_round_trip_and_black():
    XYZ = np.array([[0.3, 0.5, 0.2], [95.047, 100.0, 108.883], [1e-3, 2e-3, 3e-3]])
    np.testing.assert_allclose(ac.xyY_to_XYZ(ac.XYZ_to_xyY(XYZ)), XYZ, rtol=1e-14)
    assert np.all(ac.xyY_to_XYZ([0.3, 0.0, 0.0]) == 0.0)
    np.testing.assert_array_equal(ac.XYZ_to_xyY([0.0, 0.0, 0.0]), [0.3127, 0.3290, 0.0])
    # against colour-science
    np.testing.assert_allclose(ac.XYZ_to_xyY(XYZ), colour.XYZ_to_xyY(XYZ), rtol=1e-14)


def test_linear_rgb_round_trip_and_white():
    XYZ = np.random.default_rng(2).random((4, 5, 3))
    for cs in ("sRGB", "ITU-R BT.2020", "ACEScg"):
        rgb = ac.XYZ_to_linear_rgb(XYZ, cs)
        assert rgb.shape == (4, 5, 3)
        np.testing.assert_allclose(ac.linear_rgb_to_XYZ(rgb, cs), XYZ, rtol=1e-10, atol=1e-14)
    # sRGB: the D65 white (Y = 1) is R = G = B = 1, and Y = 0.2126 R + 0.7152 G + 0.0722 B
    # (IEC 61966-2-1 / ITU-R BT.709)
    # (the IEC matrix's white is xy = (0.31272, 0.32900), i.e. D65 to its 4 printed
    # decimals: R = G = B = 1 to 2e-4)
    white = ac.xyY_to_XYZ([0.3127, 0.3290, 1.0])
    np.testing.assert_allclose(ac.XYZ_to_linear_rgb(white), [1.0, 1.0, 1.0], atol=2e-4)
    # the published sRGB XYZ→RGB matrix (as carried by colour-science) maps the D65 white
    # [0.9505, 1, 1.089] to 1 within its 4-decimal rounding
    np.testing.assert_allclose(ac.XYZ_to_linear_rgb([0.9505, 1.0, 1.089]), [1.0, 1.0, 1.0], atol=1e-4)
    # XYZ → RGB is exactly colour-science's conversion (no chromatic adaptation)
    for cs in ("sRGB", "ITU-R BT.2020", "ACEScg"):
        np.testing.assert_allclose(
            ac.XYZ_to_linear_rgb(XYZ, cs),
            colour.XYZ_to_RGB(XYZ, cs, illuminant=None, apply_cctf_encoding=False),
            rtol=1e-12,
            atol=1e-15,
        )
    Y = ac.linear_rgb_to_XYZ(np.eye(3))[:, 1]
    np.testing.assert_allclose(Y, [0.2126, 0.7152, 0.0722], atol=1e-4)


def test_XYZ_to_linear_rgb_matches_colour_science():
    # colour.XYZ_to_RGB without chromatic adaptation or transfer function
    XYZ = np.random.default_rng(4).random((20, 3))
    for cs in ("sRGB", "ACEScg", "ITU-R BT.2020", "Display P3"):
        ref = colour.XYZ_to_RGB(XYZ, cs, illuminant=None, apply_cctf_encoding=False)
        np.testing.assert_allclose(ac.XYZ_to_linear_rgb(XYZ, cs), ref, rtol=1e-12, atol=1e-15)
        # and the reverse agrees with colour.RGB_to_XYZ to the precision of its matrices
        ref_back = colour.RGB_to_XYZ(ref, cs, illuminant=None, apply_cctf_decoding=False)
        np.testing.assert_allclose(ac.linear_rgb_to_XYZ(ref, cs), ref_back, rtol=0, atol=1e-4)


def test_linear_rgb_float32_preserved():
    XYZ = np.random.default_rng(3).random((10, 3)).astype(np.float32)
    rgb = ac.XYZ_to_linear_rgb(XYZ)
    assert rgb.dtype == np.float32
    assert ac.linear_rgb_to_XYZ(rgb).dtype == np.float32
    np.testing.assert_allclose(ac.linear_rgb_to_XYZ(rgb), XYZ, rtol=1e-4, atol=1e-6)


def test_unknown_colourspace_lists_options():
    with pytest.raises(ValueError, match=r"colourspace='not-a-space'.*'sRGB'"):
        ac.XYZ_to_linear_rgb([0.5, 0.5, 0.5], "not-a-space")
    with pytest.raises(ValueError, match="colourspace"):
        ac.linear_rgb_to_XYZ([0.5, 0.5, 0.5], "not-a-space")
    names = ac.colourspace_names()
    assert "sRGB" in names and names == sorted(names)


def test_non_numeric_is_type_error():
    with pytest.raises(TypeError, match="XYZ"):
        ac.XYZ_to_linear_rgb("white")


# --- the shipped CMF table (data/cie1931_2deg_cmf.csv) -------------------------------------
def test_cmf_table_matches_colour_science():
    """The shipped CIE 1931 2° CMFs are colour-science's (scripts/make_cmf_table.py writes
    them with repr: an exact decimal round trip, so rtol 1e-15 only allows for parsing)."""
    colour = pytest.importorskip("colour")
    from atmoscatter.colour import _cmfs

    wl, v = _cmfs()
    ref = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    np.testing.assert_array_equal(wl, np.asarray(ref.wavelengths, dtype=float))
    np.testing.assert_allclose(v, np.asarray(ref.values, dtype=float), rtol=1e-15, atol=0)
    assert wl[0] == 360.0 and wl[-1] == 830.0 and np.all(np.diff(wl) == 1.0)


# --- the shipped colourspace table (data/colourspaces.json) ------------------------------
def test_colourspace_table_matches_colour_science():
    """The table is written from colour-science (scripts/make_colourspace_table.py); here it
    must agree with the installed one.  Tolerance: the matrices of some colourspaces are
    computed by colour-science at import (normalised primary matrix: a 3×3 solve, condition
    number < 1e3), so a different CPU/BLAS may change them by a few ulp: rtol 1e-12 covers
    that with margin and is still far below any colour difference (1e-6)."""
    colour = pytest.importorskip("colour")
    from atmoscatter.colour import _colourspace_table

    table = _colourspace_table()
    cs = colour.RGB_COLOURSPACES
    if colour.__version__ == table["colour_science_version"]:
        assert list(cs.keys()) == list(table["colourspaces"])
        assert dict(zip(cs.lower_keys(), cs.keys(), strict=True)) == table["lower"]
        assert dict(zip(cs.slugified_keys(), cs.keys(), strict=True)) == table["slugified"]
        assert dict(zip(cs.canonical_keys(), cs.keys(), strict=True)) == table["canonical"]
    for name, entry in table["colourspaces"].items():
        if name not in cs:  # pragma: no cover - a colour-science that dropped a colourspace
            continue
        c = cs[name]
        for key, ref in (("matrix_XYZ_to_RGB", c.matrix_XYZ_to_RGB),
                         ("primaries", c.primaries), ("whitepoint", c.whitepoint)):
            np.testing.assert_allclose(entry[key], np.asarray(ref, dtype=float), rtol=1e-12,
                                       atol=1e-15, err_msg=f"{name} {key}")


def test_colourspace_names_are_resolved_as_colour_science_does():
    colour = pytest.importorskip("colour")
    from atmoscatter.colour import _resolve_colourspace

    cs = colour.RGB_COLOURSPACES
    probes = list(cs.keys()) + list(cs.lower_keys()) + list(cs.slugified_keys())
    probes += list(cs.canonical_keys()) + [n.upper() for n in cs.keys()]
    probes += ["sRGBB", "", "itu-r-bt-2020", "aces cg", "rec709", "not-a-space"]
    for name in probes:
        got = _resolve_colourspace(name)
        assert (got is not None) == (name in cs), name
        if got is not None:
            assert cs[got] is cs[name], name
    assert _resolve_colourspace(3) is None


def test_aliases_render_like_the_canonical_name():
    xyz = np.array([[0.3, 0.4, 0.5], [10.0, 20.0, 5.0]])
    # the same matrix through the same code: equal to rounding
    np.testing.assert_allclose(ac.XYZ_to_linear_rgb(xyz, "srgb"), ac.XYZ_to_linear_rgb(xyz),
                               rtol=1e-15)
    assert ac.Scene(colourspace="iturbt2020").colourspace == "iturbt2020"
    with pytest.raises(ValueError, match=r"colourspace='sRGBB' is not valid"):
        ac.Scene(colourspace="sRGBB")


@pytest.mark.parametrize("fn, name", [(ac.xyY_to_XYZ, "xyY"), (ac.XYZ_to_xyY, "XYZ"),
                                      (ac.XYZ_to_linear_rgb, "XYZ"),
                                      (ac.linear_rgb_to_XYZ, "rgb")])
@pytest.mark.parametrize("shape", [(2,), (4, 2), (5,), ()])
def test_colour_conversions_need_three_channels(fn, name, shape):
    """A last axis of length ≠ 3 is a one-line ValueError naming the argument and its
    shape (before: IndexError, numpy's matmul message, or silently the first three)."""
    with pytest.raises(ValueError, match=rf"{name} must have shape \(\.\.\., 3\)"):
        fn(np.ones(shape))
