"""The rendered sky: :class:`SkyImage`, the layers of a render and their metadata."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..directions import DirectionSet
from ..scene import Plan, Scene

__all__ = ["SkyImage"]


@dataclass
class SkyImage:
    """A rendered sky.

    Attributes
    ----------
    scene : Scene
    plan : Plan
    directions_set : DirectionSet
        Where each pixel/vertex looks (see :attr:`directions`).
    rgb : ndarray or None
        Linear RGB in ``scene.colourspace`` [cd m⁻²], shape ``shape + (3,)``, after the
        scene's ``gamut`` policy (default: no negative channel; see the module notes).
    xyz : ndarray or None
        CIE XYZ [cd m⁻²] when ``output`` is ``xyz``.
    luminance_only : ndarray or None
        Y [cd m⁻²] when ``output`` is ``luminance``.
    spectral : ndarray or None
        Spectral radiance [W m⁻² sr⁻¹ nm⁻¹] at :attr:`wavelengths`.
    alpha : ndarray
        1 where the sky was evaluated, 0 for ground fill and outside the map.
    metadata : dict of str
        Provenance written to the EXR header.
    """

    scene: Scene
    plan: Plan
    directions_set: DirectionSet
    rgb: np.ndarray | None = None
    xyz: np.ndarray | None = None
    luminance_only: np.ndarray | None = None
    spectral: np.ndarray | None = None
    wavelengths: np.ndarray | None = None
    alpha: np.ndarray | None = None
    metadata: dict = field(default_factory=dict)

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
            return self.xyz[..., 1]
        from ..colour import XYZ_to_linear_rgb  # noqa: PLC0415

        # exact inverse of the forward matrix used by render()
        m = np.linalg.inv(XYZ_to_linear_rgb(np.eye(3), self.scene.colourspace))
        return (self.rgb.astype(np.float64) @ m[:, 1]).astype(np.float32)

    def to_numpy(self) -> dict:
        """The layers as a dict of numpy arrays (``rgb``, ``xyz``, ``luminance``, …)."""
        out = {"directions": self.directions, "luminance": self.luminance}
        for name in ("rgb", "xyz", "spectral", "alpha", "wavelengths"):
            v = getattr(self, name)
            if v is not None:
                out[name] = v
        if self.faces is not None:
            out["faces"] = self.faces
        return out

    def to_xarray(self):
        """An :class:`xarray.Dataset` of the layers (needs xarray installed)."""
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
