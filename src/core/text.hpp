// Text the tools compare without regard to case: file extensions, format names.
#pragma once

#include <algorithm>
#include <cctype>
#include <cmath>
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

/// `v` with two decimals ("%.2f"): metres and seconds in messages; a magnitude of 1e9 or more as
/// "%g" ("1e+300", not its 301 digits).
inline std::string two_decimals(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, std::abs(v) >= 1e9 ? "%g" : "%.2f", v);
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

/// `text` as it can be shown anywhere a line of text goes (a terminal, a one-line message, XML,
/// JSON): valid UTF-8 kept; control characters (C0 and C1, DEL; tab and newline too, for one line)
/// and bytes that are not UTF-8 shown as "\x1b", one a byte. So a zone's name with ESC in it
/// cannot recolour a terminal, nor make a KML or JSON file that does not parse.
inline std::string visible_text(std::string_view text) {
  static const char* hex = "0123456789abcdef";
  std::string out;
  out.reserve(text.size());
  const auto shown = [&](unsigned char byte) { out += std::string("\\x") + hex[byte >> 4] + hex[byte & 15]; };
  const auto cont = [&](size_t i) { return i < text.size() && (static_cast<unsigned char>(text[i]) & 0xC0) == 0x80; };
  for (size_t i = 0; i < text.size();) {
    const auto b = static_cast<unsigned char>(text[i]);
    size_t length = 0;  // of a valid sequence starting here, 0 for none
    if (b >= 0x20 && b < 0x7F) {
      length = 1;
    } else if (b >= 0xC2 && b <= 0xDF && cont(i + 1)) {
      length = b == 0xC2 && static_cast<unsigned char>(text[i + 1]) < 0xA0 ? 0 : 2;  // C1 controls
    } else if (b >= 0xE0 && b <= 0xEF && cont(i + 1) && cont(i + 2)) {
      const auto b1 = static_cast<unsigned char>(text[i + 1]);
      length = (b == 0xE0 && b1 < 0xA0) || (b == 0xED && b1 > 0x9F) ? 0 : 3;  // overlong, surrogates
    } else if (b >= 0xF0 && b <= 0xF4 && cont(i + 1) && cont(i + 2) && cont(i + 3)) {
      const auto b1 = static_cast<unsigned char>(text[i + 1]);
      length = (b == 0xF0 && b1 < 0x90) || (b == 0xF4 && b1 > 0x8F) ? 0 : 4;
    }
    if (length == 0) {
      shown(b);
      ++i;
      continue;
    }
    out.append(text.substr(i, length));
    i += length;
  }
  return out;
}

}  // namespace dsmplan
