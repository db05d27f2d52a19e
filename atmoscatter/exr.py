"""OpenEXR sky maps: atomic writes with provenance, and reading them back.

Public objects
--------------
:func:`write_exr`
    Write a :class:`~atmoscatter.render.SkyImage` (half or float; RGB(A), XYZ,
    luminance and spectral layers; ``envmap`` and ``chromaticities`` header
    attributes; the scene, plan, model, package version and error estimate as
    string attributes).  The write is atomic.
:func:`read_exr`, :class:`ExrImage`
    Read a sky map (any EXR) back: channels, header, and the scene it records.
:func:`is_complete_exr`
    Whether a file is a complete, readable EXR (batch resume uses it).
:func:`atomic_write`
    Context manager giving a temporary path that replaces the target only on success.

Channel layout
--------------
* ``R``, ``G``, ``B`` (+ ``A``): linear RGB in the scene's colourspace [cd m⁻²];
  alpha is 1 for evaluated sky and 0 for ground fill / outside a fisheye circle.
* ``XYZ.X``, ``XYZ.Y``, ``XYZ.Z``: CIE XYZ [cd m⁻²] (``output = "xyz"``).
* ``Y``: luminance only [cd m⁻²] (``output = "luminance"``; OpenEXR's
  luminance-image convention).
* ``S0.<λ>nm`` (λ written with a decimal comma, e.g. ``S0.550,000000nm``):
  spectral radiance [W m⁻² sr⁻¹ nm⁻¹], the layout of Fichet, Pacanowski &
  Wilkie (2021), "An OpenEXR layout for spectral images", JCGT 10(3).
* ``dir.X``, ``dir.Y``, ``dir.Z`` (float, dome only): vertex directions in the
  local frame (x = east, y = north, z = up); a dome is stored as a 1-row
  image with one pixel per vertex.

Lat-long and cube maps carry the standard ``envmap`` attribute; their pixel
orientation is OpenEXR's with the environment frame x = west, y = up,
z = north (see :mod:`atmoscatter.render.directions`).
"""

from __future__ import annotations

import contextlib
import json
import os
import tempfile

import numpy as np

from ._atomic import atomic_write

__all__ = ["write_exr", "read_exr", "ExrImage", "is_complete_exr", "atomic_write",
           "spectral_channel_name"]


def spectral_channel_name(wavelength: float) -> str:
    """EXR channel name of spectral radiance at ``wavelength`` [nm] (Fichet et al. 2021).

    Parameters
    ----------
    wavelength : float
        Wavelength [nm], a scalar (anything ``float()`` accepts).

    Returns
    -------
    str
        ``"S0.<λ>nm"`` with λ written to 6 decimals and a decimal comma, e.g.
        ``"S0.550,000000nm"`` for 550 nm.

    Raises
    ------
    ValueError, TypeError
        If ``wavelength`` cannot be converted to a float (raised by ``float()``).
    """
    return "S0." + f"{float(wavelength):.6f}".replace(".", ",") + "nm"


def _chromaticities(colourspace: str):
    from .colour import _colourspace_data  # noqa: PLC0415  (shipped table: no colour-science)

    cs = _colourspace_data(colourspace)
    p, w = cs["primaries"], cs["whitepoint"]
    return (p[0, 0], p[0, 1], p[1, 0], p[1, 1], p[2, 0], p[2, 1], w[0], w[1])


def write_exr(path, image, *, precision: str | None = None, compression: str = "zip") -> str:
    """Write ``image`` (a :class:`~atmoscatter.render.SkyImage`) to ``path`` atomically.

    Parameters
    ----------
    path : str or path-like
        Output file (directories are created).
    image : SkyImage
        The rendered sky.
    precision : {"half", "float"}, optional
        Pixel type of the radiance channels (default: ``image.scene.precision``).
        Half floats hold up to 65504: brighter values (the sun disc) saturate.
    compression : {"zip", "piz", "none"}
        OpenEXR compression.

    Returns
    -------
    str
        The path written.
    """
    import OpenEXR  # noqa: PLC0415

    prec = image.scene.precision if precision is None else precision
    if prec not in ("half", "float"):
        raise ValueError(f"precision={prec!r} is not valid; choose one of ['float', 'half']")
    comp = {"zip": OpenEXR.ZIP_COMPRESSION, "piz": OpenEXR.PIZ_COMPRESSION,
            "none": OpenEXR.NO_COMPRESSION}
    if compression not in comp:
        raise ValueError(f"compression={compression!r} is not valid; choose one of {sorted(comp)}")
    dtype = np.float16 if prec == "half" else np.float32

    dome = len(image.shape) == 1  # a mesh / direction list: one row, one pixel each
    if len(image.shape) > 2:
        raise ValueError(f"cannot write layers of shape {image.shape} as an image")

    def as_image(a):
        a = np.asarray(a)
        if dome:  # one row, one pixel per vertex
            a = a.reshape((1,) + a.shape)
        return np.ascontiguousarray(a)

    def conv(a):
        # A plane of the image (C-contiguous float32: SkyImage stores its layers planar) is
        # handed to OpenEXR as it is, without a copy; half floats are converted straight into
        # a float16 plane (no float32 temporary of the map's size).
        if dtype is np.float32:
            return as_image(np.asarray(a, dtype=np.float32))
        out = np.empty(np.shape(a), dtype=np.float16)
        np.minimum(a, np.float32(65504.0), out=out, casting="same_kind",
                   signature=(np.float32, np.float32, np.float32))
        return as_image(out)

    channels = {}
    if image.rgb is not None:
        for c, plane in zip("RGB", image.planes("rgb"), strict=True):
            channels[c] = conv(plane)
        if image.scene.alpha:
            channels["A"] = as_image(image._alpha_as(dtype))
    if image.xyz is not None:
        for c, plane in zip("XYZ", image.planes("xyz"), strict=True):
            channels[f"XYZ.{c}"] = conv(plane)
    if image.luminance_only is not None:
        channels["Y"] = conv(image.luminance_only)
        if image.scene.alpha:
            channels["A"] = as_image(image._alpha_as(dtype))
    if image.spectral is not None:
        for wl, plane in zip(image.wavelengths, image.planes("spectral"), strict=True):
            channels[spectral_channel_name(wl)] = conv(plane)
    if dome:
        d = image.directions.reshape(-1, 3)
        for i, c in enumerate("XYZ"):
            channels[f"dir.{c}"] = as_image(d[:, i].astype(np.float32))

    header = {
        "compression": comp[compression],
        "type": OpenEXR.scanlineimage,
    }
    if image.projection == "latlong":
        header["envmap"] = OpenEXR.ENVMAP_LATLONG
    elif image.projection == "cubemap":
        header["envmap"] = OpenEXR.ENVMAP_CUBE
    if image.rgb is not None:
        header["chromaticities"] = tuple(float(v) for v in _chromaticities(image.scene.colourspace))
        header["whiteLuminance"] = 1.0  # RGB (1, 1, 1) has a luminance of 1 cd m^-2
    for k, v in image.metadata.items():
        header[str(k)] = str(v)

    path = os.fspath(path)
    if os.path.isdir(path):
        raise ValueError(f"output {path!r} is a directory; give a file name such as sky.exr")
    with atomic_write(path) as tmp:
        with OpenEXR.File(header, channels) as f:
            f.write(tmp)
    return path


class ExrImage:
    """An EXR file read back: ``channels`` (name → array) and ``header`` (name → value).

    Returned by :func:`read_exr`.  The properties give the layers written by
    :func:`write_exr` (:attr:`rgb`, :attr:`xyz`, :attr:`alpha`, :attr:`luminance`,
    :attr:`spectral`), the string attributes (:attr:`metadata`), the render plan
    (:attr:`plan`) and the scene (:meth:`scene`); see the module notes for the channel
    layout and units.

    Parameters
    ----------
    channels : dict of str to ndarray
        Channel name → pixels, shape (height, width) (a dome: (1, n_vertices)).
    header : dict of str to object
        Header attribute name → value, as the OpenEXR bindings return them.

    Attributes
    ----------
    channels : dict of str to ndarray
        Channel name → pixels, shape (height, width), in the file's pixel type
        (float16 for half, float32 for float, uint32 for uint).  Grouped ``RGB``/``RGBA``
        channels are split into ``R``, ``G``, ``B`` (, ``A``).
    header : dict of str to object
        Every header attribute: the standard ones (``dataWindow``, ``compression``,
        ``chromaticities``, ...) with the OpenEXR bindings' types, and atmoscatter's
        provenance as ``str``.
    """

    def __init__(self, channels: dict, header: dict):
        self.channels = channels
        self.header = header

    @property
    def metadata(self) -> dict[str, str]:
        """The string attributes of the header."""
        return {k: v for k, v in self.header.items() if isinstance(v, str)}

    def _stack(self, names):
        if all(n in self.channels for n in names):
            return np.stack([self.channels[n] for n in names], axis=-1)
        return None

    @property
    def rgb(self):
        """``(..., 3)`` RGB, or None."""
        return self._stack(["R", "G", "B"])

    @property
    def xyz(self):
        """``(..., 3)`` XYZ, or None."""
        return self._stack(["XYZ.X", "XYZ.Y", "XYZ.Z"])

    @property
    def alpha(self):
        """The ``A`` channel (1 evaluated sky, 0 ground fill / outside the map), or None."""
        return self.channels.get("A")

    @property
    def luminance(self):
        """The luminance-only ``Y`` channel [cd m⁻²], or None."""
        return self.channels.get("Y")

    @property
    def spectral(self):
        """``(wavelengths [nm], radiance (..., n))`` or None."""
        names = [n for n in self.channels if n.startswith("S0.") and n.endswith("nm")]
        if not names:
            return None
        wl = np.array([float(n[3:-2].replace(",", ".")) for n in names])
        order = np.argsort(wl)
        return wl[order], np.stack([self.channels[names[i]] for i in order], axis=-1)

    @property
    def plan(self) -> dict | None:
        """The render plan recorded in ``atmoscatter:plan`` (parsed JSON), or None."""
        text = self.header.get("atmoscatter:plan")
        return json.loads(text) if isinstance(text, str) else None

    def scene(self):
        """The :class:`~atmoscatter.scene.Scene` recorded in the header."""
        from .scene import Scene  # noqa: PLC0415

        data = {k: self.header[k] for k in Scene.field_names()
                if isinstance(self.header.get(k), str)}
        if not data:
            raise ValueError("this EXR file records no atmoscatter scene")
        return Scene.from_dict(data)


def read_exr(path) -> ExrImage:
    """Read an EXR file: all channels (as arrays) and the header.

    Any OpenEXR file is read, not only those written by :func:`write_exr`; OpenEXR's own
    diagnostics of a broken file are kept off the terminal.

    Parameters
    ----------
    path : str or path-like
        The EXR file.

    Returns
    -------
    ExrImage
        Every channel (grouped ``RGB``/``RGBA`` split into ``R``, ``G``, ``B``, ``A``) and
        every header attribute.

    Raises
    ------
    ValueError
        If ``path`` does not exist, is not a regular file, or is not a readable OpenEXR file
        (truncated, corrupt or another format); the message names the path.
    """
    import OpenEXR  # noqa: PLC0415

    path = os.fspath(path)
    if not os.path.isfile(path):
        raise ValueError(f"{path!r} does not exist or is not a file")
    try:
        with _c_output_captured(), OpenEXR.File(path) as f:
            header = dict(f.header())
            chans = {}
            for name, ch in f.channels().items():
                px = np.asarray(ch.pixels)
                if px.ndim == 3:  # grouped RGB/RGBA
                    parts = [name[i] for i in range(len(name))] if name in ("RGB", "RGBA") else []
                    for i, c in enumerate(parts):
                        chans[c] = px[..., i]
                    if parts:
                        continue
                chans[name] = px
    except Exception as exc:  # OpenEXR raises various types for broken files
        raise ValueError(f"{path!r} is not a readable OpenEXR file ({exc})") from None
    return ExrImage(chans, header)


@contextlib.contextmanager
def _c_output_captured():
    """Send what the OpenEXR C++ library prints to file descriptors 1 and 2 (diagnostics
    of broken files, several lines each) to a scratch file instead of the terminal; the
    error raised for the file says what is wrong in one line."""
    import sys  # noqa: PLC0415

    try:
        fds = [1, 2]
        saved = [os.dup(fd) for fd in fds]
    except OSError:  # no such descriptors (embedded interpreters)
        yield
        return
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(Exception):
            stream.flush()
    with tempfile.TemporaryFile() as sink:
        try:
            for fd in fds:
                os.dup2(sink.fileno(), fd)
            yield
        finally:
            for fd, old in zip(fds, saved, strict=True):
                os.dup2(old, fd)
                os.close(old)


def is_complete_exr(path) -> bool:
    """True if ``path`` is an EXR whose header and every pixel can be read.

    Parameters
    ----------
    path : str or path-like
        The file to check.

    Returns
    -------
    bool
        True if ``path`` is a regular file with the OpenEXR magic number that
        :func:`read_exr` reads completely and that has at least one channel; False
        otherwise (missing, truncated, corrupt, not an EXR).  Never raises: every error
        reads as False.
    """
    try:
        import OpenEXR  # noqa: PLC0415

        if not os.path.isfile(path) or not OpenEXR.isOpenExrFile(os.fspath(path)):
            return False
        img = read_exr(path)
        return bool(img.channels)
    except Exception:
        return False
