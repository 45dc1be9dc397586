"""Tests of the rangeseg Python module against analytic scenes, the command line and bad input.

Run by ctest (test `python_module`) with the built module on PYTHONPATH; RANGESEG_CLI names the
command-line tool, RANGESEG_DATA (or ../shared/data beside the sources) the sensor data.
"""

import json
import math
import multiprocessing
import os
import subprocess
import pathlib
import pickle
import re
import tempfile
import threading
import unittest
import warnings

import numpy as np

import rangeseg

SOURCE_DIR = os.environ.get("RANGESEG_SOURCE_DIR", os.path.join(os.path.dirname(__file__), "..", ".."))
DATA_DIR = os.environ.get("RANGESEG_DATA", os.path.join(SOURCE_DIR, "..", "shared", "data"))
KINECT_FRAME = os.path.join(DATA_DIR, "kinect", "grabber_frame0.pcd")

# A Kinect at 640 x 480, and the same camera at half the resolution.
FX, CX, CY = 525.0, 319.5, 239.5
HALF = dict(fx=FX / 2, fy=FX / 2, cx=159.5, cy=119.5)


def rays(width, height, fx, fy, cx, cy):
    """Viewing rays (H, W, 3) with z = 1."""
    u, v = np.meshgrid(np.arange(width, dtype=np.float64), np.arange(height, dtype=np.float64))
    return np.stack([(u - cx) / fx, (v - cy) / fy, np.ones_like(u)], axis=-1)


def plane_depth(normal, offset, width=320, height=240, **camera):
    """Depth z of the plane normal . x + offset = 0 along each pixel's ray (NaN behind)."""
    camera = camera or HALF
    d = rays(width, height, **camera)
    denom = d @ np.asarray(normal, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = -offset / denom
    z[~(z > 0)] = np.nan
    return z


def lidar_scan_of_a_cylinder_wall():
    """A spinning lidar's organized scan (16 beams, 2 deg apart; 360 columns round the sensor)
    of a cylinder wall 5 m away, (16, 360, 3): a grid that no pinhole camera explains."""
    elevation = np.radians(15.0 - 2.0 * np.arange(16))[:, None]
    azimuth = np.radians(np.arange(360.0))[None, :]
    r = 5.0 / np.cos(elevation) * np.ones_like(azimuth)
    return np.stack([r * np.cos(elevation) * np.cos(azimuth),
                     r * np.cos(elevation) * np.sin(azimuth),
                     r * np.sin(elevation) * np.ones_like(azimuth)], -1).astype(np.float32)


def kinect_sigma(z):
    return 0.0012 + 0.0019 * (z - 0.4) ** 2


def angle_deg(a, b):
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    c = abs(a @ b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return math.degrees(math.acos(min(1.0, c)))


def depth_to_points(z, fx, fy, cx, cy):
    return (rays(z.shape[1], z.shape[0], fx, fy, cx, cy) * z[..., None]).astype(np.float32)


class AnalyticScenes(unittest.TestCase):
    def test_tilted_plane_is_one_segment_with_the_true_plane(self):
        normal = np.array([0.2, -0.5, -1.0])
        normal /= np.linalg.norm(normal)
        z = plane_depth(normal, 1.5)
        result = rangeseg.Pipeline(preset="ideal").process_depth(z.astype(np.float32), **HALF)
        valid = np.isfinite(z)
        self.assertEqual(len(result.segments), 1)
        segment = result.segments[0]
        self.assertGreaterEqual((result.labels[valid] == 1).mean(), 0.99)
        self.assertLess(angle_deg(segment["normal"], normal), 0.05)
        self.assertAlmostEqual(segment["offset"], 1.5, delta=1e-4)
        self.assertEqual(segment["surface"]["type"], "plane")
        # The polygon's corners lie on the plane, and its area is that of the points' faces.
        outer = segment["polygon"]["loops"][0]
        self.assertFalse(outer["hole"])
        self.assertLess(np.abs(outer["points"] @ normal + 1.5).max(), 1e-4)
        self.assertAlmostEqual(segment["polygon"]["area_m2"], segment["area_m2"],
                               delta=0.02 * segment["area_m2"])

    def test_noisy_millimetre_depth_gives_the_plane_within_a_degree(self):
        normal = np.array([0.0, -0.6, -0.8])
        z = plane_depth(normal, 1.2)
        rng = np.random.default_rng(7)
        noisy = z + rng.normal(size=z.shape) * kinect_sigma(np.nan_to_num(z))
        depth_mm = np.where(np.isfinite(noisy), np.round(noisy * 1000), 0).astype(np.uint16)
        result = rangeseg.Pipeline(preset="kinect").process_depth(depth_mm, **HALF)
        self.assertEqual(len(result.segments), 1)
        self.assertLess(angle_deg(result.segments[0]["normal"], normal), 1.0)
        self.assertGreaterEqual((result.labels[depth_mm > 0] == 1).mean(), 0.97)

    def test_a_depth_step_gives_two_planes_that_score_as_correct(self):
        z = np.full((240, 320), 1.0)
        z[:, 160:] = 1.5
        truth = np.where(np.arange(320) < 160, 1, 2)[None, :].repeat(240, axis=0)
        result = rangeseg.Pipeline(preset="ideal").process_depth(z, **HALF)
        self.assertEqual(len(result.segments), 2)
        score = rangeseg.evaluate(truth, result.labels)
        self.assertEqual((score["gt_regions"], score["correct"], score["noise"]), (2, 2, 0))
        offsets = sorted(s["offset"] for s in result.segments)
        self.assertAlmostEqual(offsets[0], 1.0, delta=1e-4)
        self.assertAlmostEqual(offsets[1], 1.5, delta=1e-4)

    def test_tracked_planes_keep_their_ids_while_the_step_moves(self):
        pipeline = rangeseg.Pipeline(preset="ideal", track=True)
        self.assertTrue(pipeline.track)
        ids_of_depth = None
        for frame in range(4):
            z = np.full((240, 320), 1.0)
            z[:, 100 + 20 * frame:] = 1.5  # the step moves 20 px per frame
            result = pipeline.process_depth(z, **HALF)
            self.assertEqual(len(result.segments), 2)
            ids = {round(s["offset"], 3): s["track_id"] for s in result.segments}
            if ids_of_depth is not None:
                self.assertEqual(ids, ids_of_depth)
            ids_of_depth = ids
            self.assertGreater(result.times["tracking"], 0.0)
        pipeline.reset_tracks()
        again = pipeline.process_depth(z, **HALF)
        self.assertTrue(all(s["track_id"] > max(ids_of_depth.values()) for s in again.segments))
        untracked = rangeseg.Pipeline(preset="ideal").process_depth(z, **HALF)
        self.assertTrue(all("track_id" not in s for s in untracked.segments))

    def test_a_sphere_before_a_wall_is_found_with_its_radius(self):
        width, height = 320, 240
        d = rays(width, height, **HALF)
        d /= np.linalg.norm(d, axis=-1, keepdims=True)
        centre, radius = np.array([0.05, 0.0, 1.3]), 0.15
        b = d @ centre
        disc = b * b - (centre @ centre - radius * radius)
        hit = disc > 0
        t = np.where(hit, b - np.sqrt(np.where(hit, disc, 0)), np.inf)
        wall = 2.0 / d[..., 2]
        r = np.minimum(t, wall)
        points = (d * r[..., None]).astype(np.float32)
        result = rangeseg.Pipeline(preset="ideal", model="auto").process(points)
        spheres = [s for s in result.segments if s["surface"]["type"] == "sphere"]
        self.assertEqual(len(spheres), 1, [s["surface"]["type"] for s in result.segments])
        found = spheres[0]["surface"]
        self.assertAlmostEqual(found["radius"], radius, delta=0.01 * radius)
        self.assertLess(np.linalg.norm(np.asarray(found["centre"]) - centre), 0.005)
        # Nearly every pixel that sees the sphere is in its segment.
        label = spheres[0]["id"]
        self.assertGreaterEqual((result.labels[hit] == label).mean(), 0.95)


class Inputs(unittest.TestCase):
    def step_points(self):
        z = np.full((240, 320), 1.0)
        z[:, 160:] = 1.4
        z[100:140, 40:80] = np.nan  # a hole
        return depth_to_points(z, **HALF)

    def test_unorganized_points_in_any_order_get_the_labels_of_their_pixels(self):
        points = self.step_points()
        organized = rangeseg.Pipeline(preset="ideal").process(points)
        valid = np.isfinite(points[..., 2])
        flat = points[valid]
        order = np.random.default_rng(3).permutation(len(flat))
        result = rangeseg.Pipeline(preset="ideal").process(flat[order])
        self.assertFalse(result.organized)
        self.assertEqual(result.labels.shape, (len(flat),))
        self.assertEqual(result.points.shape, (len(flat), 3))
        back = np.empty_like(result.labels)
        back[order] = result.labels
        np.testing.assert_array_equal(back, organized.labels[valid])
        # Put back on their pixel grid, they ran the grid's stages; off it, over rings, whose
        # times are named as the command line names them.
        self.assertIn("mesh", result.times)
        self.assertIn("order", result.times)  # the moves onto the grid and back
        self.assertNotIn("input", result.times)
        jittered = flat + np.random.default_rng(4).normal(0.0, 1e-3, flat.shape)
        over_rings = rangeseg.Pipeline(preset="ideal").process(jittered).times
        self.assertIn("rings", over_rings)
        self.assertIn("order", over_rings)
        self.assertNotIn("mesh", over_rings)
        self.assertNotIn("input", over_rings)

    def test_float64_lists_and_clouds_give_the_float32_result(self):
        points = self.step_points()
        pipeline = rangeseg.Pipeline(preset="ideal")
        want = pipeline.process(points).labels
        np.testing.assert_array_equal(pipeline.process(points.astype(np.float64)).labels, want)
        np.testing.assert_array_equal(pipeline.process(rangeseg.Cloud(points)).labels, want)
        small = points[:4, :5]
        np.testing.assert_array_equal(pipeline.process(small.tolist()).points, pipeline.process(small).points)

    def test_results_are_copies_that_outlive_the_next_frame(self):
        pipeline = rangeseg.Pipeline(preset="ideal")
        first = pipeline.process(self.step_points())
        labels = first.labels.copy()
        pipeline.process_depth(np.full((240, 320), 2.0), **HALF)
        np.testing.assert_array_equal(first.labels, labels)
        self.assertEqual(len(first.segments), 2)

    def test_a_frame_keeps_nothing_of_the_frame_before(self):
        # NumPy points go into a buffer the pipeline keeps: a frame with intensity, another size
        # or an unorganized cloud before must not change the next frame's result.
        points = self.step_points()
        want = rangeseg.Pipeline(preset="kinect").process(points)
        pipeline = rangeseg.Pipeline(preset="kinect")
        pipeline.process(points, intensity=np.random.default_rng(1).random(points.shape[:2]))
        pipeline.process(points[:100, :50])
        pipeline.process(points[np.isfinite(points[..., 2])][:5000])
        got = pipeline.process(points)
        np.testing.assert_array_equal(got.labels, want.labels)
        np.testing.assert_array_equal(got.points, want.points)

    def test_python_threads_may_share_a_pipeline(self):
        pipeline = rangeseg.Pipeline(preset="ideal")
        scenes = [self.step_points(), depth_to_points(np.full((240, 320), 1.2), **HALF)]
        want = [pipeline.process(s).labels.max() for s in scenes]
        got = {}

        def work(i):
            got[i] = [pipeline.process(scenes[(i + k) % 2]).labels.max() for k in range(4)]

        threads = [threading.Thread(target=work, args=(i,), daemon=True) for i in range(2)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(timeout=120)
        self.assertFalse(any(t.is_alive() for t in threads), "threads sharing a pipeline hang")
        for i in range(2):
            self.assertEqual(got[i], [want[(i + k) % 2] for k in range(4)])

    def test_inf_is_no_point_as_nan_is(self):
        points = self.step_points()
        gaps = (np.arange(320) % 7 == 0)[None, :, None]
        pipeline = rangeseg.Pipeline(preset="kinect")
        with_nan = pipeline.process(np.where(gaps, np.nan, points))
        with_inf = pipeline.process(np.where(gaps, np.inf, points))
        np.testing.assert_array_equal(with_inf.labels, with_nan.labels)
        self.assertFalse(np.isinf(with_inf.points).any())

    def test_depth_of_any_integer_dtype_gives_the_uint16_result(self):
        z = plane_depth([0.1, -0.6, -0.8], 1.3)
        depth = np.where(np.isfinite(z), np.round(z * 1000), 0).astype(np.uint16)
        pipeline = rangeseg.Pipeline(preset="kinect")
        want = pipeline.process_depth(depth, **HALF)
        for other in (depth.astype(np.int32), depth.astype(">u2"), depth.astype(np.uint32)):
            got = pipeline.process_depth(other, **HALF)
            np.testing.assert_array_equal(got.labels, want.labels)
            np.testing.assert_array_equal(got.points, want.points)
        camera = dict(HALF, width=320, height=240)  # as read_camera_json gives it
        np.testing.assert_array_equal(pipeline.process_depth(depth, **camera).labels, want.labels)
        with self.assertRaisesRegex(ValueError, "640"):
            pipeline.process_depth(depth, **dict(HALF, width=640))

    def test_two_threads_give_the_one_thread_result(self):
        z = plane_depth([0.1, -0.7, -0.7], 1.0, 640, 480, fx=FX, fy=FX, cx=CX, cy=CY)
        z[:, 300:] = np.minimum(z[:, 300:], 1.3)
        one = rangeseg.Pipeline(preset="ideal").process_depth(z, fx=FX, fy=FX, cx=CX, cy=CY)
        two = rangeseg.Pipeline(preset="ideal", threads=2).process_depth(z, fx=FX, fy=FX, cx=CX, cy=CY)
        self.assertEqual(two.labels.max(), one.labels.max())
        np.testing.assert_array_equal(two.labels, one.labels)
        np.testing.assert_array_equal(two.normals, one.normals)

    def test_more_threads_than_cores_are_named(self):
        cores = len(os.sched_getaffinity(0))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            rangeseg.Pipeline(threads=min(cores, 256))
        if cores < 256:
            with self.assertWarnsRegex(UserWarning, f"threads={cores + 1} on {cores} cores"):
                rangeseg.Pipeline(threads=cores + 1)

    def test_colours_as_open3d_floats_equal_uint8_colours(self):
        points = self.step_points()
        rgb = (np.indices(points.shape[:2]).sum(axis=0) % 256).astype(np.uint8)
        colors = np.repeat(rgb[..., None], 3, axis=-1)
        pipeline = rangeseg.Pipeline(preset="kinect")
        a = pipeline.process(points, colors=colors)
        b = pipeline.process(points, colors=colors / 255.0)
        np.testing.assert_array_equal(a.points, b.points)

    def test_config_dict_and_file_set_the_same_settings(self):
        points = self.step_points()
        # The left face of the step has 160 x 240 - 1600 = 36800 points, the right one 38400;
        # min_region_fx 0 counts them in this grid's own pixels, whatever its camera.
        config = {"segmentation": {"min_region_size": 37500, "min_region_fx": 0}}
        from_dict = rangeseg.Pipeline(preset="ideal", config=config).process(points)
        self.assertEqual([s["pixel_count"] for s in from_dict.segments], [160 * 240])
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "params.json")
            with open(path, "w") as f:
                json.dump(config, f)
            from_file = rangeseg.Pipeline(preset="ideal", config=path).process(points)
        np.testing.assert_array_equal(from_file.labels, from_dict.labels)

    def test_read_cloud_reads_what_it_is_given(self):
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "small.pcd")
            with open(path, "w") as f:
                f.write("VERSION .7\nFIELDS x y z rgb label\nSIZE 4 4 4 4 4\nTYPE F F F U U\n"
                        "COUNT 1 1 1 1 1\nWIDTH 2\nHEIGHT 2\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 4\n"
                        "DATA ascii\n0 0 1 16711680 3\n0.1 0 1 65280 3\nnan nan nan 0 0\n0.1 0.1 1.5 255 7\n")
            cloud = rangeseg.read_cloud(pathlib.Path(path))
        self.assertTrue(cloud.is_organized)
        self.assertEqual((cloud.width, cloud.height, cloud.count_valid()), (2, 2, 3))
        self.assertEqual(cloud.points.shape, (2, 2, 3))
        np.testing.assert_array_equal(cloud.colors[0, 0], [255, 0, 0])
        np.testing.assert_array_equal(cloud.colors[1, 1], [0, 0, 255])
        np.testing.assert_array_equal(cloud.labels, [[3, 3], [0, 7]])
        self.assertTrue(np.isnan(cloud.points[1, 0]).all())
        self.assertIsNone(cloud.intensity)


    def test_read_camera_takes_ros_camera_info_and_warns_of_distortion(self):
        z = plane_depth([0.1, -0.6, -0.8], 1.4)
        depth = np.nan_to_num(z * 1000).astype(np.uint16)
        k = [HALF["fx"], 0, HALF["cx"], 0, HALF["fy"], HALF["cy"], 0, 0, 1]
        with tempfile.TemporaryDirectory() as tmp:
            info = os.path.join(tmp, "info.yaml")
            with open(info, "w") as f:
                f.write("height: 240\nwidth: 320\ndistortion_model: plumb_bob\n"
                        "d: [0.0, 0.0, 0.0, 0.0, 0.0]\nk: %s\n---\n" % k)
            distorted = os.path.join(tmp, "ost.yaml")
            with open(distorted, "w") as f:
                f.write("image_width: 320\nimage_height: 240\ncamera_matrix: {rows: 3, cols: 3, "
                        "data: %s}\ndistortion_model: plumb_bob\n"
                        "distortion_coefficients: {data: [0.1, 0, 0, 0, 0]}\n" % k)
            camera = rangeseg.read_camera(info)
            with self.assertWarnsRegex(UserWarning, "plumb_bob"):
                self.assertEqual(rangeseg.read_camera(distorted), camera)
        self.assertEqual(camera, dict(HALF, width=320, height=240))
        pipeline = rangeseg.Pipeline()
        np.testing.assert_array_equal(pipeline.process_depth(depth, **camera).labels,
                                      pipeline.process_depth(depth, **HALF).labels)

    def test_clouds_results_and_pipelines_pickle(self):
        points = self.step_points()
        colors = (np.indices(points.shape[:2]).sum(axis=0) % 256).astype(np.uint8)
        colors = np.repeat(colors[..., None], 3, axis=-1)
        labels = (points[..., 2] > 1.2).astype(np.int32)
        for cloud in (rangeseg.Cloud(points, colors=colors, labels=labels),
                      rangeseg.Cloud(points[np.isfinite(points[..., 2])])):
            back = pickle.loads(pickle.dumps(cloud))
            self.assertEqual((back.width, back.height), (cloud.width, cloud.height))
            np.testing.assert_array_equal(back.points, cloud.points)
            for name in ("intensity", "colors", "labels"):
                if getattr(cloud, name) is None:
                    self.assertIsNone(getattr(back, name))
                else:
                    np.testing.assert_array_equal(getattr(back, name), getattr(cloud, name))
        pipeline = rangeseg.Pipeline(preset="ideal", model="auto", threads=2,
                                     config={"segmentation": {"min_region_size": 300}})
        copy = pickle.loads(pickle.dumps(pipeline))
        self.assertEqual(copy.settings, pipeline.settings)
        self.assertEqual((copy.model, copy.smooth, copy.threads), ("auto", False, 2))
        result = pipeline.process(points)
        back = pickle.loads(pickle.dumps(result))
        np.testing.assert_array_equal(back.labels, result.labels)
        np.testing.assert_array_equal(back.normals, result.normals)
        self.assertEqual([s["pixel_count"] for s in back.segments],
                         [s["pixel_count"] for s in result.segments])
        self.assertEqual((back.width, back.height, back.organized), (320, 240, True))
        # The copy segments as the original does, here in another process.
        with multiprocessing.get_context("spawn").Pool(1) as pool:
            remote = pool.apply(copy.process, (points,))
        np.testing.assert_array_equal(remote.labels, result.labels)
        # Every pickle protocol, the old text ones too.
        for protocol in range(pickle.HIGHEST_PROTOCOL + 1):
            for obj in (rangeseg.Cloud(points), result, pipeline):
                self.assertEqual(type(pickle.loads(pickle.dumps(obj, protocol))), type(obj))

class BadInput(unittest.TestCase):
    def assert_raises_with(self, error, text, call, *args, **kwargs):
        with self.assertRaises(error) as caught:
            call(*args, **kwargs)
        self.assertIn(text, str(caught.exception))

    def test_arrays_of_the_wrong_shape_or_type_are_value_errors_naming_them(self):
        p = rangeseg.Pipeline()
        self.assert_raises_with(ValueError, "(H, W, 3)", p.process, np.zeros((10, 4)))
        self.assert_raises_with(ValueError, "got (5,)", p.process, np.zeros(5))
        self.assert_raises_with(ValueError, "dtype", p.process, np.array([["a", "b", "c"]]))
        self.assert_raises_with(ValueError, "points", p.process, np.zeros((0, 3)))
        points = np.ones((4, 5, 3), dtype=np.float32)
        self.assert_raises_with(ValueError, "intensity must have the points' shape (4, 5)", p.process,
                                points, intensity=np.ones((5, 4)))
        self.assert_raises_with(ValueError, "colors must be uint8 0..255 or floats 0..1", p.process,
                                points, colors=np.full((4, 5, 3), 300))
        self.assert_raises_with(ValueError, "depth must be a 2D array", p.process_depth,
                                np.ones((2, 2, 2)), **HALF)
        self.assert_raises_with(ValueError, "got shape (1, 640)", p.process_depth, np.ones((1, 640)), **HALF)
        self.assert_raises_with(ValueError, "got shape (480, 0)", p.process_depth,
                                np.ones((480, 0), np.uint16), **HALF)
        self.assert_raises_with(ValueError, "depth must be an array of real numbers, got str",
                                p.process_depth, "depth.png", **HALF)
        self.assert_raises_with(ValueError, "need at least 2 rows", p.process, np.ones((1, 5, 3)))
        self.assert_raises_with(ValueError, "depth_scale", p.process_depth, np.ones((4, 4), np.uint16),
                                depth_scale=-1, **HALF)
        self.assert_raises_with(ValueError, "ground_truth must be integers", rangeseg.evaluate,
                                np.zeros((2, 2)), np.zeros((2, 2), int))
        self.assert_raises_with(ValueError, "shape (3, 2) but ground_truth (2, 2)", rangeseg.evaluate,
                                np.zeros((2, 2), int), np.zeros((3, 2), int))
        # uint64 beyond 2^63 would wrap to negative int64 values if cast before the check.
        huge = np.full((4, 5), 2**64 - 1, np.uint64)
        self.assert_raises_with(ValueError, "labels must fit in 32-bit integers", rangeseg.Cloud,
                                points, labels=huge)
        self.assert_raises_with(ValueError, "ground_truth must fit in 32-bit integers", rangeseg.evaluate,
                                huge, np.zeros((4, 5), np.int32))
        self.assert_raises_with(ValueError, "fx must be >= 0 pixels and finite", p.process, points,
                                fx=float("nan"))
        self.assert_raises_with(ValueError, "got -1", p.process, rangeseg.Cloud(points), fx=-1)

    def test_float_millimetres_without_a_scale_warn(self):
        z = np.full((24, 32), 1500.0)  # millimetres, taken as metres
        p = rangeseg.Pipeline()
        with self.assertWarnsRegex(UserWarning, "depth_scale=0.001"):
            p.process_depth(z, fx=26.25, fy=26.25, cx=15.5, cy=11.5)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            # 5.7 cm pixels at 1.5 m: a mesh without faces (test_a_frame_without_segments_says_why)
            warnings.filterwarnings("ignore", "no segments")
            p.process_depth(z / 1000, fx=26.25, fy=26.25, cx=15.5, cy=11.5)  # metres
            result = p.process_depth(z, fx=26.25, fy=26.25, cx=15.5, cy=11.5, depth_scale=0.001)
        self.assertEqual(repr(result), "<rangeseg.Result (24, 32): %d segments>" % len(result.segments))

    def test_a_depth_image_given_as_labels_warns(self):
        depth = np.nan_to_num(plane_depth([0.1, -0.6, -0.8], 1.4) * 1000).astype(np.int32)
        labels = (depth > np.median(depth)).astype(np.int32) + 1
        with self.assertWarnsRegex(UserWarning, "segmentation: its [0-9]+ labels, none below"):
            scores = rangeseg.evaluate(labels, depth)
        self.assertEqual(scores["correct"], 0)
        with warnings.catch_warnings():
            warnings.simplefilter("error")  # labels numbered from 1001 are labels
            self.assertEqual(rangeseg.evaluate(labels, labels + 1000)["correct"], 2)

    def test_a_scanners_grid_with_the_default_preset_warns_once(self):
        # A spinning lidar's organized scan (16 beams, 2 deg apart; 360 columns round the
        # sensor) of a cylinder wall: no pinhole camera explains that grid.
        scan = lidar_scan_of_a_cylinder_wall()
        for preset in (None, "auto"):
            p = rangeseg.Pipeline(preset=preset) if preset else rangeseg.Pipeline()
            with self.assertWarnsRegex(UserWarning, 'no pinhole camera explains this grid.*"laser"'):
                p.process(scan)
            with warnings.catch_warnings():
                warnings.simplefilter("error")
                p.process(scan)  # once per pipeline
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            rangeseg.Pipeline(preset="laser").process(scan)
            rangeseg.Pipeline(preset="kinect").process(scan)  # chosen: no warning
            rangeseg.Pipeline().process(scan, fx=57.3)  # a camera given
            # A depth camera's grid.
            points = rays(320, 240, **HALF) * plane_depth([0.1, -0.6, -0.8], 1.4)[..., None]
            rangeseg.Pipeline().process(points.astype(np.float32))

    def test_the_default_preset_takes_laser_for_an_unorganized_scan_round_its_sensor(self):
        # The lidar scan of a cylinder wall round the sensor as (N, 3) points, as the command
        # line's --preset auto takes it; a camera's points (a cone) keep kinect.
        scan = lidar_scan_of_a_cylinder_wall()
        points = scan.reshape(-1, 3)
        small = dict(fx=FX / 16, fy=FX / 16, cx=19.5, cy=14.5)  # 40 x 30
        camera_points = rays(40, 30, **small) * plane_depth([0.1, -0.6, -0.8], 1.4, 40, 30,
                                                            **small)[..., None]
        camera_points = camera_points.reshape(-1, 3).astype(np.float32)
        laser = rangeseg.Pipeline(preset="laser", model="auto").settings
        kinect = rangeseg.Pipeline(preset="kinect", model="auto").settings
        self.assertNotEqual(laser, kinect)
        for preset in (None, "auto"):
            p = rangeseg.Pipeline(preset=preset, model="auto")
            self.assertEqual(p.settings, kinect)  # until the first frame
            copy = pickle.loads(pickle.dumps(p))  # undecided too
            p.process(points)
            self.assertEqual(p.settings, laser)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                p.process(camera_points)  # decided once, on the first frame
            self.assertEqual(p.settings, laser)
            copy.process(points)
            self.assertEqual(copy.settings, laser)
            self.assertEqual(pickle.loads(pickle.dumps(p)).settings, laser)
            camera = rangeseg.Pipeline(preset=preset, model="auto")
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # a 40 x 30 camera's pixels: few faces
                camera.process(camera_points)
            self.assertEqual(camera.settings, kinect)
            camera.process(points)
            self.assertEqual(camera.settings, kinect)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                grid = rangeseg.Pipeline(preset=preset, model="auto")
                grid.process(scan)  # an organized scan: kinect, with the warning
            self.assertEqual(grid.settings, kinect)
        chosen = rangeseg.Pipeline(preset="kinect", model="auto")
        chosen.process(points)
        self.assertEqual(chosen.settings, kinect)
        # An undecided copy keeps the settings the original was made with, whatever happens to
        # its config afterwards.
        config = {"segmentation": {"min_region_size": 77}}
        p = rangeseg.Pipeline(config=config)
        config["segmentation"]["min_region_size"] = 5
        copy = pickle.loads(pickle.dumps(p))
        self.assertEqual(copy.settings, p.settings)
        copy.process(points)
        self.assertEqual(copy.settings["segmentation"]["min_region_size"], 77)
        self.assertEqual(copy.settings["noise"], laser["noise"])
        # Decided on laser, its grids need no word about the preset.
        p = rangeseg.Pipeline()
        p.process(points)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            p.process(scan)

    def test_a_frame_without_segments_says_why(self):
        # A plane at 1.2-2 m seen by a Kinect at 320 x 240, every other row empty: no mesh face.
        points = rays(320, 240, **HALF) * plane_depth([0.1, -0.6, -0.8], 1.4)[..., None]
        points = points.astype(np.float32)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            self.assertGreater(len(rangeseg.Pipeline().process(points).segments), 0)
        rows = points.copy()
        rows[1::2] = np.nan
        p = rangeseg.Pipeline()
        with self.assertWarnsRegex(UserWarning, r"no segments: the mesh joins hardly any.*every "
                                   r'2nd row from row 0: .*points\[0::2, 0::1\].*"pixel_stride": 2'):
            self.assertEqual(len(p.process(rows).segments), 0)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            p.process(rows)  # once per pipeline
            # The hint's setting joins them.
            every_other = rangeseg.Pipeline(config={"mesh": {"pixel_stride": 2}})
            self.assertGreater(len(every_other.process(rows).segments), 0)
        # A 32 x 24 camera (fx 26 px): its pixels' rays lie 1 / 26 rad apart (1.4 / 26 across the
        # diagonal), beyond the edge bound; the value the warning proposes joins them.
        z = np.full((24, 32), 1500, np.uint16)
        coarse = dict(fx=26.25, fy=26.25, cx=15.5, cy=11.5)
        with self.assertWarnsRegex(UserWarning, r"rays lie 0\.048\d* rad apart.*0\.07\d* m at the "
                                   r"median range of 1\.6\d* m.*edge bound there, 0\.046\d* m.*"
                                   r"max_edge_b .* to about") as caught:
            rangeseg.Pipeline().process_depth(z, **coarse)
        b = float(re.search(r"to about ([0-9.]+)", str(caught.warning)).group(1))
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            raised = rangeseg.Pipeline(config={"mesh": {"max_edge_b": b}})
            self.assertEqual(len(raised.process_depth(z, **coarse).segments), 1)
        with self.assertWarnsRegex(UserWarning, "no segments: the cloud has no point"):
            rangeseg.Pipeline().process(np.full((10, 10, 3), np.nan, np.float32))

    def test_an_implausible_integer_depth_scale_warns(self):
        z = np.full((24, 32), 1500, np.uint16)  # millimetres
        p = rangeseg.Pipeline()
        camera = dict(fx=26.25, fy=26.25, cx=15.5, cy=11.5)
        for scale in (1.0, 1e-6):  # metres per unit, micrometres: 1500 m, 1.5 mm
            with self.assertWarnsRegex(UserWarning, "is the scale right"):
                p.process_depth(z, depth_scale=scale, **camera)
        with warnings.catch_warnings():
            warnings.simplefilter("error")
            warnings.filterwarnings("ignore", "no segments")  # 5.7 cm pixels at 1.5 m
            p.process_depth(z, **camera)  # the default 0.001
            p.process_depth(z, depth_scale=0.0001, **camera)  # a RealSense's 0.1 mm: 0.15 m

    def test_huge_integer_depths_are_far_points_not_a_cast_error(self):
        z = np.full((24, 32), 1500, np.uint64)
        z[:, 16:] = 2**64 - 1  # no uint16, no int64: the raw-units path, not a failed cast
        result = rangeseg.Pipeline().process_depth(z, fx=26.25, fy=26.25, cx=15.5, cy=11.5)
        self.assertAlmostEqual(float(np.nanmin(result.points[:, :16, 2])), 1.5, places=2)

    def test_an_array_like_that_runs_the_pipeline_while_read_does_not_deadlock(self):
        p = rangeseg.Pipeline()
        points = Inputs.step_points(None)

        class Reentrant:
            def __array__(self, dtype=None, copy=None):
                p.process(points)  # NumPy reads the argument before the pipeline is locked
                return points

        self.assertEqual(len(p.process(Reentrant()).segments), len(p.process(points).segments))

    def test_bad_settings_name_the_setting(self):
        self.assert_raises_with(ValueError, "valid", rangeseg.Pipeline, preset="kinnect")
        self.assert_raises_with(ValueError, "unknown model 'planes'", rangeseg.Pipeline, model="planes")
        self.assert_raises_with(ValueError, "threads", rangeseg.Pipeline, threads=0)
        self.assert_raises_with(ValueError, "unknown key 'min_region'", rangeseg.Pipeline,
                                config={"segmentation": {"min_region": 3}})
        self.assert_raises_with(ValueError, "key 'min_region_size' = -3 is invalid", rangeseg.Pipeline,
                                config={"segmentation": {"min_region_size": np.int64(-3)}})
        self.assert_raises_with(ValueError, "key 'segmentation.max_normal_angle' must be a finite", rangeseg.Pipeline,
                                config={"segmentation": {"max_normal_angle": float("nan")}})
        self.assert_raises_with(ValueError, "key 'tracking.min_overlap' must be a finite", rangeseg.Pipeline,
                                config={"tracking": {"min_overlap": np.float32("inf")}})
        self.assert_raises_with(ValueError, "a dict or the path", rangeseg.Pipeline, config=3)
        self.assert_raises_with(ValueError, "config: values must be numbers", rangeseg.Pipeline,
                                config={"segmentation": {"min_region_size": {1}}})
        self.assert_raises_with(ValueError, "threads must be 1..256, got 0", rangeseg.Pipeline, threads=0)
        # A file's errors name the file.
        with tempfile.TemporaryDirectory() as tmp:
            path = os.path.join(tmp, "params.json")
            with open(path, "w") as f:
                f.write('{"mesh": {"typ": "quad"}}')
            self.assert_raises_with(RuntimeError, path + " [mesh]: unknown key 'typ'", rangeseg.Pipeline,
                                    config=path)

    def test_settings_show_every_key_and_feed_back_as_config(self):
        pipeline = rangeseg.Pipeline(preset="abw", model="auto")
        settings = pipeline.settings
        self.assertEqual(settings["segmentation"]["model"], "auto")
        self.assertFalse(settings["smooth"])
        self.assertAlmostEqual(settings["mesh"]["eps_theta"], 0.2182)
        self.assertEqual(rangeseg.Pipeline(preset="kinect", config=settings).settings, settings)
        self.assertIn("model='auto'", repr(pipeline))

    def test_keywords_win_over_the_config(self):
        config = {"smooth": False, "segmentation": {"model": "auto", "min_region_size": 50}}
        pipeline = rangeseg.Pipeline(model="plane", smooth=True, config=config)
        self.assertEqual((pipeline.model, pipeline.smooth), ("plane", True))
        self.assertEqual(rangeseg.Pipeline(config=config).model, "auto")
        self.assertFalse(rangeseg.Pipeline(track=False, config={"track": True}).track)
        self.assertTrue(rangeseg.Pipeline(config={"track": True}).track)

    def test_unreadable_files_are_runtime_errors_naming_the_file(self):
        with tempfile.TemporaryDirectory() as tmp:
            missing = os.path.join(tmp, "missing.pcd")
            self.assert_raises_with(RuntimeError, missing, rangeseg.read_cloud, missing)
            truncated = os.path.join(tmp, "truncated.pcd")
            with open(truncated, "w") as f:
                f.write("VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 4\n"
                        "HEIGHT 4\nPOINTS 16\nDATA binary\n\0\0")
            self.assert_raises_with(RuntimeError, truncated, rangeseg.read_cloud, truncated)
            self.assert_raises_with(RuntimeError, "unknown.txt", rangeseg.read_cloud,
                                    os.path.join(tmp, "unknown.txt"))
            self.assert_raises_with(RuntimeError, missing, rangeseg.Pipeline, config=missing)


@unittest.skipUnless(os.path.exists(KINECT_FRAME), f"shared data not found: {KINECT_FRAME} "
                     "(set RANGESEG_DATA or put ../shared/data beside the repository)")
class KinectFrame(unittest.TestCase):
    @unittest.skipUnless(os.environ.get("RANGESEG_CLI"), "RANGESEG_CLI is not set")
    def test_the_module_gives_the_command_lines_segmentation(self):
        result = rangeseg.Pipeline(preset="kinect").process(rangeseg.read_cloud(KINECT_FRAME))
        with tempfile.TemporaryDirectory() as tmp:
            subprocess.run([os.environ["RANGESEG_CLI"], "segment", KINECT_FRAME, "-o", tmp,
                            "--preset", "kinect", "--no-mesh"], check=True, capture_output=True)
            labels = rangeseg.read_label_png(os.path.join(tmp, "labels.png"))
            with open(os.path.join(tmp, "segments.json")) as f:
                segments = json.load(f)["segments"]
        np.testing.assert_array_equal(result.labels, labels)
        self.assertEqual([s["pixel_count"] for s in result.segments],
                         [s["pixel_count"] for s in segments])
        for mine, theirs in zip(result.segments, segments):
            self.assertAlmostEqual(mine["offset"], theirs["offset"], places=9)
            if "polygon" in theirs:
                self.assertAlmostEqual(mine["polygon"]["area_m2"], theirs["polygon"]["area_m2"], places=9)

    def test_zeros_for_missing_points_are_no_points(self):
        # RealSense's SDK writes (0, 0, 0) for a pixel without depth; flattened to (N, 3), such
        # a frame must still be put back on its pixel grid, as one with NaN is (before, it ran
        # over k-nearest-neighbour rings: 22 segments instead of 11).
        points = rangeseg.read_cloud(KINECT_FRAME).points
        pipeline = rangeseg.Pipeline(preset="kinect", smooth=False)
        with_nan = pipeline.process(points.reshape(-1, 3))
        with_zeros = pipeline.process(np.nan_to_num(points).reshape(-1, 3))
        np.testing.assert_array_equal(with_zeros.labels, with_nan.labels)
        organized = pipeline.process(np.nan_to_num(points))
        np.testing.assert_array_equal(organized.labels, pipeline.process(points).labels)

    def test_the_floor_is_one_plane_and_the_timings_add_up(self):
        result = rangeseg.Pipeline().process(rangeseg.read_cloud(KINECT_FRAME))
        largest = result.segments[0]
        self.assertEqual(largest["surface"]["type"], "plane")
        self.assertGreater(largest["pixel_count"], 100000)
        self.assertEqual(largest["plane_group"], largest["id"])  # the largest of its group
        t = result.times
        stages = t["input"] + t["mesh"] + t["normals"] + t["smoothing"] + t["segmentation"] + t["polygons"]
        self.assertLessEqual(stages, t["total"] * 1.001)
        self.assertEqual(result.curvature.shape, (480, 640))


class Examples(unittest.TestCase):
    def test_the_example_runs(self):
        example = os.path.join(SOURCE_DIR, "examples", "segment_frame.py")
        out = subprocess.run([os.sys.executable, example], check=True, capture_output=True, text=True).stdout
        self.assertIn("segments", out)


if __name__ == "__main__":
    unittest.main()
