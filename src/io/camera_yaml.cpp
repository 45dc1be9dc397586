#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>
#include <string_view>
#include <vector>

#include "detail/number_text.hpp"
#include "rangeseg/io/camera_file.hpp"
#include "rangeseg/io/camera_json.hpp"
#include "rangeseg/io/file.hpp"

namespace rangeseg::io {
namespace {

[[noreturn]] void fail(const std::string& name, const std::string& why) {
  throw std::runtime_error("camera YAML '" + name + "': " + why);
}

std::string where(const YAML::Node& node) {
  return " (line " + std::to_string(node.Mark().line + 1) + ")";
}

double number(const YAML::Node& node, const std::string& key, const std::string& name) {
  double value = NAN;
  if (!node.IsScalar() || !YAML::convert<double>::decode(node, value)) {
    fail(name, "key \"" + key + "\" is not a number: " + YAML::Dump(node) + where(node));
  }
  if (!std::isfinite(value)) fail(name, "key \"" + key + "\" is not finite" + where(node));
  return value;
}

std::vector<double> numbers(const YAML::Node& node, const std::string& key,
                            const std::string& name) {
  if (!node.IsSequence()) {
    fail(name, "key \"" + key + "\" is not a list of numbers: " + YAML::Dump(node) + where(node));
  }
  std::vector<double> values;
  values.reserve(node.size());
  for (std::size_t i = 0; i < node.size(); ++i) {
    values.push_back(number(node[i], key + "[" + std::to_string(i) + "]", name));
  }
  return values;
}

int size_value(const YAML::Node& root, const char* key, const std::string& name) {
  const YAML::Node node = root[key];
  if (!node) return 0;
  const double value = number(node, key, name);
  if (value < 0 || value > 1e6 || value != std::floor(value)) {
    fail(name, std::string("key \"") + key + "\" is not a valid image size: " + YAML::Dump(node));
  }
  return static_cast<int>(value);
}

// The first key of `keys` that `map` has, or an undefined node.
YAML::Node first_of(const YAML::Node& map, std::initializer_list<const char*> keys,
                    std::string& found) {
  for (const char* key : keys) {
    if (YAML::Node node = map[key]) {
      found = key;
      return node;
    }
  }
  return YAML::Node(YAML::NodeType::Undefined);
}

// A matrix as ROS writes it: a plain list (a message's k / K), or a calibration file's
// {rows, cols, data} map.
std::vector<double> matrix(const YAML::Node& node, const std::string& key,
                           const std::string& name) {
  if (!node.IsMap()) return numbers(node, key, name);
  const YAML::Node data = node["data"];
  if (!data) fail(name, "key \"" + key + "\" has no \"data\"" + where(node));
  return numbers(data, key + ".data", name);
}

// Binning and a region of interest describe an image cut or scaled from the one K is for; a
// roi of zeros or of the whole image (some drivers fill it in) describes that image.
void refuse_binning_and_roi(const YAML::Node& root, const CameraIntrinsics& camera,
                            const std::string& name) {
  for (const char* key : {"binning_x", "binning_y"}) {
    if (const YAML::Node node = root[key]; node && number(node, key, name) > 1) {
      fail(name, std::string("key \"") + key + "\" is " + YAML::Dump(node) +
                     ": binned images are not supported; give the camera of the image itself "
                     "(K divided by the binning)");
    }
  }
  const YAML::Node roi = root["roi"];
  if (!roi || !roi.IsMap()) return;
  for (const auto& [key, whole] : {std::pair{"x_offset", 0},
                                   {"y_offset", 0},
                                   {"width", camera.width},
                                   {"height", camera.height}}) {
    const YAML::Node node = roi[key];
    if (!node) continue;
    if (const double value = number(node, key, name); value != 0 && value != whole) {
      fail(name, std::string("key \"roi.") + key + "\" is " + YAML::Dump(node) +
                     ": a region of interest is not supported; give the camera of the image "
                     "itself (cx, cy less the offsets)");
    }
  }
}

CameraIntrinsics from_k(const std::vector<double>& k, const std::string& key,
                        const std::string& name) {
  if (k.size() != 9) {
    fail(name, "key \"" + key + "\" must hold 9 numbers (3x3, row-major), got " +
                   std::to_string(k.size()));
  }
  if (std::all_of(k.begin(), k.end(), [](double x) { return x == 0; })) {
    fail(name, "key \"" + key + "\" is all zero: the camera is not calibrated");
  }
  // Row-major: k[0] = fx, k[2] = cx, k[4] = fy, k[5] = cy.
  if (k[1] != 0 || k[3] != 0 || k[6] != 0 || k[7] != 0 || k[8] != 1) {
    std::string text;
    for (const double x : k) text += (text.empty() ? "" : ", ") + rangeseg::detail::number_text(x);
    fail(name, "key \"" + key + "\" [" + text +
                   "] is not a pinhole matrix [fx, 0, cx, 0, fy, cy, 0, 0, 1] (row-major, no "
                   "skew)");
  }
  return {.fx = k[0], .fy = k[4], .cx = k[2], .cy = k[5]};
}

// ROS's projection matrix, the camera of the rectified image: row-major 3x4
// [fx', 0, cx', Tx, 0, fy', cy', Ty, 0, 0, 1, 0], into `camera`; an all-zero P (drivers that do
// not rectify leave it so) leaves `camera` as it is.
void from_p(const std::vector<double>& p, const std::string& key, const std::string& name,
            CameraIntrinsics& camera) {
  if (p.size() != 12) {
    fail(name, "key \"" + key + "\" must hold 12 numbers (3x4, row-major), got " +
                   std::to_string(p.size()));
  }
  if (std::all_of(p.begin(), p.end(), [](double x) { return x == 0; })) return;
  if (p[1] != 0 || p[4] != 0 || p[8] != 0 || p[9] != 0 || p[10] != 1 || p[11] != 0) {
    std::string text;
    for (const double x : p) text += (text.empty() ? "" : ", ") + rangeseg::detail::number_text(x);
    fail(name, "key \"" + key + "\" [" + text +
                   "] is not a projection matrix [fx, 0, cx, Tx, 0, fy, cy, Ty, 0, 0, 1, 0] "
                   "(row-major, no skew)");
  }
  camera.fx = p[0];
  camera.cx = p[2];
  camera.fy = p[5];
  camera.cy = p[6];
}

// The first YAML document of `text` (ROS's echo ends a message with `---`, and
// `ros2 topic echo` without --once prints one after another), with an error for the one input
// on which Debian 12's yaml-cpp 0.7 never returns (it allocates until memory runs out): a
// document whose first token is a ','.
std::string first_document(const std::string& text, const std::string& name) {
  std::size_t pos = 0;
  bool content = false;
  std::size_t end = text.size();
  while (pos < text.size()) {
    const std::size_t eol = std::min(text.find('\n', pos), text.size());
    std::string_view line(text.data() + pos, eol - pos);
    while (!line.empty() && (line.back() == '\r' || line.back() == ' ' || line.back() == '\t')) {
      line.remove_suffix(1);
    }
    const bool marker =
        line.starts_with("---") && (line.size() == 3 || line[3] == ' ' || line[3] == '\t');
    if (content && (marker || line == "...")) {
      end = pos;
      break;
    }
    std::string_view rest = line;
    if (marker) rest.remove_prefix(3);
    // Node properties (&anchor, !tag) may precede the first token.
    for (;;) {
      while (!rest.empty() && (rest.front() == ' ' || rest.front() == '\t')) rest.remove_prefix(1);
      if (rest.empty() || (rest.front() != '&' && rest.front() != '!')) break;
      const std::size_t space = rest.find_first_of(" \t");
      rest.remove_prefix(space == std::string_view::npos ? rest.size() : space);
    }
    if (!content && !rest.empty() && rest.front() != '#' && rest.front() != '%') {
      if (rest.front() == ',') {
        fail(name,
             "invalid YAML at line " +
                 std::to_string(std::count(text.begin(),
                                           text.begin() + static_cast<std::ptrdiff_t>(pos), '\n') +
                                1) +
                 ": a document cannot start with ','");
      }
      content = true;
    }
    pos = eol + 1;
  }
  return text.substr(0, end);
}

}  // namespace

bool CameraFile::distorted() const {
  return std::any_of(distortion.begin(), distortion.end(), [](double d) { return d != 0; });
}

bool CameraFile::projection_differs() const {
  return intrinsics.fx != camera_matrix.fx || intrinsics.fy != camera_matrix.fy ||
         intrinsics.cx != camera_matrix.cx || intrinsics.cy != camera_matrix.cy;
}

CameraFile parse_camera_yaml(const std::string& text, const std::string& name) {
  YAML::Node root;
  try {
    root = YAML::Load(first_document(text, name));
  } catch (const YAML::Exception& e) {
    fail(name, "invalid YAML at line " + std::to_string(e.mark.line + 1) + ": " + e.msg);
  }
  if (!root.IsMap()) fail(name, "top level is not a YAML map (key: value lines)");

  CameraFile file;
  CameraIntrinsics& camera = file.intrinsics;
  std::string key;
  if (const YAML::Node k = first_of(root, {"camera_matrix", "k", "K"}, key)) {
    camera = from_k(matrix(k, key, name), key, name);
    camera.width = size_value(root, key == "camera_matrix" ? "image_width" : "width", name);
    camera.height = size_value(root, key == "camera_matrix" ? "image_height" : "height", name);
    refuse_binning_and_roi(root, camera, name);
    file.camera_matrix = camera;
    const char* const p_key = key == "camera_matrix" ? "projection_matrix" : key == "k" ? "p" : "P";
    if (const YAML::Node p = root[p_key]) from_p(matrix(p, p_key, name), p_key, name, camera);
  } else if (root["fx"]) {
    for (const auto& [key_name, value] : {std::pair{"fx", &camera.fx},
                                          {"fy", &camera.fy},
                                          {"cx", &camera.cx},
                                          {"cy", &camera.cy}}) {
      const YAML::Node node = root[key_name];
      if (!node) fail(name, std::string("missing key \"") + key_name + "\"");
      *value = number(node, key_name, name);
    }
    camera.width = size_value(root, "width", name);
    camera.height = size_value(root, "height", name);
    file.camera_matrix = camera;
  } else {
    fail(name,
         "no camera matrix: expected \"camera_matrix\" (a ROS calibration file), \"k\" or "
         "\"K\" (a CameraInfo message) or \"fx\", \"fy\", \"cx\", \"cy\"");
  }
  if (const YAML::Node model = root["distortion_model"]; model && model.IsScalar()) {
    file.distortion_model = model.Scalar();
  }
  if (const YAML::Node d = first_of(root, {"distortion_coefficients", "d", "D"}, key)) {
    file.distortion = matrix(d, key, name);
  }
  try {
    validate(camera);
  } catch (const std::invalid_argument& e) {
    fail(name, e.what());
  }
  return file;
}

CameraFile read_camera_file(const std::string& path) {
  const std::string ext = extension(path);
  const std::vector<std::uint8_t> bytes = read_file(path, std::uint64_t{1} << 24);
  const std::string text(bytes.begin(), bytes.end());
  if (ext == ".yaml" || ext == ".yml") return parse_camera_yaml(text, path);
  CameraFile file;
  file.intrinsics = parse_camera_json(text, path);
  file.camera_matrix = file.intrinsics;
  return file;
}

}  // namespace rangeseg::io
