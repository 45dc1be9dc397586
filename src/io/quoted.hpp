// Quoting a piece of a file in an error message.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

namespace rangeseg::io::detail {

/// `text` between `quote` characters, cut after `max` characters ("...") and with unprintable
/// bytes as '?': garbage input must not make huge or unprintable messages.
inline std::string quoted(std::string_view text, char quote = '"', std::size_t max = 60) {
  std::string out(1, quote);
  for (const char c : text.substr(0, max)) out += (c >= 32 && c < 127) ? c : '?';
  if (text.size() > max) out += "...";
  return out + quote;
}

}  // namespace rangeseg::io::detail
