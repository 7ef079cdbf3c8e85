"""The keypose policy's view of the table: the scene camera's RGB-D image re-projected onto a grid
over the table seen from above (colour and height of the highest point in each cell), as Transporter
networks and CLIPort see their workspace. A cell of the grid is a place on the table, so a heatmap over
it names a position in metres and the network's errors are errors in metres.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from samplehd.learn.perception.geometry import backproject

__all__ = ["GRID_CHANNELS", "TopDownGrid"]

# colour (3, in [0, 1]), height above the table (1, per 10 cm), seen (1), x and y of the cell (2, in [-1, 1])
GRID_CHANNELS = 7
HEIGHT_SCALE = 0.1  # a height channel value of 1 is this far above the table [m]
MAX_HEIGHT = 0.5  # points higher above the table (the arm, the wall) are left out [m]


@dataclass(frozen=True)
class TopDownGrid:
    """A grid of ``rows`` × ``cols`` square cells of side ``cell`` [m] whose corner is ``origin``
    (world x, y [m]); rows run along x, columns along y."""

    origin: tuple[float, float] = (-0.512, -0.64)
    cell: float = 0.008
    rows: int = 128
    cols: int = 160

    def world(self, row: np.ndarray | float, col: np.ndarray | float) -> np.ndarray:
        """World x, y [m] of (fractional) cell indices, at the cells' centres for whole ones."""
        row, col = np.asarray(row, np.float64), np.asarray(col, np.float64)
        return np.stack([self.origin[0] + (row + 0.5) * self.cell, self.origin[1] + (col + 0.5) * self.cell], -1)

    def cell_of(self, xy: np.ndarray) -> np.ndarray:
        """Fractional (row, col) of world x, y [m] (the inverse of :meth:`world`)."""
        xy = np.asarray(xy, np.float64)
        return np.stack([(xy[..., 0] - self.origin[0]) / self.cell - 0.5,
                         (xy[..., 1] - self.origin[1]) / self.cell - 0.5], -1)

    def coarse(self, factor: int) -> TopDownGrid:
        """The same area in cells ``factor`` times larger (the network's maps)."""
        return TopDownGrid(self.origin, self.cell * factor, self.rows // factor, self.cols // factor)

    def contains(self, xy: np.ndarray) -> bool:
        rc = self.cell_of(xy)
        return bool(0 <= rc[0] <= self.rows - 1 and 0 <= rc[1] <= self.cols - 1)

    def project(self, rgb: np.ndarray, depth: np.ndarray, camera: Mapping[str, Any], table_height: float,
                robot: np.ndarray | None = None) -> np.ndarray:
        """The grid image (:data:`GRID_CHANNELS`, rows, cols), float32, of one RGB-D image of a camera
        (``camera``: width, height, intrinsics, extrinsics as in a scene annotation): each cell the
        colour and height of the highest point seen in it; cells no pixel falls in are zero, seen 0.
        ``robot``: the pixels that show the robot, left out (a robot's self-filter, which knows where
        its links are; above the table, the arm would hide what lies under it)."""
        return self._image(rgb, *self._tops(depth, camera, table_height, robot))

    def project_labels(self, labels: np.ndarray, depth: np.ndarray, camera: Mapping[str, Any], table_height: float,
                       robot: np.ndarray | None = None) -> np.ndarray:
        """Per cell (rows, cols) the label (an integer image beside the depth, e.g. segmentation ids) of
        the highest point seen in it, as :meth:`project` chooses it; 0 where no point falls."""
        cells, pixels, _ = self._tops(depth, camera, table_height, robot)
        return self._labels(labels, cells, pixels)

    def project_with_labels(self, rgb: np.ndarray, labels: np.ndarray, depth: np.ndarray, camera: Mapping[str, Any],
                            table_height: float, robot: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(:meth:`project`, :meth:`project_labels`) of one RGB-D image, its points found once."""
        tops = self._tops(depth, camera, table_height, robot)
        return self._image(rgb, *tops), self._labels(labels, tops[0], tops[1])

    def _image(self, rgb: np.ndarray, cells: np.ndarray, pixels: np.ndarray, height: np.ndarray) -> np.ndarray:
        out = np.zeros((GRID_CHANNELS, self.rows * self.cols), np.float32)
        out[0:3, cells] = rgb.reshape(-1, 3)[pixels].T / 255.0
        out[3, cells] = np.maximum(height, 0.0) / HEIGHT_SCALE
        out[4, cells] = 1.0
        out = out.reshape(GRID_CHANNELS, self.rows, self.cols)
        for step in (1, -1):  # a cell between two rows of pixels (far from the camera) takes a neighbour's
            hole = out[4] == 0
            src = np.roll(out, step, axis=1)
            fill = hole & (src[4] > 0)
            fill[0 if step == 1 else -1] = False
            out[:5, fill] = src[:5, fill]
        out[5] = np.linspace(-1.0, 1.0, self.rows, dtype=np.float32)[:, None]
        out[6] = np.linspace(-1.0, 1.0, self.cols, dtype=np.float32)[None, :]
        return out

    def _labels(self, labels: np.ndarray, cells: np.ndarray, pixels: np.ndarray) -> np.ndarray:
        out = np.zeros(self.rows * self.cols, np.int64)
        out[cells] = np.asarray(labels).reshape(-1)[pixels]
        return out.reshape(self.rows, self.cols)

    def _tops(self, depth: np.ndarray, camera: Mapping[str, Any], table_height: float,
              robot: np.ndarray | None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(cells, pixels, heights): each cell some pixel falls in (flat index), the pixel of its highest
        point (flat index) and that point's height above the table [m]."""
        h, w = depth.shape
        rows, cols = np.indices((h, w))
        points = backproject(depth, rows.ravel(), cols.ravel(), camera)
        height = points[:, 2] - table_height
        rc = np.floor((points[:, :2] - np.asarray(self.origin)) / self.cell).astype(np.int64)
        keep = ((rc[:, 0] >= 0) & (rc[:, 0] < self.rows) & (rc[:, 1] >= 0) & (rc[:, 1] < self.cols)
                & (height > -0.02) & (height < MAX_HEIGHT) & np.isfinite(height))
        if robot is not None:
            keep &= ~np.asarray(robot, bool).ravel()
        pixels = np.flatnonzero(keep)
        flat = rc[pixels, 0] * self.cols + rc[pixels, 1]
        order = np.lexsort((height[pixels], flat))  # by cell, then height: each cell's highest point last
        flat, pixels = flat[order], pixels[order]
        last = np.r_[flat[1:] != flat[:-1], True]
        return flat[last], pixels[last], height[pixels[last]]
