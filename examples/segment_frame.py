#!/usr/bin/env python3
"""Segments one frame with the rangeseg Python module and prints its segments.

    python3 examples/segment_frame.py [CLOUD [PRESET]]

CLOUD is a .pcd, .ply, .xyz* or .range file; without it, a depth image of a floor with a box
on it, seen by a Kinect 1 m above the floor, is made here with NumPy. PRESET is the sensor's:
kinect (the default), abw or perceptron (SegComp .range images), laser or ideal.
"""

import sys

import numpy as np

import rangeseg


def floor_with_a_box(width=640, height=480, fx=525.0, fy=525.0, cx=319.5, cy=239.5):
    """Depth [m] of a floor 1 m below the camera, which looks 40 degrees down, and the 0.4 m
    square top of a 0.3 m high box (its sides are not drawn)."""
    u, v = np.meshgrid(np.arange(width), np.arange(height))
    rays = np.stack([(u - cx) / fx, (v - cy) / fy, np.ones(u.shape)], axis=-1)
    tilt = np.radians(40)
    up = np.array([0.0, -np.cos(tilt), -np.sin(tilt)])  # the floor's normal in the camera frame
    depth = np.full(u.shape, np.inf)
    for height_above_floor in (0.0, 0.3):  # the floor, then the box top
        t = (1.0 - height_above_floor) / -(rays @ up)
        hit = t > 0
        if height_above_floor > 0:  # the top is a 0.4 m square around the point 1.6 m ahead
            points = rays * t[..., None]
            along = points @ np.array([0.0, np.sin(tilt), -np.cos(tilt)]) * -1
            hit &= (np.abs(points[..., 0]) < 0.2) & (np.abs(along - 1.6) < 0.2)
        depth = np.where(hit, np.minimum(depth, t), depth)
    depth[~np.isfinite(depth)] = 0
    return depth.astype(np.float32), dict(fx=fx, fy=fy, cx=cx, cy=cy)


def main():
    preset = sys.argv[2] if len(sys.argv) > 2 else "kinect"
    pipeline = rangeseg.Pipeline(preset=preset, model="auto")
    if len(sys.argv) > 1:
        result = pipeline.process(rangeseg.read_cloud(sys.argv[1]))
    else:
        depth, camera = floor_with_a_box()
        result = pipeline.process_depth(depth, **camera)
    print(f"{result.width} x {result.height}: {len(result.segments)} segments "
          f"in {result.times['total']:.1f} ms")
    for s in result.segments:
        line = f"  {s['id']:3d} {s['surface']['type']:8s} {s['pixel_count']:7d} px"
        line += f"  normal ({s['normal'][0]:+.3f} {s['normal'][1]:+.3f} {s['normal'][2]:+.3f})"
        line += f"  offset {s['offset']:.3f} m"
        if "polygon" in s:
            line += f"  polygon {s['polygon']['area_m2']:.3f} m^2"
        print(line)


if __name__ == "__main__":
    main()
