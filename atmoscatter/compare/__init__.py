r"""Use atmoscatter as a reference oracle: compare another renderer's sky map with ours.

Public objects
--------------
- :func:`compare_images`: compare two images already in the same layout (arrays) —
  luminance relative error without rescaling, best-fit scale factor, ΔE 2000 after exposure
  normalisation, error maps.  Returns a :class:`Comparison`.
- :class:`Comparison`: the result; :meth:`Comparison.to_dict` (JSON-ready summary) and
  :meth:`Comparison.write` (``summary.json``, ``error_map.png``, ``delta_e_map.png``).
- :func:`read_sky_map`: read another renderer's EXR (lat-long, cube map, fisheye or a
  direction set) into CIE XYZ in our layout, applying the rotate/flip/colourspace options.
- :func:`compare_exr`: read an EXR, render our reference for a scene at the same directions
  and compare (the Python equivalent of ``atmoscatter compare``).
- :func:`add_compare_parser`, :func:`run_compare`: the ``compare`` subcommand.
- :data:`SCALE_METHODS`: registry of best-fit scale estimators.

Assumed layout and frame
------------------------
Our sky maps use OpenEXR's environment-map conventions with the OpenEXR environment frame
(x = west, y = up, z = north) tied to our local frame (x = east, y = north, z = up):

- **lat-long** (``envmap = latlong``, width = 2 × height): row 0 at the zenith, the last row
  at the nadir, rows uniform in elevation; column ``c`` looks at geographic azimuth (from
  north toward east) ``2π (c + ½)/width − π`` — south at both edges, north in the centre
  column, east at three quarters of the width.
- **cube map** (``envmap = cube``, height = 6 × width): six faces stacked vertically in the
  order +X, −X, +Y, −Y, +Z, −Z of the OpenEXR frame (west, east, up, down, north, south),
  with OpenEXR's face orientations.
- **fisheye** (square): angular (equidistant) projection of the upper hemisphere, zenith at
  the centre, north up, east to the left (as seen looking up).
- **directions**: any direction set (a sky-dome mesh, your own sample points): the file
  carries the unit direction of every pixel in channels ``dir.X``, ``dir.Y``, ``dir.Z`` in the
  local frame (x = east, y = north, z = up), as ``atmoscatter render`` writes dome meshes.
  Our reference is rendered at exactly those directions; statistics are weighted per pixel.

Another renderer's map in a different convention is brought into ours with ``flip``
(applied first) and ``rotate_deg``: the pixel the file stores at azimuth *a* is compared
with our sky at azimuth *a* + ``rotate_deg``.  Lat-long maps are shifted column-wise (linear
interpolation for fractional shifts); for cube maps, fisheyes and direction sets the pixels'
directions are transformed and our reference is rendered exactly there.
``flip="horizontal"`` mirrors azimuth (a map whose azimuth runs west-ward),
``flip="vertical"`` swaps zenith and nadir (top and bottom rows of a lat-long map).
RGB files are read as **linear** RGB in ``colourspace`` (any colour-science name, default
sRGB / Rec. 709 primaries); files that carry ``XYZ.X/Y/Z`` or a single ``Y`` channel are
used as such; spectral files (layers ``S0.<λ>nm`` of spectral radiance in
W m⁻² sr⁻¹ nm⁻¹, the Fichet et al. 2021 convention the renderer writes) are integrated to XYZ
with the CIE 1931 2° colour-matching functions.  Priority: XYZ, RGB, spectral, Y.

What is compared
----------------
- ``luminance_relative_error``: ``|Y_other − Y_ours| / Y_ours`` per pixel, **without**
  rescaling, summarised by its median, 95th percentile and maximum.  Percentiles are
  weighted by pixel solid angle when it is known (a fraction of the sky, not of the
  pixels), inverted-CDF definition (no interpolation).
- ``scale``: the best-fit factor *s* with ``s · Y_other ≈ Y_ours`` — for renderers in
  arbitrary units.  Default estimator ``median_log``: ``s = exp(weighted median of
  ln(Y_ours/Y_other))``, robust to local defects; ``least_squares`` minimises the weighted
  relative squared error ``Σ w (s Y_other/Y_ours − 1)²``.
- ``scaled_luminance_relative_error``: the same statistics after multiplying by *s*.
- ``delta_e_2000``: CIEDE2000 colour difference (colour-science) after exposure
  normalisation: the other image is multiplied by *s*, both are divided by
  ``Y_w = median(Y_ours)/0.18`` (so our median sky luminance sits at middle grey, L* ≈ 50)
  and converted to CIELAB with the D65 white.  Pixels where our luminance is not positive,
  pixels that are not finite in either image, pixels outside the chosen region (default:
  the sky above the horizon) and a small cone around the sun (default 1°) are excluded.

Modules
-------
read
    Step 1: read another renderer's EXR into CIE XYZ and bring it to our layout
    (:func:`read_sky_map`, :class:`SkyMap`).
stats
    Step 2: the statistics of two images in the same layout (:func:`compare_images`,
    :class:`Comparison`, :func:`weighted_quantile`, :data:`SCALE_METHODS`).
report
    Step 3: the report files (PNG error maps, JSON encoding) that :meth:`Comparison.write`
    writes.
reference
    The steps chained against our reference render of a scene (:func:`compare_exr`).
cli
    The ``compare`` subcommand (:func:`add_compare_parser`, :func:`run_compare`).

The public names are re-exported here and flat from :mod:`atmoscatter`.
"""

# LAYOUTS, FLIPS, REGIONS, MIDDLE_GREY and the map ranges are not in __all__ but stay
# importable from atmoscatter.compare, as before the split (hence the noqa).
from .cli import add_compare_parser, run_compare
from .read import FLIPS, LAYOUTS, SkyMap, read_sky_map  # noqa: F401
from .reference import REGIONS, compare_exr  # noqa: F401
from .report import DELTA_E_MAP_RANGE, ERROR_MAP_RANGE  # noqa: F401
from .stats import (  # noqa: F401
    MIDDLE_GREY,
    SCALE_METHODS,
    Comparison,
    compare_images,
    weighted_quantile,
)

__all__ = [
    "SCALE_METHODS",
    "Comparison",
    "compare_images",
    "weighted_quantile",
    "SkyMap",
    "read_sky_map",
    "compare_exr",
    "add_compare_parser",
    "run_compare",
]
