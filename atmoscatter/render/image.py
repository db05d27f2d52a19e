"""The rendered sky: :class:`SkyImage`, the layers of a render and their metadata.

Storage
-------
Layers are stored planar: one C-contiguous plane per channel (``rgb`` and ``xyz`` as a
``(3,) + shape`` block, ``spectral`` as ``(n_wl,) + shape``), which is what OpenEXR writes
(one channel after another), so :func:`~atmoscatter.write_exr` hands the planes over without
copying them.  The channel-last arrays of the attributes (``rgb[..., c]``) are views of those
planes (``np.moveaxis``), not copies: writing into them changes the image.  :meth:`planes`
gives the planar block itself.  Where the sky was evaluated is kept as a bool mask (1 byte a
pixel); :attr:`alpha` turns it into float32 on first use.
"""

from __future__ import annotations

import numpy as np

from ..scene import Scene
from .directions import DirectionSet
from .plan import Plan

__all__ = ["SkyImage"]

#: Layers with a channel axis (last in the attributes, first in the planar storage).
_STACKED = ("rgb", "xyz", "spectral")

#: Directions per band when :attr:`SkyImage.luminance` converts RGB (bounded temporaries).
_LUMINANCE_BAND = 1 << 16


class SkyImage:
    """A rendered sky.

    Made by :func:`~atmoscatter.render`; the layers it was not asked for are None.

    Parameters
    ----------
    scene : Scene
        The scene rendered.
    plan : Plan
        The plan the render followed.
    directions_set : DirectionSet
        Where each pixel/vertex looks.
    rgb, xyz, luminance_only, spectral, wavelengths, alpha : ndarray or None, optional
        The layers, shaped as the attributes below (channels on the last axis); stored planar
        (a channel-last array is copied into planes once, a view of planes is not copied).
    metadata : dict of str, optional
        Provenance written to the EXR header (default: empty).

    Attributes
    ----------
    scene : Scene
    plan : Plan
    directions_set : DirectionSet
        Where each pixel/vertex looks (see :attr:`directions`).
    rgb : ndarray or None
        Linear RGB in ``scene.colourspace`` [cd m⁻²], shape ``shape + (3,)``, after the
        scene's ``gamut`` policy (default: no negative channel; see
        :mod:`atmoscatter.render.evaluate`).  A view of :meth:`planes` ``("rgb")``.
    xyz : ndarray or None
        CIE XYZ [cd m⁻²], shape ``shape + (3,)``, when ``output`` is ``xyz``.
    luminance_only : ndarray or None
        Y [cd m⁻²], shape ``shape``, when ``output`` is ``luminance``.
    spectral : ndarray or None
        Spectral radiance [W m⁻² sr⁻¹ nm⁻¹] at :attr:`wavelengths`, shape
        ``shape + (n_wl,)``.
    wavelengths : ndarray or None
        Wavelengths [nm] of :attr:`spectral` (and of the plan's spectral sampling).
    alpha : ndarray (float32) or None
        1 where the sky was evaluated, 0 for ground fill and outside the map, shape ``shape``.
    metadata : dict of str
        Provenance written to the EXR header.
    """

    def __init__(self, scene: Scene, plan: Plan, directions_set: DirectionSet, rgb=None,
                 xyz=None, luminance_only=None, spectral=None, wavelengths=None, alpha=None,
                 metadata: dict | None = None):
        self.scene = scene
        self.plan = plan
        self.directions_set = directions_set
        self._planes: dict[str, np.ndarray] = {}
        self.rgb = rgb
        self.xyz = xyz
        self.spectral = spectral
        self.luminance_only = luminance_only
        self.wavelengths = wavelengths
        self.alpha = alpha
        self.metadata = {} if metadata is None else metadata

    @classmethod
    def _from_planes(cls, scene, plan, directions_set, *, planes: dict, luminance_only=None,
                     alpha_mask=None, wavelengths=None, metadata=None) -> SkyImage:
        """The evaluator's constructor: ``planes`` (name → C-contiguous ``(C,) + shape``)
        and ``alpha_mask`` (bool, ``shape``) are kept as they are, without copies."""
        img = cls(scene, plan, directions_set, luminance_only=luminance_only,
                  wavelengths=wavelengths, metadata=metadata)
        img._planes.update(planes)
        img._alpha = alpha_mask
        return img

    _FIELDS = ("scene", "plan", "directions_set", "rgb", "xyz", "luminance_only", "spectral",
               "wavelengths", "alpha", "metadata")

    def replace(self, **changes) -> SkyImage:
        """A copy with some attributes replaced (what :func:`dataclasses.replace` did when
        ``SkyImage`` was a dataclass); unchanged layers are shared, not copied.

        Parameters
        ----------
        **changes
            New values of any of ``scene``, ``plan``, ``directions_set``, ``rgb``, ``xyz``,
            ``luminance_only``, ``spectral``, ``wavelengths``, ``alpha``, ``metadata``.

        Returns
        -------
        SkyImage
            The new image; ``metadata`` is a shallow copy unless replaced.

        Raises
        ------
        TypeError
            If a keyword names no attribute of a sky image.
        """
        unknown = sorted(set(changes) - set(self._FIELDS))
        if unknown:
            raise TypeError(f"SkyImage.replace() got unknown attribute(s) {unknown}; "
                            f"valid: {list(self._FIELDS)}")
        new = type(self).__new__(type(self))
        new.scene, new.plan, new.directions_set = self.scene, self.plan, self.directions_set
        new._planes = dict(self._planes)
        new._luminance_only = self._luminance_only
        new._alpha = self._alpha
        new.wavelengths = self.wavelengths
        new.metadata = dict(self.metadata)
        for k, v in changes.items():
            setattr(new, k, v)
        return new

    __replace__ = replace  # copy.replace (Python 3.13+)

    def __repr__(self) -> str:
        layers = [n for n in ("rgb", "xyz", "luminance_only", "spectral", "alpha")
                  if getattr(self, "_" + n if n in ("luminance_only", "alpha") else n)
                  is not None]
        return (f"SkyImage(model={self.scene.model!r}, projection={self.projection!r}, "
                f"shape={self.shape}, layers={layers})")

    # --- planar storage ---------------------------------------------------------------
    def planes(self, layer: str):
        """The layer ``layer`` as its planar block, shape ``(C,) + shape`` (no copy).

        Parameters
        ----------
        layer : {"rgb", "xyz", "spectral"}
            Which stacked layer.

        Returns
        -------
        ndarray or None
            The C-contiguous planes (``planes("rgb")[0]`` is R, ``[1]`` G, ``[2]`` B;
            ``planes("spectral")[i]`` is at ``wavelengths[i]``), or None when the image has
            no such layer.  The attribute of the same name is a view of it.

        Raises
        ------
        ValueError
            If ``layer`` is not one of ``"rgb"``, ``"xyz"``, ``"spectral"``.
        """
        if layer not in _STACKED:
            raise ValueError(f"layer={layer!r} is not valid; choose one of {list(_STACKED)}")
        return self._planes.get(layer)

    def _get_stacked(self, name):
        p = self._planes.get(name)
        return None if p is None else np.moveaxis(p, 0, -1)

    def _set_stacked(self, name, value):
        if value is None:
            self._planes.pop(name, None)
            return
        a = np.asarray(value)
        if a.ndim < 1:
            raise ValueError(f"SkyImage.{name} needs an array with channels on its last axis, "
                             f"got shape {a.shape}")
        self._planes[name] = np.ascontiguousarray(np.moveaxis(a, -1, 0))

    rgb = property(lambda self: self._get_stacked("rgb"),
                   lambda self, v: self._set_stacked("rgb", v),
                   doc="Linear RGB, shape ``shape + (3,)`` (a view of ``planes('rgb')``).")
    xyz = property(lambda self: self._get_stacked("xyz"),
                   lambda self, v: self._set_stacked("xyz", v),
                   doc="CIE XYZ, shape ``shape + (3,)`` (a view of ``planes('xyz')``).")
    spectral = property(lambda self: self._get_stacked("spectral"),
                        lambda self, v: self._set_stacked("spectral", v),
                        doc="Spectral radiance, shape ``shape + (n_wl,)`` (a view of "
                            "``planes('spectral')``).")

    @property
    def luminance_only(self):
        """Y [cd m⁻²] of an ``output = "luminance"`` render, shape ``shape``, or None."""
        return self._luminance_only

    @luminance_only.setter
    def luminance_only(self, value):
        self._luminance_only = None if value is None else np.asarray(value)

    @property
    def alpha(self):
        """1 where the sky was evaluated, 0 for ground fill and outside the map (float32)."""
        a = self._alpha
        if a is not None and a.dtype == bool:  # stored as a mask: converted once, then kept
            a = self._alpha = a.astype(np.float32)
        return a

    @alpha.setter
    def alpha(self, value):
        self._alpha = None if value is None else np.asarray(value)

    def _alpha_as(self, dtype):
        """Alpha converted to ``dtype`` without keeping a float32 copy of a bool mask."""
        a = self._alpha
        return None if a is None else a.astype(dtype, copy=a.dtype != dtype)

    # --- geometry ---------------------------------------------------------------------
    @property
    def shape(self) -> tuple:
        """Image shape (rows, columns), or (vertices,) for a dome."""
        return self.directions_set.shape

    @property
    def projection(self) -> str:
        return self.directions_set.kind

    @property
    def directions(self) -> np.ndarray:
        """Unit view directions, shape ``shape + (3,)`` (computed on demand)."""
        return self.directions_set.all_directions()

    @property
    def faces(self):
        """Triangles (m, 3) of a dome mesh, else None."""
        return getattr(self.directions_set, "faces", None)

    @property
    def luminance(self) -> np.ndarray:
        """Luminance Y [cd m⁻²], shape ``shape``."""
        if self.luminance_only is not None:
            return self.luminance_only
        if self.xyz is not None:
            return self._planes["xyz"][1]
        from ..colour import XYZ_to_linear_rgb  # noqa: PLC0415

        # exact inverse of the forward matrix used by render(); in bands of directions so
        # that the float64 temporaries stay bounded for any map size
        m = np.linalg.inv(XYZ_to_linear_rgb(np.eye(3), self.scene.colourspace))[:, 1]
        p = self._planes["rgb"]
        flat = p.reshape(p.shape[0], -1)
        out = np.empty(flat.shape[1], dtype=np.float32)
        for a in range(0, flat.shape[1], _LUMINANCE_BAND):
            b = min(a + _LUMINANCE_BAND, flat.shape[1])
            out[a:b] = flat[:, a:b].T.astype(np.float64, order="C") @ m
        return out.reshape(p.shape[1:])

    def to_numpy(self) -> dict:
        """The layers as a dict of numpy arrays (``rgb``, ``xyz``, ``luminance``, …).

        Returns
        -------
        dict of str to ndarray
            ``directions`` and ``luminance`` always, then each layer the image has (``rgb``,
            ``xyz``, ``spectral``, ``alpha``, ``wavelengths``; channel-last views of the
            planar storage) and ``faces`` of a dome mesh.
        """
        out = {"directions": self.directions, "luminance": self.luminance}
        for name in ("rgb", "xyz", "spectral", "alpha", "wavelengths"):
            v = getattr(self, name)
            if v is not None:
                out[name] = v
        if self.faces is not None:
            out["faces"] = self.faces
        return out

    def to_xarray(self):
        """An :class:`xarray.Dataset` of the layers (needs xarray installed).

        Returns
        -------
        xarray.Dataset
            ``luminance`` and ``direction``, plus ``rgb``, ``XYZ``, ``spectral`` and
            ``alpha`` when present, with units as attributes and :attr:`metadata` as the
            dataset's attributes.
        """
        try:
            import xarray as xr  # noqa: PLC0415
        except ImportError as exc:  # pragma: no cover
            raise ImportError("SkyImage.to_xarray needs xarray: pip install xarray") from exc
        dims = ("row", "column") if len(self.shape) == 2 else ("vertex",)
        data = {"luminance": (dims, self.luminance, {"units": "cd m-2"}),
                "direction": (dims + ("xyz",), self.directions,
                              {"frame": "x=east, y=north, z=up"})}
        coords = {}
        if self.rgb is not None:
            data["rgb"] = (dims + ("channel",), self.rgb,
                           {"units": "cd m-2", "colourspace": self.scene.colourspace})
            coords["channel"] = ["R", "G", "B"]
        if self.xyz is not None:
            data["XYZ"] = (dims + ("cie",), self.xyz, {"units": "cd m-2"})
            coords["cie"] = ["X", "Y", "Z"]
        if self.spectral is not None:
            data["spectral"] = (dims + ("wavelength",), self.spectral,
                                {"units": "W m-2 sr-1 nm-1"})
            coords["wavelength"] = self.wavelengths
        if self.alpha is not None:
            data["alpha"] = (dims, self.alpha)
        return xr.Dataset(data, coords=coords, attrs=dict(self.metadata))
