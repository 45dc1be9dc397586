"""What the module says about input that would give wrong results without an error: points in
millimetres, depth under a wrong scale, results built from anything, config values of the wrong
type."""
import os
import struct
import tempfile
import unittest
import warnings
import zlib

import numpy as np

import rangeseg

FX, CX, CY = 525.0, 319.5, 239.5


def wall_points(depth=2.0, width=320, height=240):
    """A wall `depth` metres away, (H, W, 3) float32, seen by a camera of focal length FX / 2."""
    u, v = np.meshgrid(np.arange(float(width)), np.arange(float(height)))
    f, cx, cy = FX / 2, (width - 1) / 2, (height - 1) / 2
    z = np.full(u.shape, depth)
    return np.stack([(u - cx) / f * z, (v - cy) / f * z, z], axis=-1).astype(np.float32)


def warnings_of(call):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        result = call()
    return result, [str(w.message) for w in caught if issubclass(w.category, UserWarning)]


class InputChecks(unittest.TestCase):
    def test_points_in_millimetres_or_far_smaller_units_warn_once(self):
        pipeline = rangeseg.Pipeline(preset="kinect")
        _, said = warnings_of(lambda: pipeline.process(wall_points() * 1000))
        self.assertTrue(any("median distance from the sensor is 2170 m" in s for s in said), said)
        _, again = warnings_of(lambda: pipeline.process(wall_points() * 1000))
        self.assertFalse(any("median distance" in s for s in again), again)
        _, tiny = warnings_of(lambda: rangeseg.Pipeline().process(wall_points() * 1e-6))
        self.assertTrue(any("median distance from the sensor is 2.17e-06 m" in s for s in tiny), tiny)
        result, none = warnings_of(lambda: rangeseg.Pipeline().process(wall_points()))
        self.assertFalse(any("median distance" in s for s in none), none)
        self.assertEqual(len(result.segments), 1)

    def test_points_moved_far_from_the_origin_name_the_noise_model(self):
        # A wall 2 m from its camera, moved 30 m aside (a map's frame): the Kinect's sigma there
        # (1.7 m) is above a thirtieth of the wall's 3 m; a constant sigma (laser) is not.
        moved = wall_points() + np.array([30.0, 0.0, 0.0], dtype=np.float32)
        _, said = warnings_of(lambda: rangeseg.Pipeline(preset="kinect").process(moved))
        self.assertTrue(any("the noise model's sigma is" in s for s in said), said)
        _, laser = warnings_of(lambda: rangeseg.Pipeline(preset="laser").process(moved))
        self.assertFalse(any("noise model" in s for s in laser), laser)
        _, near = warnings_of(lambda: rangeseg.Pipeline(preset="kinect").process(wall_points()))
        self.assertFalse(any("noise model" in s for s in near), near)

    def test_float_depth_under_a_given_scale_is_checked_as_integer_depth_is(self):
        depth_mm = np.full((240, 320), 2000.0, dtype=np.float32)
        camera = dict(fx=FX / 2, fy=FX / 2, cx=159.5, cy=119.5)
        _, said = warnings_of(
            lambda: rangeseg.Pipeline().process_depth(depth_mm, depth_scale=1.0, **camera))
        self.assertTrue(any("the median depth is 2000" in s for s in said), said)
        _, fine = warnings_of(
            lambda: rangeseg.Pipeline().process_depth(depth_mm, depth_scale=0.001, **camera))
        self.assertFalse(any("median depth" in s for s in fine), fine)

    def test_a_result_is_built_only_from_what_process_makes(self):
        result = rangeseg.Pipeline().process(wall_points())
        fields = [result.width, result.height, result.organized, result.labels, result.points,
                  result.normals, result.raw_normals, result.curvature, result.segments,
                  result.times]
        self.assertEqual(rangeseg.Result(*fields).labels.shape, (240, 320))
        bad = list(fields)
        bad[3] = "hello"
        with self.assertRaisesRegex(ValueError, r"labels must be a int32 array of shape \(240, 320\)"):
            rangeseg.Result(*bad)
        bad = list(fields)
        bad[4] = result.points.astype(np.float64)
        with self.assertRaisesRegex(ValueError, "points must be a float32 array"):
            rangeseg.Result(*bad)
        bad = list(fields)
        bad[0] = -5
        with self.assertRaisesRegex(ValueError, "width -5"):
            rangeseg.Result(*bad)

    def test_config_values_of_the_wrong_type_say_what_the_key_takes(self):
        with self.assertRaisesRegex(ValueError, "key 'smooth' must be true or false, got \"yes\""):
            rangeseg.Pipeline(config={"smooth": "yes"})
        pipeline = rangeseg.Pipeline(config={"segmentation": {"min_region_size": 200.0}})
        self.assertEqual(pipeline.settings["segmentation"]["min_region_size"], 200)

    def test_fx_given_for_unorganized_points_says_it_is_not_used(self):
        wall = wall_points()
        _, said = warnings_of(lambda: rangeseg.Pipeline().process(wall.reshape(-1, 3), fx=300.0))
        self.assertTrue(any("fx is not used for unorganized points" in s for s in said), said)
        _, organized = warnings_of(lambda: rangeseg.Pipeline().process(wall, fx=FX / 2))
        self.assertFalse(any("fx is not used" in s for s in organized), organized)
        _, unknown = warnings_of(lambda: rangeseg.Pipeline().process(wall.reshape(-1, 3)))
        self.assertFalse(any("fx is not used" in s for s in unknown), unknown)

    def test_an_8_bit_png_read_as_depth_warns_and_a_16_bit_one_does_not(self):
        def write_png(path, bits, value):
            width, height = 8, 4
            sample = bytes([value]) if bits == 8 else struct.pack(">H", value)
            rows = b"".join(b"\x00" + sample * width for _ in range(height))

            def chunk(kind, data):
                return (struct.pack(">I", len(data)) + kind + data +
                        struct.pack(">I", zlib.crc32(kind + data)))

            header = struct.pack(">IIBBBBB", width, height, bits, 0, 0, 0, 0)
            with open(path, "wb") as f:
                f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) +
                        chunk(b"IDAT", zlib.compress(rows)) + chunk(b"IEND", b""))

        with tempfile.TemporaryDirectory() as folder:
            eight, sixteen = os.path.join(folder, "mask.png"), os.path.join(folder, "depth.png")
            write_png(eight, 8, 200)
            write_png(sixteen, 16, 2000)
            depth, said = warnings_of(lambda: rangeseg.read_depth_png(eight))
            self.assertTrue(any("mask.png: an 8-bit PNG" in s for s in said), said)
            self.assertEqual(int(depth[0, 0]), 200)
            depth, none = warnings_of(lambda: rangeseg.read_depth_png(sixteen))
            self.assertEqual(none, [])
            self.assertEqual(int(depth[3, 7]), 2000)


if __name__ == "__main__":
    unittest.main()
