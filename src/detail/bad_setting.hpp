// The one message of a rejected setting, "Owner::field = value must be condition", and the check
// of the noise model that meshing, segmentation and the rings share.
#pragma once

#include <cmath>
#include <stdexcept>
#include <string>
#include <string_view>

#include "detail/number_text.hpp"
#include "rangeseg/sensor.hpp"

namespace rangeseg::detail {

/// Throws std::invalid_argument "Owner::field = value must be condition", the value as the
/// shortest text that reads back as it (number_text: an integer as an integer, 2147483647, a
/// float as the float it is, 0.2182, and 1.0000001 not as 1).
template <class T>
[[noreturn]] void throw_bad_setting(std::string_view owner, std::string_view field, T value,
                                    std::string_view condition) {
  std::string message(owner);
  message.append("::").append(field).append(" = ").append(number_text(value));
  message.append(" must be ").append(condition);
  throw std::invalid_argument(message);
}

/// sigma(z) > 0 at every depth: a finite and > 0, b finite and >= 0, z0 finite; else throws
/// naming `owner`'s field (e.g. MeshSettings::noise.a).
inline void require_noise(const SensorNoise& noise, std::string_view owner) {
  if (!std::isfinite(noise.a) || !(noise.a > 0)) {
    throw_bad_setting(owner, "noise.a", noise.a, "finite and > 0");
  }
  if (!std::isfinite(noise.b) || !(noise.b >= 0)) {
    throw_bad_setting(owner, "noise.b", noise.b, "finite and >= 0");
  }
  if (!std::isfinite(noise.z0)) throw_bad_setting(owner, "noise.z0", noise.z0, "finite");
}

}  // namespace rangeseg::detail
