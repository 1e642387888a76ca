"""Height fields: hills from a formula, rough ground from a seed, heights from a file."""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np

from tensim.limits import MAX_GRID_CELLS
from tensim.terrain._errors import TerrainError
from tensim.terrain._geometry import Grid

IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff")
ARRAY_SUFFIXES = (".npy", ".csv", ".txt")


def _axis(half: float, resolution: float) -> np.ndarray:
    """Sample positions from -half to +half [m], at most ``resolution`` apart."""
    return np.linspace(-half, half, int(np.ceil(2 * half / resolution - 1e-9)) + 1)


@functools.lru_cache(maxsize=4)
def hills_grid(height: float, wavelength: float, half: float, resolution: float) -> Grid:
    """h sin(2πx/λ) cos(2πy/λ) sampled over ±half [m]."""
    axis = _axis(half, resolution)
    x, y = np.meshgrid(axis, axis)  # rows along y
    k = 2 * np.pi / wavelength
    return Grid(height * np.sin(k * x) * np.cos(k * y), half, half)


@functools.lru_cache(maxsize=4)
def rough_grid(roughness: float, correlation: float, seed: int, half: float,
               resolution: float) -> Grid:
    """White noise from ``seed``, Gaussian-filtered (sigma ``correlation`` [m]), scaled to an
    RMS height of ``roughness`` [m] about a zero mean."""
    from scipy import ndimage  # imported on use: ~0.1 s that flat-ground runs need not pay

    axis = _axis(half, resolution)
    noise = np.random.default_rng(seed).standard_normal((axis.size, axis.size))
    smooth = ndimage.gaussian_filter(noise, sigma=correlation / resolution, mode="wrap")
    smooth -= smooth.mean()
    return Grid(smooth * (roughness / smooth.std()), half, half)


def load_grid(file: str, height: float | None) -> np.ndarray:
    """Heights [m] from an image (grey level times ``height``, default 0.1 m; top row at +y)
    or an array file (metres; row 0 at -y), rows along y.

    Raises:
        TerrainError: the file is missing, of an unknown type, or not a 2-D grid of numbers.
    """
    path = Path(file)
    where = f"terrain 'heightfield': file {str(path)!r}"
    if not path.is_file():
        raise TerrainError(f"{where} does not exist")
    suffix = path.suffix.lower()
    try:
        if suffix in IMAGE_SUFFIXES:
            heights = np.flipud(_grey(path)) * (0.1 if height is None else height)
        elif suffix in ARRAY_SUFFIXES:
            if height is not None:
                raise TerrainError(f"{where}: height applies to images only; array files "
                                   "hold heights in metres")
            heights = _array(path, suffix)
        else:
            raise TerrainError(f"{where}: unknown type {suffix!r}; expected an image "
                               f"{IMAGE_SUFFIXES} or an array {ARRAY_SUFFIXES}")
    except TerrainError:
        raise
    except Exception as err:  # image and array readers raise many types for a damaged file
        if isinstance(err, MemoryError):
            raise
        raise TerrainError(f"{where} cannot be read: {err}") from err
    if heights.ndim != 2 or min(heights.shape) < 2:
        raise TerrainError(f"{where}: expected a 2-D grid of at least 2 x 2 heights, got shape "
                           f"{heights.shape}")
    if heights.size > MAX_GRID_CELLS:
        raise TerrainError(f"{where}: {heights.shape[0]} x {heights.shape[1]} heights is more "
                           f"than the limit of {MAX_GRID_CELLS} samples; downsample the file")
    if not np.all(np.isfinite(heights)):
        raise TerrainError(f"{where}: heights must be finite numbers")
    return np.ascontiguousarray(heights, dtype=float)


def _grey(path: Path) -> np.ndarray:
    """An image's grey level in [0, 1] (mean of the colour channels, alpha ignored)."""
    from matplotlib import image

    raw = np.asarray(image.imread(path))
    pixels = raw.astype(float)
    if np.issubdtype(raw.dtype, np.integer):  # 8- or 16-bit levels; PNGs come as 0..1 floats
        pixels /= np.iinfo(raw.dtype).max
    return pixels[..., :3].mean(axis=-1) if pixels.ndim == 3 else pixels


def _array(path: Path, suffix: str) -> np.ndarray:
    if suffix == ".npy":
        return np.asarray(np.load(path, allow_pickle=False), dtype=float)
    return np.loadtxt(path, delimiter="," if suffix == ".csv" else None, ndmin=2)
