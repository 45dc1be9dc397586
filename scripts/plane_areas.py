#!/usr/bin/env python3
"""Plane areas against ground truth on synthetic Kinect scenes.

For each seed, renders the scene with Kinect noise and without (`rangeseg synth`), segments the
noisy one (`rangeseg.Pipeline()`), and compares, for every plane segment that shares 80 % of its
pixels with one ground-truth plane both ways, two areas with the noise-free rendering's: the
sum of its mesh faces (`Segmenter.compute_areas`' definition, here the cells whose four corners
carry its label) and its polygon's (`area_m2` since 2026-12-07). Prints the median, mean
absolute and 90th-percentile relative errors.

    PYTHONPATH=build/python python3 scripts/plane_areas.py [boxes|mixed] [SEEDS]
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

import rangeseg

HERE = os.path.dirname(os.path.abspath(__file__))
CLI = os.path.join(HERE, "..", "build", "apps", "rangeseg", "rangeseg")


def cell_areas(points, keep):
    """Areas of the two triangles of every cell whose four corners `keep` marks [m^2]."""
    a, b, c, d = points[:-1, :-1], points[:-1, 1:], points[1:, :-1], points[1:, 1:]

    def tri(p, q, r):
        return 0.5 * np.linalg.norm(np.cross(q - p, r - p), axis=-1)

    area = tri(a, d, b) + tri(a, c, d)
    inside = keep[:-1, :-1] & keep[:-1, 1:] & keep[1:, :-1] & keep[1:, 1:]
    return float(np.nansum(area[inside]))


def main():
    scene = sys.argv[1] if len(sys.argv) > 1 else "boxes"
    seeds = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    faces_error, polygon_error = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(1, seeds + 1):
            clouds = {}
            for noise in ("none", "kinect"):
                out = os.path.join(tmp, f"{scene}{seed}_{noise}")
                subprocess.run([CLI, "synth", "--scene", scene, "--seed", str(seed), "--noise",
                                noise, "-o", out], check=True, capture_output=True)
                clouds[noise] = rangeseg.read_cloud(os.path.join(out, "cloud.pcd"))
            truth = clouds["none"].labels
            exact = clouds["none"].points.astype(np.float64)
            pipeline = rangeseg.Pipeline()
            result = pipeline.process(clouds["kinect"])
            # The faces' sum of the noisy mesh, as the segmenter gives it without polygons.
            faces = rangeseg.Pipeline(config={"polygons": False}).process(clouds["kinect"])
            assert np.array_equal(faces.labels, result.labels)
            for segment, plain in zip(result.segments, faces.segments):
                if segment["surface"]["type"] != "plane" or "polygon" not in segment:
                    continue
                mine = result.labels == segment["id"]
                ids, counts = np.unique(truth[mine], return_counts=True)
                label = ids[counts.argmax()]
                if label == 0 or counts.max() < 0.8 * mine.sum():
                    continue
                if counts.max() < 0.8 * (truth == label).sum():
                    continue
                reference = cell_areas(exact, truth == label)
                faces_error.append(plain["area_m2"] / reference - 1)
                polygon_error.append(segment["area_m2"] / reference - 1)
    for name, e in (("faces' sum", faces_error), ("polygon", polygon_error)):
        e = np.asarray(e)
        print(f"{scene} 1-{seeds}, {len(e)} planes, {name}: median {100 * np.median(e):+.1f} %, "
              f"mean |error| {100 * np.mean(abs(e)):.1f} %, "
              f"90th percentile |error| {100 * np.percentile(abs(e), 90):.1f} %")


if __name__ == "__main__":
    main()
