"""Sky models: analytic luminance/colour distributions and aerial perspective.

Modules
-------
perez
    The Perez all-weather distribution function (seed 003 §5, seed 004).
preetham
    Preetham, Shirley & Smits (1999) sky: Yxy, XYZ, linear RGB and spectral radiance.
cie
    CIE overcast and CIE clear-sky luminance distributions (seed 004).
aerial
    Hoffman–Preetham extinction, in-scattering, sunlight and two-shell sky (seed 000).

The public names are re-exported flat from :mod:`atmoscatter`.
"""
