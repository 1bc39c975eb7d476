// Mesh files in: what write_mesh writes, and the common variants of the same formats other tools
// write. PLY after Turk, "The PLY Polygon File Format" (ascii, binary_little_endian and
// binary_big_endian 1.0); Wavefront OBJ ("v" and "f" statements of the OBJ spec, Appendix B1);
// OFF as in Geomview's OFF(5). The CRS comes back from the header comments crs_lines() in
// mesh_writer.cpp writes. Every count a header declares is checked against the file size
// before anything is reserved, so a lying header costs an error, never memory.
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "core/huge_pages.hpp"
#include "core/mapped_file.hpp"
#include "core/text.hpp"
#include "dsmplan/export.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {

namespace {

constexpr uint64_t kMaxVertices = std::numeric_limits<uint32_t>::max();  // Triangle holds uint32 indices
constexpr size_t kProgressBytes = size_t{1} << 20;

std::string line_place(size_t line) { return "line " + std::to_string(line); }
std::string byte_place(size_t byte) { return "byte " + std::to_string(byte); }

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && is_blank(s.front())) s.remove_prefix(1);
  while (!s.empty() && is_blank(s.back())) s.remove_suffix(1);
  return s;
}

// Splits on blanks; `out` is reused so a line costs no allocation once it has grown.
void split(std::string_view line, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && is_blank(line[i])) ++i;
    const size_t begin = i;
    while (i < line.size() && !is_blank(line[i])) ++i;
    if (i > begin) out.push_back(line.substr(begin, i - begin));
  }
}

// from_chars does not take a leading '+', which some writers print.
std::string_view without_plus(std::string_view s) {
  return s.size() > 1 && s.front() == '+' && s[1] != '-' ? s.substr(1) : s;
}

template <typename T>
bool parse_number(std::string_view text, T& value) {
  text = without_plus(text);
  const char* end = text.data() + text.size();
  auto [stop, ec] = std::from_chars(text.data(), end, value);
  return ec == std::errc() && stop == end;
}

// Whole file mapped where it lies: every format here needs random access for its checks, and a
// mapping costs no copy and no fresh pages (a 2 M-triangle PLY: 50 MB the page cache holds).
std::shared_ptr<const MappedFile> map_whole_file(const std::string& path) {
  require_input_file(path);
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (ec || !std::filesystem::exists(status)) {
    throw InputError(path, "", "cannot open: " + std::string(std::strerror(ENOENT)));
  }
  if (std::filesystem::is_directory(status)) throw InputError(path, "", "is a directory, not a mesh file");
  if (!std::filesystem::is_regular_file(status)) throw InputError(path, "", "not a regular file");
  std::shared_ptr<const MappedFile> file = MappedFile::open(path);
  if (file->size() == 0) throw InputError(path, "", "empty file, not a mesh");
  return file;
}

// The CRS lines of crs_lines() in mesh_writer.cpp, from comments in any of the formats. The
// first line of each kind counts; comments that are not CRS lines are ignored.
class CrsComments {
public:
  explicit CrsComments(const std::string& path) : path_(path) {}

  void comment(std::string_view text, const std::string& place) {
    text = trim(text);
    const size_t space = text.find_first_of(" \t");
    const std::string_view key = text.substr(0, space);
    const std::string_view value = space == std::string_view::npos ? std::string_view{} : trim(text.substr(space));
    if (key == "crs_name" && !name_) {
      name_ = std::string(value);
    } else if (key == "crs_epsg" && !epsg_) {
      int code = 0;
      if (!parse_number(value, code) || code <= 0) {
        throw InputError(path_, place, "crs_epsg " + shown(value) + " is not an EPSG code");
      }
      epsg_ = code;
    } else if (key == "crs_wkt" && !wkt_) {
      wkt_ = std::string(value);
    } else if (key == "crs_wkt_part") {
      // "K/N PIECE": the WKT cut into lines short enough for every PLY reader (mesh_writer.cpp).
      const size_t slash = value.find('/'), blank = value.find(' ');
      int k = 0, n = 0;
      if (slash == std::string_view::npos || blank == std::string_view::npos || blank < slash ||
          !parse_number(value.substr(0, slash), k) || !parse_number(value.substr(slash + 1, blank - slash - 1), n) ||
          k < 1 || n < 1 || k > n || n > 1000)
        throw InputError(path_, place, "crs_wkt_part " + shown(value) + " is not 'K/N PIECE'");
      if (parts_total_ && *parts_total_ != n)
        throw InputError(path_, place, "crs_wkt_part: the parts disagree on their count");
      parts_total_ = n;
      parts_[k] = std::string(trim(value.substr(blank)));
    } else if (key == "vertical" && !vertical_) {
      vertical_ = std::string(value);
    }
  }

  Crs crs() const {
    Crs crs;
    if (name_ && *name_ != "unknown") crs.name = *name_;
    if (epsg_) crs.epsg = *epsg_;
    if (wkt_) {
      crs.wkt = *wkt_;
    } else if (parts_total_ && parts_.size() == static_cast<size_t>(*parts_total_)) {
      for (const auto& [k, piece] : parts_) crs.wkt += piece;
    }
    crs.definition = !crs.wkt.empty() ? crs.wkt : crs.epsg ? "EPSG:" + std::to_string(crs.epsg) : "";
    crs.geographic = geographic_wkt(crs.wkt);
    if (vertical_) {
      // "NAME (UNIT)", "unknown (UNIT)", "NAME" or "unknown": the writer's four shapes.
      std::string name = *vertical_;
      const size_t open = name.rfind(" (");
      if (!name.empty() && name.back() == ')' && open != std::string::npos) {
        crs.vertical_unit = name.substr(open + 2, name.size() - open - 3);
        name.erase(open);
      }
      if (name != "unknown") crs.vertical_name = name;
    }
    return crs;
  }

  // The core has no PROJ: a WKT whose first (horizontal) CRS keyword is geographic or
  // geodetic says enough. BASEGEOGCRS inside a PROJCRS comes after the PROJCRS keyword.
  static bool geographic_wkt(const std::string& wkt) {
    size_t first = std::string::npos;
    bool geographic = false;
    for (const char* keyword : {"PROJCRS[", "PROJCS[", "PROJECTEDCRS[", "GEOGCRS[", "GEOGCS[", "GEOGRAPHICCRS[",
                                "GEODCRS[", "GEODETICCRS["}) {
      const size_t at = wkt.find(keyword);
      if (at < first) {
        first = at;
        geographic = keyword[0] == 'G';
      }
    }
    return geographic;
  }

private:
  const std::string& path_;
  std::optional<std::string> name_, wkt_, vertical_;
  std::optional<int> epsg_, parts_total_;
  std::map<int, std::string> parts_;  ///< crs_wkt_part K -> its piece
};

// Lines of a text file with their numbers (from 1) and byte offsets.
class Lines {
public:
  explicit Lines(std::string_view text) : text_(text) {}
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    offset_ = pos_;
    const size_t end = text_.find('\n', pos_);
    const size_t stop = end == std::string_view::npos ? text_.size() : end;
    line = text_.substr(pos_, stop - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = stop + 1;
    ++number_;
    return true;
  }
  size_t number() const { return number_; }
  size_t offset() const { return offset_; }

private:
  std::string_view text_;
  size_t pos_ = 0, offset_ = 0, number_ = 0;
};

class ProgressByBytes {
public:
  ProgressByBytes(const Progress& progress, size_t total) : progress_(progress), total_(total) {}
  void at(size_t byte) {
    if (progress_ && byte >= next_) {
      report(progress_, 0.99 * static_cast<double>(byte) / total_);
      next_ = byte + kProgressBytes;
    }
  }

private:
  const Progress& progress_;
  size_t total_, next_ = 0;
};

// ---- PLY ----------------------------------------------------------------------------------

enum class PlyType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Float32, Float64 };

std::optional<PlyType> ply_type(std::string_view name) {
  if (name == "char" || name == "int8") return PlyType::Int8;
  if (name == "uchar" || name == "uint8") return PlyType::UInt8;
  if (name == "short" || name == "int16") return PlyType::Int16;
  if (name == "ushort" || name == "uint16") return PlyType::UInt16;
  if (name == "int" || name == "int32") return PlyType::Int32;
  if (name == "uint" || name == "uint32") return PlyType::UInt32;
  if (name == "float" || name == "float32") return PlyType::Float32;
  if (name == "double" || name == "float64") return PlyType::Float64;
  return std::nullopt;
}

size_t type_size(PlyType type) {
  switch (type) {
    case PlyType::Int8:
    case PlyType::UInt8:
      return 1;
    case PlyType::Int16:
    case PlyType::UInt16:
      return 2;
    case PlyType::Int32:
    case PlyType::UInt32:
    case PlyType::Float32:
      return 4;
    case PlyType::Float64:
      return 8;
  }
  return 8;
}

bool is_float(PlyType type) { return type == PlyType::Float32 || type == PlyType::Float64; }

enum class PlyFormat { Ascii, BinaryLittle, BinaryBig };

// What a property is for: everything but x, y, z and the face's index list is skipped.
enum class Role { Skip, X, Y, Z, Indices };

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::Float64;
  bool list = false;
  PlyType count_type = PlyType::UInt8;
  Role role = Role::Skip;
};

struct PlyElement {
  std::string name;
  uint64_t count = 0;
  std::vector<PlyProperty> properties;
  size_t line = 0;  // of its "element" header line
};

class PlyReader {
public:
  PlyReader(const std::string& path, std::string_view bytes, const Progress& progress)
      : path_(path), bytes_(bytes), crs_(path), progress_(progress, bytes.size()) {}

  /// The header alone (`bytes` may end right after it): its CRS.
  Crs header_crs() {
    header();
    return crs_.crs();
  }

  Mesh read() {
    header();
    check_sizes();
    Mesh mesh;
    for (const PlyElement& element : elements_) {
      if (element.name == "vertex") mesh.vertices.reserve(element.count);
      if (element.name == "face") mesh.triangles.reserve(element.count);
    }
    if (format_ == PlyFormat::Ascii) {
      read_ascii(mesh);
    } else {
      read_binary(mesh);
    }
    mesh.crs = crs_.crs();
    return mesh;
  }

private:
  [[noreturn]] void fail(const std::string& place, const std::string& problem) const {
    throw InputError(path_, place, problem);
  }

  void header() {
    if (bytes_.compare(0, 4, "ply\n") != 0 && bytes_.compare(0, 5, "ply\r\n") != 0) {
      fail("header", "not a PLY file (it does not start with a 'ply' line)");
    }
    Lines lines(bytes_);
    std::string_view line;
    lines.next(line);
    std::vector<std::string_view> words;
    bool have_format = false;
    while (true) {
      if (!lines.next(line)) fail("header", "no 'end_header' line: the header never ends");
      const std::string place = line_place(lines.number());
      split(line, words);
      if (words.empty()) continue;
      const std::string_view keyword = words[0];
      if (keyword == "end_header") {
        const size_t end = lines.offset() + line.size();
        body_ = lines.offset() + (end < bytes_.size() && bytes_[end] == '\r' ? line.size() + 2 : line.size() + 1);
        body_ = std::min(body_, bytes_.size());
        break;
      }
      if (keyword == "comment") {
        const size_t at = line.find("comment") + 7;
        crs_.comment(line.substr(at), place);
      } else if (keyword == "obj_info") {
        // free text, nothing for us
      } else if (keyword == "format") {
        if (have_format) fail(place, "a second 'format' line");
        if (words.size() != 3 || words[2] != "1.0") fail(place, "expected 'format <encoding> 1.0'");
        if (words[1] == "ascii") {
          format_ = PlyFormat::Ascii;
        } else if (words[1] == "binary_little_endian") {
          format_ = PlyFormat::BinaryLittle;
        } else if (words[1] == "binary_big_endian") {
          format_ = PlyFormat::BinaryBig;
        } else {
          fail(place, "unknown PLY encoding " + shown(words[1]));
        }
        have_format = true;
      } else if (keyword == "element") {
        if (!have_format) fail(place, "'element' before the 'format' line");
        uint64_t count = 0;
        if (words.size() != 3 || !parse_number(words[2], count)) fail(place, "expected 'element <name> <count>'");
        for (const PlyElement& e : elements_) {
          if (e.name == words[1]) fail(place, "a second element " + shown(words[1]));
        }
        elements_.push_back({std::string(words[1]), count, {}, lines.number()});
      } else if (keyword == "property") {
        if (elements_.empty()) fail(place, "'property' before any 'element'");
        property(words, place);
      } else {
        fail(place, "unknown header keyword " + shown(keyword));
      }
    }
    if (!have_format) fail("header", "no 'format' line");
    resolve_roles();
  }

  void property(const std::vector<std::string_view>& words, const std::string& place) {
    PlyElement& element = elements_.back();
    PlyProperty p;
    if (words.size() == 5 && words[1] == "list") {
      const auto count_type = ply_type(words[2]), type = ply_type(words[3]);
      if (!count_type || !type) fail(place, "unknown property type in a list");
      if (is_float(*count_type)) fail(place, "a list count must be an integer type");
      p.list = true;
      p.count_type = *count_type;
      p.type = *type;
      p.name = words[4];
    } else if (words.size() == 3) {
      const auto type = ply_type(words[1]);
      if (!type) fail(place, "unknown property type " + shown(words[1]));
      p.type = *type;
      p.name = words[2];
    } else {
      fail(place, "expected 'property <type> <name>' or 'property list <type> <type> <name>'");
    }
    for (const PlyProperty& q : element.properties) {
      if (q.name == p.name) fail(place, "a second property " + shown(p.name) + " in element " + element.name);
    }
    element.properties.push_back(p);
  }

  void resolve_roles() {
    const PlyElement* vertex = nullptr;
    for (PlyElement& element : elements_) {
      const std::string place = line_place(element.line);
      if (element.properties.empty() && element.count > 0) {
        fail(place, "element " + element.name + " has records but no properties");
      }
      if (element.name == "vertex") {
        vertex = &element;
        for (const char* axis : {"x", "y", "z"}) {
          auto it = std::find_if(element.properties.begin(), element.properties.end(),
                                 [&](const PlyProperty& p) { return p.name == axis; });
          if (it == element.properties.end()) fail(place, std::string("the vertex element has no property ") + axis);
          if (it->list || !is_float(it->type)) {
            fail(place, std::string("vertex property ") + axis + " must be float or double");
          }
          it->role = axis[0] == 'x' ? Role::X : axis[0] == 'y' ? Role::Y : Role::Z;
        }
        if (element.count > kMaxVertices) {
          fail(place, std::to_string(element.count) + " vertices are more than 32-bit indices can address");
        }
        vertices_ = element.count;
      } else if (element.name == "face") {
        auto it = std::find_if(element.properties.begin(), element.properties.end(), [](const PlyProperty& p) {
          return p.name == "vertex_indices" || p.name == "vertex_index";
        });
        if (it == element.properties.end()) fail(place, "the face element has no vertex_indices list");
        if (!it->list || is_float(it->type)) fail(place, "vertex_indices must be a list of integers");
        it->role = Role::Indices;
      }
    }
    if (!vertex) fail("header", "no vertex element");
  }

  // A header may say anything; the smallest record each element can have, times its count,
  // must fit in what follows the header.
  void check_sizes() const {
    const uint64_t available = bytes_.size() - body_;
    uint64_t needed = 0;
    for (const PlyElement& element : elements_) {
      uint64_t record = 0;
      for (const PlyProperty& p : element.properties) {
        if (format_ == PlyFormat::Ascii) {
          record += 2;  // a digit and a separator
        } else {
          record += p.list ? type_size(p.count_type) + (p.role == Role::Indices ? 3 * type_size(p.type) : 0)
                           : type_size(p.type);
        }
        if (format_ == PlyFormat::Ascii && p.role == Role::Indices) record += 6;  // "3 a b c"
      }
      const uint64_t room = available + 1 - std::min(available + 1, needed);  // +1: no final newline
      if (record > 0 && element.count > room / record) {
        fail(line_place(element.line), "element " + element.name + " declares " + std::to_string(element.count) +
                                           " records of at least " + std::to_string(record) + " bytes, but only " +
                                           std::to_string(available) + " bytes follow the header");
      }
      needed += element.count * record;
    }
  }

  // ---- binary ----

  template <typename T>
  T load(size_t at) const {
    T value;
    std::memcpy(&value, bytes_.data() + at, sizeof(T));
    if (format_ == PlyFormat::BinaryBig) {
      auto* b = reinterpret_cast<unsigned char*>(&value);
      std::reverse(b, b + sizeof(T));
    }
    return value;
  }

  void need(size_t bytes, const PlyElement& element, uint64_t record) const {
    if (bytes > bytes_.size() - pos_) {
      fail(byte_place(pos_), "the file ends inside " + element.name + " " + std::to_string(record) + " of " +
                                 std::to_string(element.count));
    }
  }

  double number_at(PlyType type, size_t at) const {
    switch (type) {
      case PlyType::Int8:
        return load<int8_t>(at);
      case PlyType::UInt8:
        return load<uint8_t>(at);
      case PlyType::Int16:
        return load<int16_t>(at);
      case PlyType::UInt16:
        return load<uint16_t>(at);
      case PlyType::Int32:
        return load<int32_t>(at);
      case PlyType::UInt32:
        return load<uint32_t>(at);
      case PlyType::Float32:
        return load<float>(at);
      case PlyType::Float64:
        return load<double>(at);
    }
    return 0;
  }

  double binary_number(PlyType type) {
    const double value = number_at(type, pos_);
    pos_ += type_size(type);
    return value;
  }

  // Records of one fixed layout, the layout of dsmplan's own files and of most writers'
  // (vertices of scalar properties, faces of a single index list), read without looking up
  // each property's type and role again: a 2 M-triangle mesh in a third of the time. Stops at
  // the first record that breaks the layout or a rule (a list of 4, an index out of range, a
  // coordinate that is not finite, the file's end), which the general loop then reads and
  // names. Returns the records read.
  uint64_t read_regular_records(const PlyElement& element, Mesh& mesh) {
    if (element.name == "vertex") {
      size_t record = 0, offset[3] = {0, 0, 0};
      PlyType type[3] = {};
      int found = 0;
      for (const PlyProperty& p : element.properties) {
        if (p.list) return 0;
        if (p.role == Role::X || p.role == Role::Y || p.role == Role::Z) {
          const int k = static_cast<int>(p.role) - 1;
          offset[k] = record, type[k] = p.type, found |= 1 << k;
        }
        record += type_size(p.type);
      }
      if (found != 7) return 0;
      const uint64_t n = std::min<uint64_t>(element.count, (bytes_.size() - pos_) / record);
      return convert_records(n, record, mesh.vertices, [&](size_t at, Vertex& v) {
        v = {number_at(type[0], at + offset[0]), number_at(type[1], at + offset[1]),
             number_at(type[2], at + offset[2])};
        return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
      });
    }
    if (element.properties.size() != 1 || element.properties[0].role != Role::Indices) return 0;
    const PlyProperty& list = element.properties[0];
    const size_t count_size = type_size(list.count_type), index_size = type_size(list.type);
    const size_t record = count_size + 3 * index_size;
    const double vertices = static_cast<double>(vertices_);
    const uint64_t n = std::min<uint64_t>(element.count, (bytes_.size() - pos_) / record);
    return convert_records(n, record, mesh.triangles, [&](size_t at, Triangle& t) {
      if (number_at(list.count_type, at) != 3) return false;
      at += count_size;
      const double a = number_at(list.type, at), b = number_at(list.type, at + index_size),
                   c = number_at(list.type, at + 2 * index_size);
      if (!(a >= 0 && a < vertices && b >= 0 && b < vertices && c >= 0 && c < vertices) || a == b || b == c || a == c)
        return false;
      t = {static_cast<uint32_t>(a), static_cast<uint32_t>(b), static_cast<uint32_t>(c)};
      return true;
    });
  }

  // Records [0, n) of a regular element from pos_ on, `record` bytes each, appended to `out`:
  // in parallel (a plan's first run spent a seventh of its time here, on one core), a million
  // records a round with the progress between rounds. `convert(byte, item)` is false for a record
  // the fast path does not take (not finite, not a triangle, an index out of range): the first
  // such ends it there, and the record-by-record loop goes on from it to name the problem.
  template <class T, class Convert>
  uint64_t convert_records(uint64_t n, size_t record, std::vector<T>& out, const Convert& convert) {
    const size_t first = out.size();
    out.resize(first + n);
    std::atomic<uint64_t> stop{n};
    const size_t base = pos_;
    constexpr uint64_t round = uint64_t(1) << 20, slice = uint64_t(1) << 14;
    for (uint64_t begin = 0; begin < stop.load(std::memory_order_relaxed); begin += round) {
      progress_.at(base + begin * record);
      tbb::parallel_for(tbb::blocked_range<uint64_t>(begin, std::min(n, begin + round), slice),
                        [&](const tbb::blocked_range<uint64_t>& range) {
                          for (uint64_t i = range.begin(); i != range.end(); ++i)
                            if (!convert(base + i * record, out[first + i])) {
                              uint64_t seen = stop.load(std::memory_order_relaxed);
                              while (i < seen && !stop.compare_exchange_weak(seen, i, std::memory_order_relaxed)) {
                              }
                              return;
                            }
                        });
    }
    const uint64_t good = stop.load();
    out.resize(first + good);
    pos_ = base + good * record;
    return good;
  }

  void read_binary(Mesh& mesh) {
    pos_ = body_;
    for (const PlyElement& element : elements_) {
      reserve_for(element, mesh);
      for (uint64_t i = format_ == PlyFormat::BinaryLittle ? read_regular_records(element, mesh) : 0; i < element.count;
           ++i) {
        progress_.at(pos_);
        const size_t record_start = pos_;
        double xyz[3] = {0, 0, 0};
        for (const PlyProperty& p : element.properties) {
          if (!p.list) {
            need(type_size(p.type), element, i);
            const double value = binary_number(p.type);
            if (p.role != Role::Skip && p.role != Role::Indices) xyz[static_cast<int>(p.role) - 1] = value;
            continue;
          }
          need(type_size(p.count_type), element, i);
          const size_t count_at = pos_;
          const double count = binary_number(p.count_type);
          if (count < 0)
            fail(byte_place(count_at), "negative list length in " + element.name + " " + std::to_string(i));
          const auto n = static_cast<uint64_t>(count);
          if (p.role == Role::Indices) {
            if (n != 3) fail(byte_place(count_at), triangle_problem(i, n));
            need(3 * type_size(p.type), element, i);
            std::array<double, 3> index{};
            for (double& v : index) v = binary_number(p.type);
            mesh.triangles.push_back(triangle(index, i, [&] { return byte_place(count_at); }));
          } else {
            // Compared by division: n * size could overflow for a lying count.
            if (n > (bytes_.size() - pos_) / type_size(p.type)) need(bytes_.size() - pos_ + 1, element, i);
            pos_ += n * type_size(p.type);
          }
        }
        if (element.name == "vertex") mesh.vertices.push_back(vertex(xyz, i, [&] { return byte_place(record_start); }));
      }
    }
    if (pos_ != bytes_.size()) {
      fail(byte_place(pos_),
           std::to_string(bytes_.size() - pos_) +
               " bytes after the last element: the header declares fewer records than the file holds");
    }
  }

  // ---- ascii ----

  // Next blank-separated word of the body, tracking its line.
  std::string_view word(const PlyElement& element, uint64_t record) {
    while (pos_ < bytes_.size() && is_blank(bytes_[pos_])) {
      if (bytes_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ >= bytes_.size()) {
      fail(line_place(line_), "the file ends inside " + element.name + " " + std::to_string(record) + " of " +
                                  std::to_string(element.count));
    }
    const size_t begin = pos_;
    while (pos_ < bytes_.size() && !is_blank(bytes_[pos_])) ++pos_;
    return std::string_view(bytes_).substr(begin, pos_ - begin);
  }

  double ascii_number(PlyType type, const PlyElement& element, uint64_t record) {
    const std::string_view text = word(element, record);
    bool ok = false;
    double value = 0;
    if (type == PlyType::Float32) {
      float f = 0;  // as a float it was written, as a float it is read: the same value as binary
      ok = parse_number(text, f);
      value = f;
    } else if (type == PlyType::Float64) {
      ok = parse_number(text, value);
    } else {
      int64_t n = 0;
      ok = parse_number(text, n);
      value = static_cast<double>(n);
    }
    if (!ok)
      fail(line_place(line_),
           "expected a number in " + element.name + " " + std::to_string(record) + ", got " + shown(text));
    return value;
  }

  void read_ascii(Mesh& mesh) {
    pos_ = body_;
    line_ = 1 + static_cast<size_t>(std::count(bytes_.begin(), bytes_.begin() + body_, '\n'));
    for (const PlyElement& element : elements_) {
      reserve_for(element, mesh);
      for (uint64_t i = 0; i < element.count; ++i) {
        progress_.at(pos_);
        double xyz[3] = {0, 0, 0};
        size_t record_line = 0;
        for (const PlyProperty& p : element.properties) {
          if (!p.list) {
            const double value = ascii_number(p.type, element, i);
            if (!record_line) record_line = line_;
            if (p.role != Role::Skip && p.role != Role::Indices) xyz[static_cast<int>(p.role) - 1] = value;
            continue;
          }
          const double count = ascii_number(p.count_type, element, i);
          if (!record_line) record_line = line_;
          if (count < 0) fail(line_place(line_), "negative list length in " + element.name + " " + std::to_string(i));
          const auto n = static_cast<uint64_t>(count);
          if (p.role == Role::Indices) {
            if (n != 3) fail(line_place(line_), triangle_problem(i, n));
            std::array<double, 3> index{};
            for (double& v : index) v = ascii_number(p.type, element, i);
            mesh.triangles.push_back(triangle(index, i, [&] { return line_place(line_); }));
          } else {
            // A list longer than the rest of the file cannot be there: word() stops at the end.
            for (uint64_t k = 0; k < n; ++k) ascii_number(p.type, element, i);
          }
        }
        if (element.name == "vertex") mesh.vertices.push_back(vertex(xyz, i, [&] { return line_place(record_line); }));
      }
    }
    while (pos_ < bytes_.size() && is_blank(bytes_[pos_])) {
      if (bytes_[pos_] == '\n') ++line_;
      ++pos_;
    }
    if (pos_ != bytes_.size()) {
      fail(line_place(line_), "data after the last element: the header declares fewer records than the file holds");
    }
  }

  // ---- shared ----

  // Room for an element's records at once (no regrowth), never more than the rest of the file
  // could hold at a byte per property: a lying count reserves nothing it could not fill.
  void reserve_for(const PlyElement& element, Mesh& mesh) const {
    const uint64_t most =
        (bytes_.size() - std::min(pos_, bytes_.size())) / std::max<size_t>(1, element.properties.size());
    const auto records = static_cast<size_t>(std::min(element.count, most));
    if (element.name == "vertex") detail::reserve_on_huge_pages(mesh.vertices, mesh.vertices.size() + records);
    for (const PlyProperty& p : element.properties)
      if (p.role == Role::Indices) detail::reserve_on_huge_pages(mesh.triangles, mesh.triangles.size() + records);
  }

  // `place` makes the message's place only when there is a message (millions of records).
  template <class Place>
  Vertex vertex(const double (&xyz)[3], uint64_t i, Place&& place) const {
    if (!std::isfinite(xyz[0]) || !std::isfinite(xyz[1]) || !std::isfinite(xyz[2])) {
      fail(place(), "vertex " + std::to_string(i) + " has a coordinate that is not a finite number");
    }
    return {xyz[0], xyz[1], xyz[2]};
  }

  template <class Place>
  Triangle triangle(const std::array<double, 3>& index, uint64_t face, Place&& place) const {
    Triangle t{};
    for (int k = 0; k < 3; ++k) {
      if (!(index[k] >= 0 && index[k] < static_cast<double>(vertices_))) {
        fail(place(), "face " + std::to_string(face) + " refers to vertex " +
                          std::to_string(static_cast<int64_t>(index[k])) + ", but there are " +
                          std::to_string(vertices_) + " vertices");
      }
      t[k] = static_cast<uint32_t>(index[k]);
    }
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      fail(place(), "face " + std::to_string(face) + " names the same vertex twice");
    }
    return t;
  }

  static std::string triangle_problem(uint64_t face, uint64_t n) {
    return "face " + std::to_string(face) + " has " + std::to_string(n) + " vertices; only triangles are accepted";
  }

  const std::string& path_;
  std::string_view bytes_;
  CrsComments crs_;
  ProgressByBytes progress_;
  PlyFormat format_ = PlyFormat::Ascii;
  std::vector<PlyElement> elements_;
  uint64_t vertices_ = 0;
  size_t body_ = 0, pos_ = 0, line_ = 0;
};

// ---- text formats ---------------------------------------------------------------------------

// An index word of an OBJ "f" statement: "v", "v/vt", "v/vt/vn" or "v//vn".
struct ObjCorner {
  int64_t v = 0, vt = 0, vn = 0;  // as written: 1-based, negative relative, 0 = absent
};

bool parse_corner(std::string_view word, ObjCorner& corner) {
  std::array<std::string_view, 3> parts{};
  size_t n = 0;
  size_t begin = 0;
  while (true) {
    const size_t slash = word.find('/', begin);
    if (n == 3) return false;
    parts[n++] = word.substr(begin, slash == std::string_view::npos ? std::string_view::npos : slash - begin);
    if (slash == std::string_view::npos) break;
    begin = slash + 1;
  }
  if (!parse_number(parts[0], corner.v) || corner.v == 0) return false;
  if (n > 1 && !parts[1].empty() && (!parse_number(parts[1], corner.vt) || corner.vt == 0)) return false;
  if (n > 2 && (!parse_number(parts[2], corner.vn) || corner.vn == 0)) return false;
  return true;
}

class ObjReader {
public:
  ObjReader(const std::string& path, std::string_view bytes, const Progress& progress)
      : path_(path), bytes_(bytes), crs_(path), progress_(progress, bytes.size()) {}

  Mesh read() {
    Mesh mesh;
    Lines lines(bytes_);
    std::string_view line;
    std::vector<std::string_view> words;
    while (lines.next(line)) {
      progress_.at(lines.offset());
      const std::string_view content = trim(line);
      if (content.empty()) continue;
      if (content.front() == '#') {
        crs_.comment(content.substr(1), line_place(lines.number()));
        continue;
      }
      split(content.substr(0, content.find('#')), words);
      if (words.empty()) continue;
      line_ = lines.number();
      const std::string_view keyword = words[0];
      if (keyword == "v") {
        vertex(words, mesh);
      } else if (keyword == "f") {
        face(words, mesh);
      } else if (keyword == "vt") {
        ++texture_coordinates_;
      } else if (keyword == "vn") {
        ++normals_;
      } else if (!ignored(keyword)) {
        fail("unknown statement " + shown(keyword) + ": not a Wavefront OBJ file");
      }
    }
    // Positive indices may point forward, so they are checked once every vertex is known.
    check_forward(max_v_, mesh.vertices.size(), "vertex");
    check_forward(max_vt_, texture_coordinates_, "texture coordinate");
    check_forward(max_vn_, normals_, "normal");
    mesh.crs = crs_.crs();
    return mesh;
  }

private:
  struct Forward {
    int64_t index = 0;
    size_t line = 0;
  };

  [[noreturn]] void fail(const std::string& problem) const { throw InputError(path_, line_place(line_), problem); }

  // Statements that say nothing about the triangle surface (groups, materials, smoothing,
  // free-form geometry, points and lines).
  static bool ignored(std::string_view keyword) {
    static constexpr std::array<std::string_view, 28> kIgnored = {
        "o",    "g",    "s",    "usemtl", "mtllib", "vp",       "l",        "p",     "cstype", "deg",
        "bmat", "step", "curv", "curv2",  "surf",   "parm",     "trim",     "hole",  "scrv",   "sp",
        "end",  "con",  "mg",   "bevel",  "lod",    "c_interp", "d_interp", "usemap"};
    return std::find(kIgnored.begin(), kIgnored.end(), keyword) != kIgnored.end();
  }

  void vertex(const std::vector<std::string_view>& words, Mesh& mesh) {
    if (words.size() < 4) fail("expected 'v x y z', got " + std::to_string(words.size() - 1) + " numbers");
    double xyz[3];
    for (size_t k = 1; k < words.size(); ++k) {
      double value = 0;
      if (!parse_number(words[k], value)) fail("expected a number, got " + shown(words[k]));
      if (k <= 3) xyz[k - 1] = value;
      if (k <= 3 && !std::isfinite(value)) {
        fail("vertex " + std::to_string(mesh.vertices.size() + 1) + " has a coordinate that is not a finite number");
      }
    }
    if (mesh.vertices.size() >= kMaxVertices) fail("more vertices than 32-bit indices can address");
    mesh.vertices.push_back({xyz[0], xyz[1], xyz[2]});
  }

  // An OBJ index as 0-based, or -1 for a forward reference checked later.
  int64_t resolve(int64_t index, uint64_t defined, Forward& forward, const char* what) {
    if (index < 0) {
      if (static_cast<uint64_t>(-index) > defined) {
        fail(std::string("relative ") + what + " index " + std::to_string(index) + " reaches before the first " + what);
      }
      return static_cast<int64_t>(defined) + index;
    }
    if (index > forward.index) forward = {index, line_};
    return index - 1;
  }

  void face(const std::vector<std::string_view>& words, Mesh& mesh) {
    if (words.size() != 4) {
      fail("a face with " + std::to_string(words.size() - 1) + " vertices; only triangles are accepted");
    }
    Triangle t{};
    for (int k = 0; k < 3; ++k) {
      ObjCorner corner;
      if (!parse_corner(words[k + 1], corner)) {
        fail("expected a vertex reference 'v', 'v/vt', 'v/vt/vn' or 'v//vn', got " + shown(words[k + 1]));
      }
      const int64_t v = resolve(corner.v, mesh.vertices.size(), max_v_, "vertex");
      if (corner.vt) resolve(corner.vt, texture_coordinates_, max_vt_, "texture coordinate");
      if (corner.vn) resolve(corner.vn, normals_, max_vn_, "normal");
      if (v > static_cast<int64_t>(kMaxVertices)) fail("vertex index " + std::to_string(corner.v) + " is too large");
      t[k] = static_cast<uint32_t>(v);
    }
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) fail("the face names the same vertex twice");
    mesh.triangles.push_back(t);
  }

  void check_forward(const Forward& forward, uint64_t defined, const char* what) {
    if (forward.index > 0 && static_cast<uint64_t>(forward.index) > defined) {
      line_ = forward.line;
      fail(std::string(what) + " " + std::to_string(forward.index) + " does not exist: the file has " +
           std::to_string(defined));
    }
  }

  const std::string& path_;
  std::string_view bytes_;
  CrsComments crs_;
  ProgressByBytes progress_;
  size_t line_ = 0;
  uint64_t texture_coordinates_ = 0, normals_ = 0;
  Forward max_v_, max_vt_, max_vn_;
};

class OffReader {
public:
  OffReader(const std::string& path, std::string_view bytes, const Progress& progress)
      : path_(path), bytes_(bytes), crs_(path), progress_(progress, bytes.size()) {}

  Mesh read() {
    Lines lines(bytes_);
    std::vector<std::string_view> words;
    // The header: "OFF", then "vertices faces edges", possibly on the same line.
    if (!next(lines, words)) fail("header", "no 'OFF' line: empty OFF file");
    if (words[0] != "OFF") {
      const bool variant = words[0].size() > 3 && words[0].substr(words[0].size() - 3) == "OFF";
      fail(line_place(lines.number()), variant ? "only plain OFF is supported, not " + shown(words[0])
                                               : "not an OFF file (it starts with " + shown(words[0]) + ")");
    }
    words.erase(words.begin());
    if (words.empty() && !next(lines, words)) fail(line_place(lines.number()), "the file ends before the counts line");
    const std::string counts_place = line_place(lines.number());
    uint64_t counts[3] = {0, 0, 0};
    if (words.size() < 2 || words.size() > 3) fail(counts_place, "expected 'vertices faces edges'");
    for (size_t k = 0; k < words.size(); ++k) {
      if (!parse_number(words[k], counts[k])) fail(counts_place, "expected a count, got " + shown(words[k]));
    }
    const uint64_t nv = counts[0], nf = counts[1];
    // "x y z\n" is at least 6 bytes, "3 a b c\n" at least 8.
    const uint64_t rest = bytes_.size() - std::min<size_t>(bytes_.size(), lines.offset());
    if (nv > kMaxVertices)
      fail(counts_place, std::to_string(nv) + " vertices are more than 32-bit indices can address");
    if (nv > rest / 6 || nf > rest / 8 || nv * 6 + nf * 8 > rest + 2) {
      fail(counts_place, "declares " + std::to_string(nv) + " vertices and " + std::to_string(nf) +
                             " faces, more than the " + std::to_string(rest) + " bytes that follow can hold");
    }
    Mesh mesh;
    mesh.vertices.reserve(nv);
    mesh.triangles.reserve(nf);
    for (uint64_t i = 0; i < nv; ++i) {
      if (!next(lines, words))
        fail(line_place(lines.number()),
             "the file ends after " + std::to_string(i) + " of " + std::to_string(nv) + " vertices");
      const std::string place = line_place(lines.number());
      if (words.size() != 3) fail(place, "expected 'x y z' for vertex " + std::to_string(i));
      double xyz[3];
      for (int k = 0; k < 3; ++k) {
        if (!parse_number(words[k], xyz[k])) fail(place, "expected a number, got " + shown(words[k]));
        if (!std::isfinite(xyz[k]))
          fail(place, "vertex " + std::to_string(i) + " has a coordinate that is not a finite number");
      }
      mesh.vertices.push_back({xyz[0], xyz[1], xyz[2]});
    }
    for (uint64_t i = 0; i < nf; ++i) {
      if (!next(lines, words))
        fail(line_place(lines.number()),
             "the file ends after " + std::to_string(i) + " of " + std::to_string(nf) + " faces");
      const std::string place = line_place(lines.number());
      uint64_t n = 0;
      if (!parse_number(words[0], n)) fail(place, "expected a vertex count, got " + shown(words[0]));
      if (n != 3)
        fail(place,
             "face " + std::to_string(i) + " has " + std::string(words[0]) + " vertices; only triangles are accepted");
      // After the indices an optional colour: up to four numbers.
      if (words.size() < 4 || words.size() > 8)
        fail(place, "expected '3 a b c [colour]' for face " + std::to_string(i));
      Triangle t{};
      for (int k = 0; k < 3; ++k) {
        uint64_t index = 0;
        if (!parse_number(words[k + 1], index) || index >= nv) {
          fail(place, "face " + std::to_string(i) + " refers to vertex " + shown(words[k + 1]) + ", but there are " +
                          std::to_string(nv) + " vertices");
        }
        t[k] = static_cast<uint32_t>(index);
      }
      if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2])
        fail(place, "face " + std::to_string(i) + " names the same vertex twice");
      mesh.triangles.push_back(t);
    }
    if (next(lines, words)) {
      fail(line_place(lines.number()),
           "data after the last face: the header declares fewer records than the file holds");
    }
    mesh.crs = crs_.crs();
    return mesh;
  }

private:
  [[noreturn]] void fail(const std::string& place, const std::string& problem) const {
    throw InputError(path_, place, problem);
  }

  // The next line with content, as words; comments ('#' to the end of the line) feed the CRS.
  bool next(Lines& lines, std::vector<std::string_view>& words) {
    std::string_view line;
    while (lines.next(line)) {
      progress_.at(lines.offset());
      const size_t hash = line.find('#');
      if (hash != std::string_view::npos) {
        if (trim(line.substr(0, hash)).empty()) crs_.comment(line.substr(hash + 1), line_place(lines.number()));
        line = line.substr(0, hash);
      }
      split(line, words);
      if (!words.empty()) return true;
    }
    return false;
  }

  const std::string& path_;
  std::string_view bytes_;
  CrsComments crs_;
  ProgressByBytes progress_;
};

}  // namespace

Mesh read_mesh(const std::string& path, const Progress& progress) {
  const std::shared_ptr<const MappedFile> file = map_whole_file(path);
  const std::string_view bytes(reinterpret_cast<const char*>(file->data()), file->size());
  // PLY and OFF files start with their name; OBJ has no magic, so it is what is left. A file
  // named .ply or .off that does not start so is read as that format, to say what is missing.
  std::optional<MeshFormat> named;
  try {
    named = mesh_format_for(path);
  } catch (const ArgumentError&) {
  }
  const std::string_view start = std::string_view(bytes).substr(0, 3);
  if (bytes.compare(0, 4, "glTF") == 0 || named == MeshFormat::Glb) {
    throw InputError(path, "header", "GLB (glTF) meshes are written, not read (float32 positions): use the PLY");
  }
  Mesh mesh;
  if (start == "ply" || (start != "OFF" && named == MeshFormat::Ply)) {
    mesh = PlyReader(path, bytes, progress).read();
  } else if (start == "OFF" || named == MeshFormat::Off) {
    mesh = OffReader(path, bytes, progress).read();
  } else {
    mesh = ObjReader(path, bytes, progress).read();
  }
  // Where no projected CRS reaches (a vertex astray at 1e15 made the roadmap's --spacing take the
  // blame): the readers' rule for rasters (kMaxCoordinate, kMaxHeight), said of the mesh file.
  for (size_t i = 0; i < mesh.vertices.size(); ++i) {
    const Vertex& v = mesh.vertices[i];
    if (std::abs(v.x) <= kMaxCoordinate && std::abs(v.y) <= kMaxCoordinate && std::abs(v.z) <= kMaxHeight) continue;
    char at[96];
    std::snprintf(at, sizeof at, "x %.10g, y %.10g, z %.10g", v.x, v.y, v.z);
    throw InputError(path, "vertex " + std::to_string(i + 1),
                     std::string(at) + " lies beyond any projected CRS (x, y within 1e9 CRS units of the origin, " +
                         "heights within 1e5)");
  }
  report(progress, 1);
  return mesh;
}

namespace {

// A GLB's CRS: asset.extras.crs and .vertical as glb_writer.cpp writes them, from the JSON chunk
// alone (GLB 2.0: a 12-byte header, then the JSON chunk's length, its type, its bytes).
Crs glb_crs(const std::string& path, std::ifstream& in) {
  unsigned char head[20] = {};
  in.seekg(0);
  if (!in.read(reinterpret_cast<char*>(head), sizeof head) ||
      std::string_view(reinterpret_cast<char*>(head + 16), 4) != "JSON")
    throw InputError(path, "byte 16", "not a GLB: no JSON chunk first");
  const uint32_t length =
      uint32_t(head[12]) | uint32_t(head[13]) << 8 | uint32_t(head[14]) << 16 | uint32_t(head[15]) << 24;
  if (length > (64u << 20)) throw InputError(path, "byte 12", "a JSON chunk of " + std::to_string(length) + " bytes");
  std::string text(length, '\0');
  if (!in.read(text.data(), length)) throw InputError(path, "byte 20", "the JSON chunk is cut short");
  const nlohmann::json gltf = nlohmann::json::parse(text, nullptr, false);
  if (gltf.is_discarded()) throw InputError(path, "JSON chunk", "not JSON");
  const nlohmann::json extras = gltf.value("/asset/extras"_json_pointer, nlohmann::json::object());
  const nlohmann::json crs_json = extras.value("crs", nlohmann::json::object()),
                       vertical = extras.value("vertical", nlohmann::json::object());
  Crs crs;
  if (crs_json.is_object()) {
    crs.name = crs_json.value("name", "");
    crs.epsg = crs_json.value("epsg", 0);
    crs.wkt = crs_json.value("wkt", "");
  }
  if (vertical.is_object())
    crs.vertical_name = vertical.value("name", ""), crs.vertical_unit = vertical.value("unit", "");
  crs.definition = !crs.wkt.empty() ? crs.wkt : crs.epsg ? "EPSG:" + std::to_string(crs.epsg) : "";
  crs.geographic = CrsComments::geographic_wkt(crs.wkt);
  return crs;
}

}  // namespace

Crs read_mesh_crs(const std::string& path) {
  require_input_file(path);
  std::ifstream in(path, std::ios::binary);
  char magic[4] = {};
  if (in && in.read(magic, 4) && std::string_view(magic, 4) == "glTF") return glb_crs(path, in);
  in.clear();
  in.seekg(3);  // the header is read on from after "ply"
  if (!in || std::string_view(magic, 3) != "ply") return read_mesh(path).crs;
  // The header, read until its end line (headers are a few kB; read_mesh() says what is wrong
  // with one that never ends). The line itself, not the word: a comment may say "end_header".
  std::string head(magic, 3);
  auto end_line = [&] {
    for (size_t at = head.find("\nend_header"); at != std::string::npos; at = head.find("\nend_header", at + 1)) {
      const size_t after = at + 11;
      if (after < head.size() && head[after] == '\n') return after + 1;
      if (after + 1 < head.size() && head[after] == '\r' && head[after + 1] == '\n') return after + 2;
    }
    return std::string::npos;
  };
  char chunk[4096];
  size_t end = std::string::npos;
  while ((end = end_line()) == std::string::npos && head.size() < (size_t(16) << 20)) {
    in.read(chunk, sizeof chunk);
    if (in.gcount() == 0) break;
    head.append(chunk, static_cast<size_t>(in.gcount()));
  }
  if (end == std::string::npos) return read_mesh(path).crs;
  head.resize(end);
  return PlyReader(path, head, {}).header_crs();
}

}  // namespace dsmplan
