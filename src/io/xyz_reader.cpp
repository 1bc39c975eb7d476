// Reads "x y z [class]" text point clouds (the XYZ/TXT/CSV exports of LiDAR tools), and picks a
// point cloud reader by file extension. Classes follow the ASPRS LAS 1.4 R15 codes.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/text.hpp"
#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"

namespace dsmplan {
namespace {

constexpr size_t kChunk = size_t{4} << 20;
// No point line is this long: a longer one means a binary file, and stopping keeps memory bounded.
constexpr size_t kMaxLine = size_t{1} << 16;
constexpr size_t kQuoteLength = 60;
constexpr std::string_view kExpected = "expected 'x y z [class]', got ";

bool is_separator(char c) { return c == ' ' || c == '\t' || c == ',' || c == ';' || c == '\r'; }

// The offending line as it can stand in a one-line message.
std::string quoted(std::string_view line) {
  while (!line.empty() && is_separator(line.back())) line.remove_suffix(1);
  std::string text;
  for (char c : line.substr(0, kQuoteLength)) {
    const auto byte = static_cast<unsigned char>(c);
    text += c == '\t' ? ' ' : (byte < 32 || byte == 127) ? '?' : c;
  }
  if (line.size() > kQuoteLength) text += "...";
  return "'" + text + "'";
}

class XyzParser {
public:
  XyzParser(const std::string& path, PointCloud& cloud) : path_(path), cloud_(cloud) {}

  void line(std::string_view text);

  // The line after the last complete one is too long.
  [[noreturn]] void too_long() const {
    throw InputError(path_, "line " + std::to_string(number_ + 1),
                     "longer than " + std::to_string(kMaxLine) + " characters: not an 'x y z [class]' text file");
  }

private:
  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(path_, "line " + std::to_string(number_), problem);
  }

  const std::string& path_;
  PointCloud& cloud_;
  size_t number_ = 0;  // of the current line, from 1
  bool seen_data_ = false;
};

void XyzParser::line(std::string_view text) {
  ++number_;
  if (number_ == 1 && text.starts_with("\xEF\xBB\xBF")) text.remove_prefix(3);  // UTF-8 byte order mark
  const size_t first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos || text[first] == '#') return;
  // Exports often start with a column header ("X Y Z Classification"); data always has digits.
  const bool first_content = !seen_data_;
  seen_data_ = true;
  if (first_content &&
      std::none_of(text.begin(), text.end(), [](char c) { return std::isdigit(static_cast<unsigned char>(c)); }))
    return;

  double value[4];
  int count = 0;
  for (size_t pos = 0;;) {
    while (pos < text.size() && is_separator(text[pos])) ++pos;
    if (pos == text.size()) break;
    size_t end = pos;
    while (end < text.size() && !is_separator(text[end])) ++end;
    if (count == 4) fail(std::string(kExpected) + quoted(text));
    std::string_view token = text.substr(pos, end - pos);
    if (token.size() > 1 && token[0] == '+' && token[1] != '+' && token[1] != '-') token.remove_prefix(1);
    const auto [stop, error] = std::from_chars(token.data(), token.data() + token.size(), value[count]);
    if (error != std::errc() || stop != token.data() + token.size()) fail(std::string(kExpected) + quoted(text));
    if (!std::isfinite(value[count])) fail("'" + std::string(token) + "' is not a finite number in " + quoted(text));
    ++count;
    pos = end;
  }
  if (count < 3) fail(std::string(kExpected) + quoted(text));

  uint8_t cls = 0;
  if (count == 4) {
    const double c = value[3];
    if (c < 0 || c > 255 || c != std::floor(c)) fail("the class must be an integer 0-255 in " + quoted(text));
    cls = static_cast<uint8_t>(c);
  }
  cloud_.add(value[0], value[1], value[2], cls);
}

}  // namespace

PointCloud read_xyz(const std::string& path, const Progress& progress) {
  require_input_file(path);
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, "", "is a directory, not a point file");
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> file(std::fopen(path.c_str(), "rb"), &std::fclose);
  if (!file) throw InputError(path, "", std::string("cannot open: ") + std::strerror(errno));
  const uintmax_t size = std::filesystem::file_size(path, ec);
  // Memory up front, from the file's size: a point line of real coordinates has at least about
  // 20 characters ("356300.5 5699750.5 51"), and each point costs 25 bytes (PointCloud: three
  // doubles and a class byte, in vectors that may double when they grow: counted once here).
  if (!ec) require_memory(path, "", double(size) / 20 * (3 * sizeof(double) + sizeof(uint8_t)));

  PointCloud cloud;
  XyzParser parser(path, cloud);
  // A chunk no larger than the file: a few-line file costs no 4 MB buffer (which, zeroed and
  // freed on every call, made the fuzzer 100x slower).
  std::vector<char> chunk(ec ? kChunk : static_cast<size_t>(std::clamp<uintmax_t>(size + 1, 1, kChunk)));
  std::string partial;  // a line split across two chunks
  uintmax_t done = 0;
  while (const size_t got = std::fread(chunk.data(), 1, chunk.size(), file.get())) {
    std::string_view rest(chunk.data(), got);
    for (size_t newline; (newline = rest.find('\n')) != std::string_view::npos; rest.remove_prefix(newline + 1)) {
      if (partial.empty()) {
        parser.line(rest.substr(0, newline));
      } else {
        partial.append(rest.substr(0, newline));
        parser.line(partial);
        partial.clear();
      }
    }
    partial.append(rest);
    if (partial.size() > kMaxLine) parser.too_long();
    done += got;
    if (!ec && size > 0) report(progress, static_cast<double>(done) / static_cast<double>(size));
  }
  if (std::ferror(file.get())) throw InputError(path, "", std::string("cannot read: ") + std::strerror(errno));
  if (!partial.empty()) parser.line(partial);
  report(progress, 1.0);
  return cloud;
}

PointCloud read_points(const std::string& path, const Progress& progress) {
  const std::string extension = lower_case(std::filesystem::path(path).extension().string());
  // .laz goes to read_las too: it decodes LASzip-compressed points (src/io/laz).
  if (extension == ".las" || extension == ".laz") return read_las(path, progress);
  if (extension == ".xyz" || extension == ".txt" || extension == ".csv") return read_xyz(path, progress);
  throw InputError(path, "",
                   (extension.empty() ? std::string("no file extension") : "unknown extension '" + extension + "'") +
                       ": point clouds are read from .las, .laz, .xyz, .txt or .csv files");
}

}  // namespace dsmplan
