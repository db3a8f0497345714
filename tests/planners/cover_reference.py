"""The disks' cover as numpy built and read it before it was compiled.

:func:`planners.visibility.sightlines.cover_table` and ``occluded_pairs`` are compiled
loops (:func:`planners.kernels.cover_sectors`, :func:`planners.kernels.occluded_by_cover`).
These are the numpy versions they replaced, kept verbatim; tests hold the tables and the
flags equal.
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

from planners.visibility.sightlines import Disks, _ramp, _sectors_of

FloatArray = npt.NDArray[np.float64]
IntArray = npt.NDArray[np.intp]
BoolArray = npt.NDArray[np.bool_]

_COVER_PAIRS = 1 << 13
"""(start, disk) pairs handled at once when the cover table is built."""
_SEGMENTS_AT_ONCE = 1 << 13
"""Segments looked up in the cover table at once."""


def cover_table_reference(
    disks: Disks, sources: FloatArray, sectors: int
) -> FloatArray:
    """Return, per source and sector, the length beyond which a segment is blocked.

    Sector k of a source holds the directions at angles in [k w - pi, (k + 1) w - pi],
    w = 2 pi / ``sectors``. A segment from the source in that sector and longer than
    the table's entry passes through a disk (inf where no disk covers the sector);
    shape (len(sources), sectors) [m]. Built ``_COVER_PAIRS`` (source, disk) pairs at
    a time, so its temporaries stay small.

    """
    table = np.full((len(sources), sectors), np.inf)
    if not len(disks.radius):
        return table
    rows = max(1, _COVER_PAIRS // len(disks.radius))
    for r0 in range(0, len(sources), rows):
        table[r0 : r0 + rows] = _nearest_cover(disks, sources[r0 : r0 + rows], sectors)
    return table


def occluded_pairs_reference(
    table: FloatArray, points: FloatArray, i: IntArray, j: IntArray
) -> BoolArray:
    """Tell which segments points[i] -> points[j] certainly pass through a disk.

    ``table`` is :func:`cover_table` of every point: the segment is looked up from both
    ends (from j its direction is reversed, half a turn of sectors on). Only a filter,
    like :func:`occluded`, which looks from the start alone and flags fewer.

    """
    sectors = table.shape[1]
    flat = table.ravel()
    x, y = np.ascontiguousarray(points[:, 0]), np.ascontiguousarray(points[:, 1])
    blocked = np.zeros(len(i), dtype=bool)
    for s0 in range(0, len(i), _SEGMENTS_AT_ONCE):
        ii, jj = i[s0 : s0 + _SEGMENTS_AT_ONCE], j[s0 : s0 + _SEGMENTS_AT_ONCE]
        # take: numpy's indexing of a 2-D array is many times slower (geometry.take_rows)
        dx = x.take(jj) - x.take(ii)
        dy = y.take(jj) - y.take(ii)
        sector = _sectors_of(dx, dy, sectors)
        length = np.hypot(dx, dy)
        back = (sector + sectors // 2) % sectors
        blocked[s0 : s0 + len(ii)] = (length > flat.take(ii * sectors + sector)) | (
            length > flat.take(jj * sectors + back)
        )
    return blocked


def _nearest_cover(disks: Disks, sources: FloatArray, sectors: int) -> FloatArray:
    """Per source and sector, the nearest distance to a disk whose cone holds the sector."""
    width = 2.0 * np.pi / sectors
    cx = disks.center[None, :, 0] - sources[:, 0:1]
    cy = disks.center[None, :, 1] - sources[:, 1:2]
    dist = np.hypot(cx, cy)
    seen = dist > disks.radius[None, :]  # the source is outside the disk
    half = np.arcsin(np.minimum(disks.radius[None, :] / np.maximum(dist, 1e-300), 1.0))
    mid = np.arctan2(cy, cx) + np.pi  # in [0, 2 pi]
    # Sectors k with [k w, (k + 1) w] inside the cone (mid - half, mid + half).
    first = np.ceil((mid - half) / width)
    last = np.floor((mid + half) / width) - 1
    count = np.where(seen, np.maximum(last - first + 1, 0), 0).astype(np.intp)
    row, disk = np.nonzero(count)
    count = count[row, disk]
    sector = (
        np.repeat(first[row, disk].astype(np.intp), count) + _ramp(count)
    ) % sectors
    near = np.full(len(sources) * sectors, np.inf)
    # On flat indices: numpy's fast path for ufunc.at (a 2-D index is several times
    # slower). The minimum does not depend on the order.
    np.minimum.at(
        near,
        np.repeat(row * sectors, count) + sector,
        np.repeat(dist[row, disk], count),
    )
    return near.reshape(len(sources), sectors)
