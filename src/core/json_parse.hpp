// JSON read strictly (nlohmann::json, RFC 8259): an object that names one key twice is refused, as
// RFC 8259 leaves the meaning of such an object to the reader ("last wins" in nlohmann): a zone
// file or a request whose second "restriction" or "safety" silently replaced the first would be
// read as something its author did not see. Header-only, for the readers of every module.
#pragma once

#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <vector>

namespace dsmplan {

/// Thrown by parse_json_strict() for a key given twice in one object; key() is the key.
struct DuplicateJsonKey {
  std::string key;
};

/// nlohmann::ordered_json or nlohmann::json parsed from `text`; its parse_error and out_of_range
/// as nlohmann throws them, DuplicateJsonKey for a key given twice in one object.
template <typename JsonType>
JsonType parse_json_strict(const std::string& text) {
  std::vector<std::set<std::string>> keys;  // the keys seen, per open object
  return JsonType::parse(text, [&keys](int, typename JsonType::parse_event_t event, JsonType& parsed) {
    using Event = typename JsonType::parse_event_t;
    if (event == Event::object_start) keys.emplace_back();
    if (event == Event::object_end && !keys.empty()) keys.pop_back();
    if (event == Event::key && !keys.empty() && !keys.back().insert(parsed.template get<std::string>()).second)
      throw DuplicateJsonKey{parsed.template get<std::string>()};
    return true;
  });
}

}  // namespace dsmplan
