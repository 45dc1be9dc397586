// Tests of the settings JSON parser (the CLI's --config, the Python module's config).
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "rangeseg/io/settings_json.hpp"
#include "rangeseg/pipeline.hpp"

namespace rangeseg {
namespace {

std::string error_of(const std::string& text, PipelineSettings& settings) {
  try {
    io::apply_settings_json(text, "params.json", settings);
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "";
}

TEST(SettingsJson, KeysSetTheirFieldsAndNamesSetModels) {
  PipelineSettings s = pipeline_preset("kinect");
  io::apply_settings_json(
      R"({"smooth": false, "mesh": {"type": "quad", "eps_theta": 0.2},
          "segmentation": {"model": "incremental", "min_region_size": 321},
          "noise": {"a": 0.002, "b": 0.001, "z0": 0.5}})",
      "params.json", s);
  EXPECT_FALSE(s.smooth);
  EXPECT_EQ(s.mesh.type, MeshType::quad);
  EXPECT_FLOAT_EQ(static_cast<float>(s.mesh.eps_theta), 0.2f);  // a float field
  EXPECT_EQ(s.segmentation.model, RegionModel::incremental_plane);
  EXPECT_EQ(s.segmentation.min_region_size, 321);
  // The noise model goes into every stage.
  EXPECT_DOUBLE_EQ(s.segmentation.noise.a, 0.002);
  EXPECT_DOUBLE_EQ(s.mesh.noise.a, 0.002);
  // "iterations" turns the filter on unless "smooth" says otherwise.
  PipelineSettings abw = pipeline_preset("abw");
  ASSERT_FALSE(abw.smooth);
  io::apply_settings_json(R"({"smoothing": {"iterations": 2}})", "p", abw);
  EXPECT_TRUE(abw.smooth);
  EXPECT_EQ(abw.smoothing.iterations, 2);
  // The polygons' settings ("polygons" turns them on or off).
  io::apply_settings_json(
      R"({"polygons": true, "polygon": {"simplify_tolerance": 0.002, "convex_hull": false,
          "simplify_inradius_fraction": 0, "min_segment_pixels": 40}})",
      "params.json", s);
  EXPECT_TRUE(s.polygons);
  EXPECT_DOUBLE_EQ(s.polygon.simplify_tolerance, 0.002);
  EXPECT_DOUBLE_EQ(s.polygon.simplify_inradius_fraction, 0);
  EXPECT_FALSE(s.polygon.convex_hull);
  EXPECT_EQ(s.polygon.min_segment_pixels, 40);
}

TEST(SettingsJson, ErrorsNameTheSourceAndKeyAndChangeNothing) {
  struct Case {
    const char* json;
    const char* message;
  };
  for (const Case c :
       {Case{R"({"segmentation": {"min_region": 3}})", "unknown key 'min_region'"},
        Case{R"({"segmentation": {"min_region_size": 2.5}})", "must be an integer"},
        Case{R"({"segmentation": {"min_region_size": -3}})",
             "[segmentation]: key 'min_region_size' = -3 is invalid"},
        Case{R"({"segmentation": {"model": "planes"}})", "unknown model 'planes'"},
        Case{R"({"mesh": {"type": "triangles"}})", "unknown mesh type"},
        Case{R"({"polygon": {"simplify_tolerance": -0.01}})",
             "[polygon]: key 'simplify_tolerance' = -0.01 is invalid"},
        Case{R"({"polygon": {"viewpoint": [0, 0, 0]}})", "unknown key 'viewpoint'"},
        Case{R"({"smooth": "yes"})", "key 'smooth' must be true or false, got \"yes\""},
        Case{R"({"mesh": {"eps_theta": "wide"}})", "key 'eps_theta' must be a number"},
        Case{R"([1, 2])", "expected a JSON object"}, Case{R"({"mesh": )", "invalid JSON"},
        // A key given twice is an edit that did not take effect: JSON keeps one value.
        Case{R"({"segmentation": {"min_region_size": 50, "min_region_size": 90}})",
             "key 'min_region_size' is given twice in 'segmentation'"},
        Case{R"({"smooth": true, "mesh": {}, "smooth": false})",
             "key 'smooth' is given twice in the top-level object"}}) {
    PipelineSettings s = pipeline_preset("kinect");
    s.segmentation.min_region_size = 77;
    const std::string error = error_of(c.json, s);
    EXPECT_NE(error.find("params.json"), std::string::npos) << c.json << ": " << error;
    EXPECT_NE(error.find(c.message), std::string::npos) << c.json << ": " << error;
    EXPECT_EQ(s.segmentation.min_region_size, 77) << c.json;
    EXPECT_EQ(s.segmentation.model, RegionModel::plane) << c.json;
  }
  // A float that holds an integer is that integer (Python's json writes 200.0 so).
  PipelineSettings whole = pipeline_preset("kinect");
  EXPECT_EQ(error_of(R"({"segmentation": {"min_region_size": 200.0}})", whole), "");
  EXPECT_EQ(whole.segmentation.min_region_size, 200);
  // A valid key beside an invalid one is not applied either.
  PipelineSettings s = pipeline_preset("kinect");
  const double angle = s.segmentation.max_normal_angle;
  EXPECT_FALSE(
      error_of(R"({"segmentation": {"max_normal_angle": 0.5, "min_region_size": 0}})", s).empty());
  EXPECT_DOUBLE_EQ(s.segmentation.max_normal_angle, angle);
}

/// The JSON of any settings, applied to other settings, gives them back: every key written is
/// read (and floats are written as the decimals they were set as).
TEST(SettingsJson, WrittenSettingsReadBack) {
  for (const char* preset : {"kinect", "abw", "laser", "perceptron", "ideal"}) {
    PipelineSettings s = pipeline_preset(preset);
    s.segmentation.model = RegionModel::automatic;
    s.mesh.type = MeshType::right_cut;
    s.rings.k = 9;
    s.restore_grid = false;
    s.polygons = false;
    s.polygon.min_loop_pixels = 3.5;
    const std::string text = io::settings_to_json(s);
    PipelineSettings back;
    io::apply_settings_json(text, "written", back);
    EXPECT_EQ(io::settings_to_json(back), text) << preset;
    EXPECT_EQ(back.smooth, s.smooth) << preset;
    EXPECT_EQ(back.segmentation.min_region_size, s.segmentation.min_region_size) << preset;
    EXPECT_EQ(back.segmentation.noise.a, s.segmentation.noise.a) << preset;
    EXPECT_EQ(back.mesh.eps_theta, s.mesh.eps_theta) << preset;
    EXPECT_EQ(back.smoothing.pixel_angle, s.smoothing.pixel_angle) << preset;
    EXPECT_EQ(back.mesh.type, MeshType::right_cut);
    EXPECT_EQ(back.rings.k, 9);
    EXPECT_FALSE(back.restore_grid);
    EXPECT_FALSE(back.polygons);
    EXPECT_EQ(back.polygon.min_loop_pixels, 3.5);
  }
  EXPECT_NE(io::settings_to_json(pipeline_preset("kinect")).find("\"eps_theta\": 0.2182,"),
            std::string::npos);
}

TEST(SettingsJson, NamesOfModelsAndMeshTypes) {
  EXPECT_EQ(region_model_from_string("auto"), RegionModel::automatic);
  EXPECT_EQ(region_model_from_string("smooth"), RegionModel::smooth);
  EXPECT_EQ(mesh_type_from_string("left"), MeshType::left_cut);
  EXPECT_THROW(region_model_from_string("Plane"), std::invalid_argument);
  EXPECT_THROW(mesh_type_from_string(""), std::invalid_argument);
  for (const MeshType t :
       {MeshType::adaptive, MeshType::quad, MeshType::left_cut, MeshType::right_cut}) {
    EXPECT_EQ(mesh_type_from_string(to_string(t)), t);
  }
}

}  // namespace
}  // namespace rangeseg
