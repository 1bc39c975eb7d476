// Text the tools compare without regard to case: file extensions, format names.
#pragma once

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <string>
#include <string_view>

namespace dsmplan {

/// `text` with ASCII letters in lower case (std::tolower in the "C" locale); other bytes as they are.
inline std::string lower_case(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return text;
}

/// `v` with two decimals ("%.2f"): metres and seconds in messages.
inline std::string two_decimals(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f", v);
  return buffer;
}

/// A number as a user would type it ("%g": "0.25", not "0.250000"; "1e-07", not "0.000000").
inline std::string short_number(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%g", v);
  return buffer;
}

/// A piece of a file as it can stand inside a one-line message: at most 40 bytes, quoted, other
/// bytes than printable ASCII as '?', "..." when cut (a 5 MB value is not echoed whole).
inline std::string shown(std::string_view text) {
  constexpr size_t kQuoteLength = 40;
  std::string out;
  for (char c : text.substr(0, kQuoteLength)) {
    const auto byte = static_cast<unsigned char>(c);
    out += (byte < 32 || byte >= 127) ? '?' : c;
  }
  if (text.size() > kQuoteLength) out += "...";
  return "'" + out + "'";
}

}  // namespace dsmplan
