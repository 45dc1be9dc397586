// libFuzzer target: parse_pcd must reject malformed input with an exception, never crash.
#include <cstddef>
#include <cstdint>
#include <exception>

#include "rangeseg/io/pcd.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  try {
    const rangeseg::OrganizedCloud cloud = rangeseg::io::parse_pcd(data, size, "fuzz.pcd");
    // Touch the result so the decoders' writes are checked by the sanitizers.
    volatile std::size_t valid = cloud.count_valid();
    (void)valid;
  } catch (const std::exception&) {
  }
  return 0;
}
