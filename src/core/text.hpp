// Text the tools compare without regard to case: file extensions, format names.
#pragma once

#include <algorithm>
#include <cctype>
#include <string>

namespace dsmplan {

/// `text` with ASCII letters in lower case (std::tolower in the "C" locale); other bytes as they are.
inline std::string lower_case(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

}  // namespace dsmplan
