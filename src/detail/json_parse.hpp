// JSON text parsed with nlohmann-json, refusing an object that gives a key twice: the parser
// would keep one of the values without a word, and in a settings or camera file a repeated key
// is an edit that did not take effect.
#pragma once

#include <nlohmann/json.hpp>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace rangeseg::detail {

/// The parsed text; throws std::runtime_error with the reason (no file name: the caller adds
/// it) for invalid JSON or a key given twice in one object.
inline nlohmann::json parse_json_keys_once(std::string_view text) {
  using nlohmann::json;
  std::vector<std::pair<std::string, std::vector<std::string>>> objects;  // name, keys so far
  std::string last_key, repeated;
  const json::parser_callback_t note_keys = [&](int, json::parse_event_t event, json& parsed) {
    if (event == json::parse_event_t::object_start) {
      objects.emplace_back(objects.empty() ? std::string() : last_key, std::vector<std::string>{});
    } else if (event == json::parse_event_t::object_end) {
      if (!objects.empty()) objects.pop_back();
    } else if (event == json::parse_event_t::key && !objects.empty()) {
      last_key = parsed.get<std::string>();
      auto& [name, keys] = objects.back();
      bool seen = false;
      for (const std::string& key : keys) seen = seen || key == last_key;
      if (seen && repeated.empty()) {
        repeated = "key '" + last_key + "' is given twice in " +
                   (name.empty() ? std::string("the top-level object") : "'" + name + "'") +
                   " (JSON keeps one of the values; give each key once)";
      }
      keys.push_back(last_key);
    }
    return true;
  };
  json j;
  try {
    j = json::parse(text.begin(), text.end(), note_keys);
  } catch (const json::exception& e) {
    throw std::runtime_error(std::string("invalid JSON: ") + e.what());
  }
  if (!repeated.empty()) throw std::runtime_error(repeated);
  return j;
}

}  // namespace rangeseg::detail
