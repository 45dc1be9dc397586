// libFuzzer target for the SegComp range decoders: Sun rasterfiles (ABW .range, .gt-seg) and
// Perceptron range images, told apart as read_segcomp_range does.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "rangeseg/io/perceptron.hpp"
#include "rangeseg/io/rasterfile.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    if (rangeseg::io::segcomp_sensor(data, size) == rangeseg::io::SegcompSensor::abw) {
      const rangeseg::BytePlane image = rangeseg::io::decode_rasterfile(data, size, "fuzz.ras");
      if (image.empty()) __builtin_trap();
      volatile std::uint8_t sink = image(image.width() - 1, image.height() - 1);
      (void)sink;
    } else {
      const rangeseg::Plane<std::uint16_t> range =
          rangeseg::io::decode_perceptron_range(data, size, "fuzz.range");
      if (range.empty() || range(range.width() - 1, range.height() - 1) > 4095) __builtin_trap();
    }
  } catch (const std::exception&) {
  }
  return 0;
}
