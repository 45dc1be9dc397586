// libFuzzer target for the Sun rasterfile decoder (SegComp .range / .gt-seg files).
#include <cstddef>
#include <cstdint>
#include <exception>

#include "rangeseg/io/rasterfile.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const rangeseg::BytePlane image = rangeseg::io::decode_rasterfile(data, size, "fuzz.ras");
    if (image.empty()) __builtin_trap();
    volatile std::uint8_t sink = image(image.width() - 1, image.height() - 1);
    (void)sink;
  } catch (const std::exception&) {
  }
  return 0;
}
