// Camera files as ROS writes them (camera_info YAML) and the dispatch by file name.
#include <gtest/gtest.h>

#include <string>

#include "rangeseg/io/camera_file.hpp"
#include "rangeseg/io/camera_json.hpp"
#include "rangeseg/io/file.hpp"
#include "test_util.hpp"

using namespace rangeseg;
using rangeseg::test::expect_runtime_error_with;

namespace {

// `ros2 topic echo --once /camera/depth/camera_info` of a RealSense D435 (values shortened);
// cx and cy differ from fx and fy so that a row/column mix-up shows.
const char* const kRos2Message = R"(header:
  stamp:
    sec: 1700000000
    nanosec: 5
  frame_id: camera_depth_optical_frame
height: 480
width: 640
distortion_model: plumb_bob
d:
- 0.0
- 0.0
- 0.0
- 0.0
- 0.0
k:
- 383.5
- 0.0
- 321.25
- 0.0
- 384.0
- 238.75
- 0.0
- 0.0
- 1.0
r: [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
p: [383.5, 0.0, 321.25, 0.0, 0.0, 384.0, 238.75, 0.0, 0.0, 0.0, 1.0, 0.0]
binning_x: 0
binning_y: 0
roi:
  x_offset: 0
  y_offset: 0
  height: 0
  width: 0
  do_rectify: false
---
)";

// camera_calibration's ost.yaml.
const char* const kCalibrationFile = R"(image_width: 640
image_height: 480
camera_name: depth
camera_matrix:
  rows: 3
  cols: 3
  data: [570.3, 0, 314.5, 0, 571.1, 235.5, 0, 0, 1]
distortion_model: plumb_bob
distortion_coefficients:
  rows: 1
  cols: 5
  data: [0.051, -0.12, 0.0, 0.0, 0.0]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
)";

void expect_camera(const CameraIntrinsics& read, const CameraIntrinsics& expected) {
  EXPECT_EQ(read.fx, expected.fx);
  EXPECT_EQ(read.fy, expected.fy);
  EXPECT_EQ(read.cx, expected.cx);
  EXPECT_EQ(read.cy, expected.cy);
  EXPECT_EQ(read.width, expected.width);
  EXPECT_EQ(read.height, expected.height);
}

}  // namespace

TEST(CameraYaml, Ros2MessageAsEchoed) {
  const io::CameraFile f = io::parse_camera_yaml(kRos2Message, "info.yaml");
  expect_camera(
      f.intrinsics,
      {.fx = 383.5, .fy = 384.0, .cx = 321.25, .cy = 238.75, .width = 640, .height = 480});
  EXPECT_EQ(f.distortion_model, "plumb_bob");
  EXPECT_EQ(f.distortion.size(), 5u);
  EXPECT_FALSE(f.distorted());
}

TEST(CameraYaml, CalibrationFileAndRos1Message) {
  const io::CameraFile f = io::parse_camera_yaml(kCalibrationFile, "ost.yaml");
  expect_camera(f.intrinsics,
                {.fx = 570.3, .fy = 571.1, .cx = 314.5, .cy = 235.5, .width = 640, .height = 480});
  EXPECT_EQ(f.distortion, (std::vector<double>{0.051, -0.12, 0, 0, 0}));
  EXPECT_TRUE(f.distorted());

  // rostopic echo -n 1 (ROS 1): upper-case keys, flow lists, an empty D, a roi the driver filled
  // in with the whole image.
  const io::CameraFile ros1 = io::parse_camera_yaml(
      "height: 240\nwidth: 320\ndistortion_model: ''\nD: []\n"
      "K: [285.0, 0.0, 160.5, 0.0, 286.0, 120.5, 0.0, 0.0, 1.0]\n"
      "roi: {x_offset: 0, y_offset: 0, height: 240, width: 320, do_rectify: false}\n---\n",
      "ros1.yaml");
  expect_camera(ros1.intrinsics,
                {.fx = 285.0, .fy = 286.0, .cx = 160.5, .cy = 120.5, .width = 320, .height = 240});
  EXPECT_TRUE(ros1.distortion.empty());
  EXPECT_FALSE(ros1.distorted());

  const io::CameraFile flat =
      io::parse_camera_yaml("fx: 600\nfy: 601\ncx: 320.5\ncy: 240.5\n", "flat.yaml");
  expect_camera(flat.intrinsics, {.fx = 600, .fy = 601, .cx = 320.5, .cy = 240.5});
}

TEST(CameraYaml, ProjectionMatrixIsTheRectifiedImagesCamera) {
  // A calibration with distortion: P, the camera of the rectified image, is the depth images'
  // (ROS's depth_image_proc takes P); K stays available for a warning.
  const std::string with_p = std::string(kCalibrationFile) +
                             "projection_matrix:\n  rows: 3\n  cols: 4\n"
                             "  data: [560.0, 0, 318.0, 0, 0, 562.5, 237.0, 0, 0, 0, 1, 0]\n";
  const io::CameraFile f = io::parse_camera_yaml(with_p, "ost.yaml");
  expect_camera(f.intrinsics,
                {.fx = 560, .fy = 562.5, .cx = 318, .cy = 237, .width = 640, .height = 480});
  expect_camera(f.camera_matrix,
                {.fx = 570.3, .fy = 571.1, .cx = 314.5, .cy = 235.5, .width = 640, .height = 480});
  EXPECT_TRUE(f.projection_differs());

  // A message's P equal to K (a RealSense) is no difference; a stereo right camera's Tx is
  // its baseline, not an intrinsic.
  const io::CameraFile same = io::parse_camera_yaml(kRos2Message, "info.yaml");
  EXPECT_FALSE(same.projection_differs());
  const io::CameraFile right = io::parse_camera_yaml(
      "K: [285.0, 0.0, 160.5, 0.0, 286.0, 120.5, 0.0, 0.0, 1.0]\n"
      "P: [285.0, 0.0, 160.5, -21.4, 0.0, 286.0, 120.5, 0.0, 0.0, 0.0, 1.0, 0.0]\n",
      "right.yaml");
  EXPECT_FALSE(right.projection_differs());
  EXPECT_EQ(right.intrinsics.fx, 285.0);

  // A driver that does not rectify leaves P all zero: K is the camera.
  const io::CameraFile zero_p = io::parse_camera_yaml(
      "K: [285.0, 0.0, 160.5, 0.0, 286.0, 120.5, 0.0, 0.0, 1.0]\nP: [0, 0, 0, 0, 0, 0, 0, 0, 0, "
      "0, 0, 0]\n",
      "zero.yaml");
  expect_camera(zero_p.intrinsics, {.fx = 285.0, .fy = 286.0, .cx = 160.5, .cy = 120.5});
  EXPECT_FALSE(zero_p.projection_differs());
}

TEST(CameraYaml, BadFilesNameFileKeyAndValue) {
  const auto check = [](const std::string& text, const std::string& needle) {
    expect_runtime_error_with([&] { io::parse_camera_yaml(text, "cam.yaml"); }, "cam.yaml");
    expect_runtime_error_with([&] { io::parse_camera_yaml(text, "cam.yaml"); }, needle);
  };
  check("k: [1, 2\n", "invalid YAML at line");
  // yaml-cpp 0.7 never returns from a document that starts with ',' (found by fuzz_camera).
  check("# comment\n--- &a ,\n", "cannot start with ','");
  check("fx: 1\n---\n,\n", "\"fy\"");  // only the first document is read
  check("", "not a YAML map");
  check("- 1\n- 2\n", "not a YAML map");
  check("width: 640\n", "no camera matrix");
  check("k: [525, 0, 319.5, 0, 525, 239.5, 0, 0]\n", "9 numbers");
  check("k: [0, 0, 0, 0, 0, 0, 0, 0, 0]\n", "not calibrated");
  check("k: [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\nwidth: -3\n", "\"width\"");
  check("k: [525, 0.5, 319.5, 0, 525, 239.5, 0, 0, 1]\n", "no skew");
  // Column-major (Open3D's order) is not a row-major K.
  check("k: [525, 0, 0, 0, 525, 0, 319.5, 239.5, 1]\n", "row-major");
  check("k: [525, 0, 319.5, 0, abc, 239.5, 0, 0, 1]\n", "\"k[4]\"");
  check("k: [525, 0, 319.5, 0, .nan, 239.5, 0, 0, 1]\n", "not finite");
  check("K: {a: 1}\n", "has no \"data\"");
  check("k: [-525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\n", "fx");
  check("k: [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\nbinning_x: 2\n", "binning_x");
  check("k: [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\nroi: {x_offset: 8}\n", "roi.x_offset");
  check(
      "k: [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\nwidth: 640\nheight: 480\n"
      "roi: {x_offset: 0, y_offset: 0, width: 320, height: 480}\n",
      "roi.width");
  check("fx: 1\nfy: 1\ncx: 1\n", "\"cy\"");
  check("fx: 1\nfy: [1]\ncx: 1\ncy: 1\n", "\"fy\"");
  check("k: [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\nd: 0.1\n", "\"d\"");
  check("k: [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\np: [525, 0, 319.5, 0, 525, 239.5]\n",
        "12 numbers");
  check(
      "k: [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\n"
      "p: [525, 0, 319.5, 0, 525, 0, 239.5, 0, 0, 0, 1, 0]\n",
      "not a projection matrix");
  check(
      "k: [525, 0, 319.5, 0, 525, 239.5, 0, 0, 1]\n"
      "p: [-525, 0, 319.5, 0, 0, 525, 239.5, 0, 0, 0, 1, 0]\n",
      "fx");
}

TEST(CameraFile, ReadsYamlOrJsonByName) {
  const auto dir = test::scratch_dir("camera_file");
  const std::string yaml = (dir / "info.YAML").string();
  io::write_file_atomic(yaml, std::string(kRos2Message));
  const io::CameraFile from_yaml = io::read_camera_file(yaml);
  EXPECT_EQ(from_yaml.intrinsics.cx, 321.25);

  // The same camera in Open3D's JSON (column-major) reads the same, without distortion.
  const std::string json = (dir / "info.json").string();
  io::write_file_atomic(json, std::string(R"({"width": 640, "height": 480, "intrinsic_matrix": )"
                                          R"([383.5, 0, 0, 0, 384, 0, 321.25, 238.75, 1]})"));
  const io::CameraFile from_json = io::read_camera_file(json);
  expect_camera(from_json.intrinsics, from_yaml.intrinsics);
  EXPECT_TRUE(from_json.distortion.empty());

  // A YAML message named .json is JSON to the reader, and its error says JSON.
  const std::string misnamed = (dir / "message.json").string();
  io::write_file_atomic(misnamed, std::string(kRos2Message));
  expect_runtime_error_with([&] { io::read_camera_file(misnamed); }, "invalid JSON");
  // A focal length given twice (an edit that JSON would drop) is refused.
  const std::string twice = (dir / "twice.json").string();
  io::write_file_atomic(twice, std::string(R"({"fx": 383.5, "fy": 384, "cx": 321.25, )"
                                           R"("cy": 238.75, "fx": 600})"));
  expect_runtime_error_with([&] { io::read_camera_file(twice); },
                            "twice.json': key 'fx' is given twice in the top-level object");
  expect_runtime_error_with([&] { io::read_camera_file((dir / "none.yaml").string()); },
                            "none.yaml");
}
