// libFuzzer target: the camera file parsers must reject malformed input with an exception,
// never crash. Byte 0 picks the parser (even: ROS camera_info YAML, odd: camera JSON).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <string>

#include "rangeseg/io/camera_file.hpp"
#include "rangeseg/io/camera_json.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size == 0) return 0;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  try {
    if (data[0] % 2 == 0) {
      const rangeseg::io::CameraFile file = rangeseg::io::parse_camera_yaml(text, "fuzz.yaml");
      volatile bool distorted = file.distorted();
      (void)distorted;
    } else {
      volatile double fx = rangeseg::io::parse_camera_json(text, "fuzz.json").fx;
      (void)fx;
    }
  } catch (const std::exception&) {
  }
  return 0;
}
