#include "rangeseg/io/camera_json.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "detail/json_parse.hpp"
#include "rangeseg/io/file.hpp"

namespace rangeseg::io {
namespace {

using nlohmann::json;

[[noreturn]] void fail(const std::string& name, const std::string& why) {
  throw std::runtime_error("camera JSON '" + name + "': " + why);
}

double number(const json& object, const char* key, const std::string& name) {
  const auto it = object.find(key);
  if (it == object.end()) fail(name, std::string("missing key \"") + key + "\"");
  if (!it->is_number()) {
    fail(name, std::string("key \"") + key + "\" is not a number: " + it->dump());
  }
  const double value = it->get<double>();
  if (!std::isfinite(value)) fail(name, std::string("key \"") + key + "\" is not finite");
  return value;
}

int size_value(const json& object, const char* key, const std::string& name, bool required) {
  if (!required && !object.contains(key)) return 0;
  const double value = number(object, key, name);
  if (value < 0 || value > 1e6 || value != std::floor(value)) {
    fail(name, std::string("key \"") + key + "\" is not a valid image size: " + object[key].dump());
  }
  return static_cast<int>(value);
}

}  // namespace

CameraIntrinsics parse_camera_json(const std::string& text, const std::string& name) {
  json root;
  try {
    root = detail::parse_json_keys_once(text);
  } catch (const std::runtime_error& e) {
    fail(name, e.what());
  }
  if (!root.is_object()) fail(name, "top level is not a JSON object");

  CameraIntrinsics camera;
  if (root.contains("intrinsic_matrix")) {
    const json& m = root["intrinsic_matrix"];
    if (!m.is_array() || m.size() != 9) {
      fail(name, "key \"intrinsic_matrix\" must be an array of 9 numbers, got " + m.dump());
    }
    std::vector<double> k(9);
    for (std::size_t i = 0; i < 9; ++i) {
      if (!m[i].is_number()) {
        fail(name, "key \"intrinsic_matrix\" element " + std::to_string(i) + " is not a number");
      }
      k[i] = m[i].get<double>();
    }
    // Column-major: k[0] = K(0,0) = fx, k[4] = K(1,1) = fy, k[6] = K(0,2) = cx, k[7] = K(1,2) = cy.
    camera.fx = k[0];
    camera.fy = k[4];
    camera.cx = k[6];
    camera.cy = k[7];
    if (k[1] != 0 || k[2] != 0 || k[3] != 0 || k[5] != 0 || k[8] != 1) {
      fail(name, "key \"intrinsic_matrix\" " + m.dump() +
                     " is not a pinhole matrix [fx,0,0, 0,fy,0, cx,cy,1] (column-major, no skew)");
    }
    camera.width = size_value(root, "width", name, true);
    camera.height = size_value(root, "height", name, true);
  } else {
    camera.fx = number(root, "fx", name);
    camera.fy = number(root, "fy", name);
    camera.cx = number(root, "cx", name);
    camera.cy = number(root, "cy", name);
    camera.width = size_value(root, "width", name, false);
    camera.height = size_value(root, "height", name, false);
  }
  try {
    validate(camera);
  } catch (const std::invalid_argument& e) {
    fail(name, e.what());
  }
  return camera;
}

CameraIntrinsics read_camera_json(const std::string& path) {
  const std::vector<std::uint8_t> bytes = read_file(path, std::uint64_t{1} << 24);
  return parse_camera_json(std::string(bytes.begin(), bytes.end()), path);
}

}  // namespace rangeseg::io
