// Pipeline::why_no_segments for the smooth model (a noisy sensor's 1-ring curvature lies above
// max_curvature nearly everywhere, and the reason names the bound that admits the points) and
// for points at an implausible scale.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <random>
#include <string>

#include "rangeseg/pipeline.hpp"
#include "segmentation_test_util.hpp"

namespace rangeseg {
namespace {

/// A wall 2 m away seen by a 640 x 480 Kinect, with its depth noise sigma(2 m) = 3.5 mm.
OrganizedCloud noisy_wall() {
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, 0.0012 + 0.0019 * 1.6 * 1.6);
  return test::cast(640, 480, [&](double, double) { return 2.0 + noise(rng); });
}

TEST(Pipeline, SaysWhenTheSmoothModelsCurvatureBoundAdmitsTooFewPoints) {
  const OrganizedCloud wall = noisy_wall();
  PipelineSettings settings = pipeline_preset("kinect");
  settings.segmentation.model = RegionModel::smooth;
  Pipeline pipeline(settings);
  pipeline.process(wall);
  ASSERT_TRUE(pipeline.segmentation().segments.empty());
  const std::string why = pipeline.why_no_segments();
  // The bounds it proposes admit the wall as one segment.
  const auto proposed = [&](const std::string& field) {
    const std::size_t at = why.find(field);
    if (at == std::string::npos) return -1.0;
    const std::string raise = "raise it to about ";
    const std::size_t value = why.find(raise, at);
    return value == std::string::npos ? -1.0
                                      : std::strtod(why.c_str() + value + raise.size(), nullptr);
  };
  const double curvature = proposed("segmentation.max_curvature = 50 1/m");
  const double angle = proposed("segmentation.max_smooth_angle = 0.14 rad");
  ASSERT_TRUE(curvature > 0 || angle > 0) << why;
  if (curvature > 0) {
    EXPECT_GT(curvature, 50.0) << why;
    settings.segmentation.max_curvature = curvature;
  }
  if (angle > 0) {
    EXPECT_GT(angle, 0.14) << why;
    settings.segmentation.max_smooth_angle = angle;
  }
  Pipeline raised(settings);
  raised.process(wall);
  ASSERT_GE(raised.segmentation().segments.size(), 1u);
  EXPECT_GT(raised.segmentation().segments[0].pixel_count, 640 * 480 / 2) << why;
  EXPECT_TRUE(raised.why_no_segments().empty());

  // The plane model finds the wall: nothing to say.
  Pipeline planes(pipeline_preset("kinect"));
  planes.process(wall);
  EXPECT_FALSE(planes.segmentation().segments.empty());
  EXPECT_TRUE(planes.why_no_segments().empty());
}

// A depth image whose floats are 1e30 (garbage for "no depth"): no other cause is found, and
// the reason is the points' scale. (A wall in millimetres read as metres still gives a segment,
// a plane 2 km away; the command line and Python warn for it.)
TEST(Pipeline, SaysWhenThePointsScaleIsImplausible) {
  const CameraIntrinsics camera{.fx = 525, .fy = 525, .cx = 319.5, .cy = 239.5};
  FloatPlane huge(640, 480, 1e30f);
  Pipeline pipeline(pipeline_preset("kinect"));
  pipeline.process(huge.view(), camera);
  ASSERT_TRUE(pipeline.segmentation().segments.empty());
  EXPECT_NE(pipeline.why_no_segments().find("median distance"), std::string::npos)
      << pipeline.why_no_segments();

  // A lattice step beyond the image leaves no cell to mesh.
  const OrganizedCloud wall = noisy_wall();
  PipelineSettings coarse = pipeline_preset("kinect");
  coarse.mesh.pixel_stride = 1000;
  Pipeline strided(coarse);
  strided.process(wall);
  EXPECT_NE(strided.why_no_segments().find("mesh.pixel_stride = 1000 leaves no lattice cell in "
                                           "this 640 x 480 grid"),
            std::string::npos)
      << strided.why_no_segments();
  // A plausible wall: segments, nothing to say.
  pipeline.process(wall);
  EXPECT_FALSE(pipeline.segmentation().segments.empty());
  EXPECT_EQ(pipeline.why_no_segments(), "");
}

}  // namespace
}  // namespace rangeseg
