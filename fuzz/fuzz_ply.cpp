// libFuzzer target: decode_ply_cloud must reject malformed input with an exception, never crash.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "rangeseg/io/ply.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const rangeseg::OrganizedCloud cloud = rangeseg::io::decode_ply_cloud(data, size, "fuzz.ply");
    // Touch the result so the decoders' writes are checked by the sanitizers.
    volatile std::size_t valid = cloud.count_valid();
    (void)valid;
  } catch (const std::exception&) {
  }
  return 0;
}
