"""The tile grid: where each model's tile goes in a side-by-side video, and composing the tiles into one frame.

Tiles fill rows left to right, top to bottom; by default there are up to :data:`MAX_DEFAULT_COLUMNS` tiles per row
with the rows filled evenly (7 tiles: 2 rows of 4 columns, the last cell empty). Unused cells are dark grey.

Example::

    layout = grid_layout(7)                       # Layout(rows=2, columns=4)
    canvas = compose(images, layout)              # (2 * h, 4 * w, 3) uint8
"""

from __future__ import annotations

import dataclasses
import math
from typing import Optional, Sequence

import numpy as np

from mjcable import _validate

__all__ = ["Layout", "grid_layout", "compose", "MAX_DEFAULT_COLUMNS", "EMPTY_TILE"]

MAX_DEFAULT_COLUMNS = 4  # tiles per row unless asked otherwise
EMPTY_TILE = 40  # grey level of unused grid cells


@dataclasses.dataclass(frozen=True, kw_only=True)
class Layout:
    """A grid of ``rows`` by ``columns`` cells holding ``n`` tiles (``n <= rows * columns``)."""

    n: int
    rows: int
    columns: int

    def cell(self, i: int) -> tuple:
        """``(row, column)`` of tile ``i``."""
        return divmod(i, self.columns)

    def shape(self, tile_height: int, tile_width: int) -> tuple:
        """``(height, width)`` of the whole frame in pixels, for tiles of the given size."""
        return self.rows * tile_height, self.columns * tile_width


def grid_layout(n: int, columns: Optional[int] = None) -> Layout:
    """The grid of ``n`` tiles with ``columns`` per row (default: up to 4, rows filled evenly).

    Raises:
      ValueError: ``columns`` is not an integer in [1, n].
    """
    n = _validate.integer("n", n, low=1)
    if columns is None:
        columns = math.ceil(n / math.ceil(n / MAX_DEFAULT_COLUMNS))
    columns = _validate.integer("columns", columns, low=1, high=n)
    return Layout(n=n, rows=math.ceil(n / columns), columns=columns)


def compose(images: Sequence[np.ndarray], layout: Layout) -> np.ndarray:
    """Place ``images`` (``layout.n`` tiles, each ``(h, w, 3)`` uint8 of one size) into one frame.

    Returns:
      ``(layout.rows * h, layout.columns * w, 3)`` uint8, unused cells dark grey.
    """
    if len(images) != layout.n:
        raise ValueError(f"images must hold {layout.n} tiles for this layout, got {len(images)}")
    h, w = images[0].shape[:2]
    canvas = np.full((*layout.shape(h, w), 3), EMPTY_TILE, np.uint8)
    for i, image in enumerate(images):
        r, c = layout.cell(i)
        canvas[r * h:(r + 1) * h, c * w:(c + 1) * w] = image
    return canvas
