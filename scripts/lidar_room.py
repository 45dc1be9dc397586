#!/usr/bin/env python3
"""A spinning lidar's organized scans of a ray-cast room, segmented on their grid and over rings.

The room (20 x 15 m, floor 1.7 m below the sensor, four walls, a 1 m box, a car-sized box, a
box across the azimuth seam, a pole of r 0.15 m, a trunk of r 0.35 m, a sphere of r 0.6 m) is
scanned as a VLP-16 (16 x 1800), an OS1-64 (64 x 1024) and an OS1-64 at 2048 columns, rows the
beams and columns the azimuth, with Gaussian range noise and random dropouts. Ground truth: one
region per connected part of each surface, the columns wrapping round the seam. Prints SegComp's
counts (T = 0.8) for the organized scan (`preset="laser", model="auto"`) and for its valid
points as an unorganized cloud (over rings), with the milliseconds of each.

    PYTHONPATH=build/python python3 scripts/lidar_room.py

Sensor frame: x forward, y left, z up. Column c has azimuth pi - 2 pi (c + 0.5) / W (forward in
the middle column, the back at the seam between the last column and the first); row 0 is the
highest beam.
"""
import time

import numpy as np

import rangeseg

GROUND_Z = -1.7

# ---------------------------------------------------------------- scene description
# Each entry: (label, name, kind, params)
#  'rect' : axis-aligned plane: axis (0/1/2), value, bounds on other two axes
#  'box'  : axis-aligned box (lo, hi) -> 6 faces, labels label..label+5 (only visible ones hit)
#  'cyl'  : vertical cylinder (cx, cy, r, z0, z1)
#  'sph'  : sphere (cx, cy, cz, r)

def room_scene():
    S = []
    S.append((1, 'floor', 'rect', (2, GROUND_Z, (-10, 10), (-7.5, 7.5))))
    S.append((2, 'wall_back_x-10 (crosses seam)', 'rect', (0, -10.0, (-7.5, 7.5), (GROUND_Z, 3.5))))
    S.append((3, 'wall_front_x+10', 'rect', (0, 10.0, (-7.5, 7.5), (GROUND_Z, 3.5))))
    S.append((4, 'wall_left_y+7.5', 'rect', (1, 7.5, (-10, 10), (GROUND_Z, 3.5))))
    S.append((5, 'wall_right_y-7.5', 'rect', (1, -7.5, (-10, 10), (GROUND_Z, 3.5))))
    # box 1x1x1 m at (4, 3)
    S.append((10, 'box1', 'box', ((3.5, 2.5, GROUND_Z), (4.5, 3.5, GROUND_Z + 1.0))))
    # car-sized box 4.5 x 1.8 x 1.5 at (-5, -3.5)
    S.append((20, 'car', 'box', ((-7.25, -4.4, GROUND_Z), (-2.75, -2.6, GROUND_Z + 1.5))))
    # a box straddling the seam (behind the sensor, -x), 1.2 m cube at (-5, 0)
    S.append((30, 'box_seam', 'box', ((-5.6, -0.6, GROUND_Z), (-4.4, 0.6, GROUND_Z + 1.2))))
    S.append((40, 'pole r0.15', 'cyl', (3.0, -2.5, 0.15, GROUND_Z, 3.0)))
    S.append((41, 'trunk r0.35', 'cyl', (-2.0, 4.5, 0.35, GROUND_Z, 3.5)))
    S.append((42, 'sphere r0.6', 'sph', (2.5, 4.5, GROUND_Z + 0.6, 0.6)))
    return S


def beam_elevations(kind):
    if kind == 'vlp16':
        return np.deg2rad(np.linspace(15, -15, 16)), 1800
    if kind == 'vlp32':
        return np.deg2rad(np.linspace(15, -25, 32)), 1800
    if kind == 'os64':
        return np.deg2rad(np.linspace(22.5, -22.5, 64)), 1024
    if kind == 'os64x2048':
        return np.deg2rad(np.linspace(22.5, -22.5, 64)), 2048
    raise ValueError(kind)


def ray_dirs(elev, W):
    az = np.pi - 2 * np.pi * (np.arange(W) + 0.5) / W
    E, A = np.meshgrid(elev, az, indexing='ij')
    d = np.stack([np.cos(E) * np.cos(A), np.cos(E) * np.sin(A), np.sin(E)], -1)
    return d, E, A


def cast(d, scene):
    H, W, _ = d.shape
    tbest = np.full((H, W), np.inf)
    lab = np.zeros((H, W), np.int32)
    with np.errstate(divide='ignore', invalid='ignore'):
        for label, name, kind, p in scene:
            if kind == 'rect':
                ax, val, b1, b2 = p
                o = [i for i in range(3) if i != ax]
                t = val / d[..., ax]
                P = t[..., None] * d
                ok = (t > 0) & (P[..., o[0]] >= b1[0]) & (P[..., o[0]] <= b1[1]) & \
                     (P[..., o[1]] >= b2[0]) & (P[..., o[1]] <= b2[1])
                hit = ok & (t < tbest)
                tbest[hit] = t[hit]; lab[hit] = label
            elif kind == 'box':
                lo, hi = np.array(p[0]), np.array(p[1])
                t1 = lo / d; t2 = hi / d
                tmin = np.minimum(t1, t2); tmax = np.maximum(t1, t2)
                tn = tmin.max(-1); tf = tmax.min(-1)
                face_axis = tmin.argmax(-1)
                ok = (tn <= tf) & (tn > 0)
                # face label: axis*2 + (hit on hi side)
                P = tn[..., None] * d
                side = np.take_along_axis(P, face_axis[..., None], -1)[..., 0] > (lo + hi)[face_axis] / 2
                fl = label + face_axis * 2 + side.astype(np.int32)
                hit = ok & (tn < tbest)
                tbest[hit] = tn[hit]; lab[hit] = fl[hit]
            elif kind == 'cyl':
                cx, cy, r, z0, z1 = p
                a = d[..., 0] ** 2 + d[..., 1] ** 2
                b = -2 * (d[..., 0] * cx + d[..., 1] * cy)
                c = cx * cx + cy * cy - r * r
                disc = b * b - 4 * a * c
                t = (-b - np.sqrt(disc)) / (2 * a)
                z = t * d[..., 2]
                ok = (disc > 0) & (t > 0) & (z >= z0) & (z <= z1)
                hit = ok & (t < tbest)
                tbest[hit] = t[hit]; lab[hit] = label
            elif kind == 'sph':
                cx, cy, cz, r = p
                C = np.array([cx, cy, cz])
                b = -2 * (d @ C)
                c = C @ C - r * r
                disc = b * b - 4 * c
                t = (-b - np.sqrt(disc)) / 2
                ok = (disc > 0) & (t > 0)
                hit = ok & (t < tbest)
                tbest[hit] = t[hit]; lab[hit] = label
    return tbest, lab


def scan(kind='vlp16', sigma=0.02, dropout=0.0, seed=0, invalid='nan', scene=None, W=None):
    """Returns points (H, W, 3) float32, labels (H, W) int32 (0 = no return)."""
    elev, W0 = beam_elevations(kind)
    W = W or W0
    d, E, A = ray_dirs(elev, W)
    t, lab = cast(d, scene or room_scene())
    rng = np.random.default_rng(seed)
    valid = np.isfinite(t) & (t < 120)
    t = t + rng.normal(0, sigma, t.shape)
    if dropout > 0:
        valid &= rng.random(t.shape) >= dropout
    P = (t[..., None] * d).astype(np.float32)
    if invalid == 'nan':
        P[~valid] = np.nan
    else:
        P[~valid] = 0.0
    lab[~valid] = 0
    return P, lab


def components(lab, wrap=True):
    """Split each surface label into grid-connected parts (8-neighbours; columns wrap at the
    azimuth seam when wrap). Returns new labels (label*100 + part) ."""
    H, W = lab.shape
    out = np.zeros_like(lab)
    seen = np.zeros(lab.shape, bool)
    for v0 in range(H):
        for u0 in range(W):
            g = lab[v0, u0]
            if g == 0 or seen[v0, u0]:
                continue
            part = 1 + len(np.unique(out[(lab == g) & (out > 0)]))
            stack = [(v0, u0)]; seen[v0, u0] = True
            while stack:
                v, u = stack.pop()
                out[v, u] = g * 100 + part
                for dv in (-1, 0, 1):
                    for du in (-1, 0, 1):
                        vv, uu = v + dv, u + du
                        if vv < 0 or vv >= H: continue
                        if wrap: uu %= W
                        elif uu < 0 or uu >= W: continue
                        if not seen[vv, uu] and lab[vv, uu] == g:
                            seen[vv, uu] = True; stack.append((vv, uu))
    return out


def run(points):
    pipeline = rangeseg.Pipeline(preset="laser", model="auto")
    start = time.perf_counter()
    result = pipeline.process(points)
    return np.asarray(result.labels), 1000 * (time.perf_counter() - start)


def main():
    print("scan      sigma dropouts | grid: correct/over/missed/noise of regions, ms "
          "| rings: the same, ms")
    for kind in ["vlp16", "os64", "os64x2048"]:
        for sigma, dropout in [(0.01, 0.02), (0.02, 0.02), (0.03, 0.02), (0.02, 0.10)]:
            if kind == "os64x2048" and (sigma, dropout) != (0.02, 0.02):
                continue
            points, labels = scan(kind, sigma, dropout, 2)
            truth = components(labels)
            grid, grid_ms = run(points)
            valid = np.isfinite(points[..., 0])
            ring_labels, rings_ms = run(points[valid])
            rings = np.zeros(labels.shape, np.int32)
            rings[valid] = ring_labels

            def counts(machine):
                e = rangeseg.evaluate(truth, machine)
                return (f"{e['correct']}/{e['over']}/{e['missed']}/{e['noise']} of "
                        f"{e['gt_regions']}")

            print(f"{kind:9s} {sigma:.2f} {dropout:.2f} | {counts(grid)} {grid_ms:5.0f} | "
                  f"{counts(rings)} {rings_ms:5.0f}")


if __name__ == "__main__":
    main()
