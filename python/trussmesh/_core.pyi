"""Type stubs of the native module `trussmesh._core` (the meshers on numpy arrays)."""

from typing import Any, Callable, Dict, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

__version__: str

class Sampled2:
    """A function's values on a 2-D grid, shape (ny, nx) at origin + spacing (i, j),
    interpolated by cubic convolution; exact at pin_points."""

    def __init__(
        self,
        values: npt.NDArray[np.float64],
        origin: Tuple[float, float],
        spacing: float,
        pin_points: Optional[npt.NDArray[np.float64]] = ...,
        pin_values: Optional[npt.NDArray[np.float64]] = ...,
    ) -> None: ...
    def eval(self, points: npt.NDArray[np.float64]) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    @property
    def spacing(self) -> float: ...

class Sampled3:
    """A function's values on a 3-D grid, shape (nz, ny, nx), interpolated (tricubic)."""

    def __init__(
        self,
        values: npt.NDArray[np.float64],
        origin: Tuple[float, float, float],
        spacing: float,
        pin_points: Optional[npt.NDArray[np.float64]] = ...,
        pin_values: Optional[npt.NDArray[np.float64]] = ...,
    ) -> None: ...
    def eval(self, points: npt.NDArray[np.float64]) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
    @property
    def spacing(self) -> float: ...

Field2 = Union[str, Sampled2]
Field3 = Union[str, Sampled3]
Mesh2 = Tuple[
    npt.NDArray[np.float64], npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int8], Dict[str, Any]
]

def mesh_2d(
    domain: Field2,
    h0: float,
    bbox: Sequence[float],
    *,
    size: Optional[Field2] = ...,
    fixed: Optional[npt.NDArray[np.float64]] = ...,
    implicit: bool = ...,
    internal: Optional[Field2] = ...,
    metric: Optional[Union[str, Tuple[Field2, Field2, Field2]]] = ...,
    max_iter: Optional[int] = ...,
    seed: Optional[int] = ...,
    fscale: Optional[float] = ...,
    deltat: Optional[float] = ...,
    dptol: Optional[float] = ...,
    projection: Optional[str] = ...,
    strategy: Optional[str] = ...,
    max_elements: Optional[int] = ...,
    sharp_corners: bool = ...,
    progress: Optional[Callable[[int, int], Any]] = ...,
) -> Mesh2:
    """(points (n, 2), triangles (m, 3), labels (m,), vertex tags (n,), report)."""

def mesh_3d(
    domain: Field3,
    h0: float,
    bbox: Sequence[float],
    *,
    size: Optional[Field3] = ...,
    fixed: Optional[npt.NDArray[np.float64]] = ...,
    implicit: bool = ...,
    max_iter: Optional[int] = ...,
    seed: Optional[int] = ...,
    fscale: Optional[float] = ...,
    deltat: Optional[float] = ...,
    dptol: Optional[float] = ...,
    projection: Optional[str] = ...,
    max_elements: Optional[int] = ...,
    polish_rounds: Optional[int] = ...,
    sharp_edges: bool = ...,
    progress: Optional[Callable[[int, int], Any]] = ...,
) -> Mesh2:
    """(points (n, 3), tetrahedra (m, 4), labels (m,), vertex tags (n,), report)."""

def mesh_surface(
    phi: Field3,
    h0: float,
    bbox: Sequence[float],
    *,
    curvature: Optional[Tuple[float, float, float]] = ...,
    implicit: bool = ...,
    max_iter: Optional[int] = ...,
    fscale: Optional[float] = ...,
    deltat: Optional[float] = ...,
    dptol: Optional[float] = ...,
    progress: Optional[Callable[[int, int], Any]] = ...,
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.int64], Dict[str, Any]]:
    """(points (n, 3), triangles (m, 3), report)."""

def check_2d(h0: float, bbox: Sequence[float], fixed: Optional[npt.NDArray[np.float64]] = ...) -> None:
    """Raises the 2-D mesher's ValueError for a bad h0, box or fixed point."""

def check_3d(h0: float, bbox: Sequence[float], fixed: Optional[npt.NDArray[np.float64]] = ...) -> None:
    """Raises the 3-D mesher's ValueError for a bad h0, box or fixed point."""
