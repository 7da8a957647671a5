"""A noise profile (``drakeslip.noise.NoiseProfile``) in three dimensions: the draws of the spatial hopper's loop on a
height map, their sizes the profile's (already in the hopper's units: ``NoiseProfile.for_hopper``).

* state estimation: the apex told is the true (x, y, z, xdot, ydot) plus Gaussian errors; the profile's x error is
  both horizontal positions', its xdot error both horizontal speeds' (``apex_errors3d``);
* actuation: each gimbal angle reached (pitch, roll) is the commanded one plus its own draw of the profile's leg
  angle error (``angle_errors3d``);
* model mismatch: the executed hopper is the planar one's (``NoiseProfile.executed_params``);
* terrain perception: every solid cell of the map seen is off by the profile's height error and the whole map is
  shifted by its edge error in x and, drawn apart, in y; holes stay holes (``perceived_map``). The robot may run a
  median filter on it (``denoised_map``: ``Terrain.denoised`` on the grid).

The planar draws are left as they were: a planar run draws exactly what it drew before these existed.
"""
from __future__ import annotations

import numpy as np

from drakeslip.noise import NoiseProfile
from drakeslip.params import check_number
from drakeslip.spatial.heightmap import HeightMap
from drakeslip.terrain import check_window


def apex_sizes3d(noise: NoiseProfile) -> np.ndarray:
    """The standard deviations of the apex told, (x, y, z, xdot, ydot), from the profile's (x, z, xdot)."""
    x, z, xdot = noise.apex
    return np.array([x, x, z, xdot, xdot])


def apex_errors3d(noise: NoiseProfile, rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 5) errors of the apexes told, one row (x, y, z, xdot, ydot) per apex."""
    return rng.normal(size=(n, 5)) * apex_sizes3d(noise)


def angle_errors3d(noise: NoiseProfile, rng: np.random.Generator, n: int) -> np.ndarray:
    """(n, 2) errors of the (pitch, roll) reached, one row per hop, each angle its own draw."""
    return rng.normal(size=(n, 2)) * noise.leg_angle


def perceived_map(noise: NoiseProfile, height_map: HeightMap, rng: np.random.Generator,
                  map_filter: int = 1) -> HeightMap:
    """``height_map`` as sensed: each solid cell's height off by a Gaussian error, then the whole map shifted by
    (dx, dy), each its own draw; holes stay holes. ``map_filter``: the cells across the median filter the robot runs
    on it (``denoised_map`` with the profile's height error; 1: the map as sensed)."""
    heights = np.array(height_map.heights)
    solid = ~np.isnan(heights)
    heights[solid] += rng.normal(size=int(solid.sum())) * noise.heights
    dx, dy = rng.normal(size=2) * noise.edges
    x0, y0 = height_map.origin
    sensed = HeightMap(heights, height_map.cell, (x0 + dx, y0 + dy), height_map.extends_flat)
    return denoised_map(sensed, noise.heights, map_filter)


def denoised_map(height_map: HeightMap, sigma: float, window: int = 5) -> HeightMap:
    """``Terrain.denoised`` on the grid: each solid cell's height replaced by the lower median of the solid cells in
    the ``window`` x ``window`` cells around it, where at least 3 such cells exist and their median is within
    3 ``sigma`` of the cell's own height; holes are kept. The lower median is one of the heights seen, so a noiseless
    map of levels more than 3 ``sigma`` apart comes back unchanged; ``sigma`` 0 or a window below 3 returns the map."""
    sigma = check_number(sigma, "denoised sigma")
    window = check_window(window, "denoised window")
    if sigma <= 0 or window < 3:
        return height_map
    h, half = height_map.heights, window // 2
    padded = np.pad(h, half, constant_values=np.nan)   # NaN: a hole or off the map, neither counts
    around = np.lib.stride_tricks.sliding_window_view(padded, (window, window)).reshape(*h.shape, window * window)
    count = np.count_nonzero(~np.isnan(around), axis=-1)
    ordered = np.sort(around, axis=-1)   # NaNs sort last
    median = np.take_along_axis(ordered, (np.maximum(count - 1, 0) // 2)[..., None], axis=-1)[..., 0]
    use = ~np.isnan(h) & (count >= 3) & (np.abs(median - h) <= 3.0 * sigma)
    if not use.any():
        return height_map
    return HeightMap(np.where(use, median, h), height_map.cell, height_map.origin, height_map.extends_flat)
