// Reads uncompressed LAS point clouds following the ASPRS LAS 1.4 R15 specification
// (public header block, VLRs, EVLRs, point data record formats 0-10; LAS 1.0-1.3 headers are
// prefixes of the 1.4 one). Every header field is checked against the file before it is trusted.
// LAZ (LASzip-compressed points: bit 7 or 6 of the point data format byte) is decoded by
// dsmplan's own LASzip decoder (src/io/laz, dsmplan/laz.hpp) into the same records.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <memory>
#include <string>
#include <vector>

#include "dsmplan/laz.hpp"
#include "dsmplan/point_io.hpp"
#include "dsmplan/points.hpp"

namespace dsmplan {

void PointCloud::add(double px, double py, double pz, uint8_t cls) {
  x.push_back(px);
  y.push_back(py);
  z.push_back(pz);
  classification.push_back(cls);
  min_x = std::min(min_x, px);
  min_y = std::min(min_y, py);
  min_z = std::min(min_z, pz);
  max_x = std::max(max_x, px);
  max_y = std::max(max_y, py);
  max_z = std::max(max_z, pz);
}

namespace {

// LAS is little-endian whatever the host is; compilers turn these into plain loads.
uint64_t little_endian(const unsigned char* p, int bytes) {
  uint64_t value = 0;
  for (int i = bytes - 1; i >= 0; --i) value = value << 8 | p[i];
  return value;
}
uint16_t u16(const unsigned char* p) { return static_cast<uint16_t>(little_endian(p, 2)); }
uint32_t u32(const unsigned char* p) { return static_cast<uint32_t>(little_endian(p, 4)); }
uint64_t u64(const unsigned char* p) { return little_endian(p, 8); }
int32_t i32(const unsigned char* p) { return static_cast<int32_t>(u32(p)); }
double f64(const unsigned char* p) { return std::bit_cast<double>(u64(p)); }

std::string field(int byte, const std::string& name) { return "byte " + std::to_string(byte) + " (" + name + ")"; }

constexpr int kMaxFormat = 10;
constexpr std::array<int, kMaxFormat + 1> kMinRecordLength = {20, 28, 26, 34, 57, 63, 30, 36, 38, 59, 67};
constexpr size_t kVlrHeader = 54, kEvlrHeader = 60;
// A CRS record larger than this is a corrupt length, not a WKT string.
constexpr uint64_t kMaxCrsRecord = 1 << 20;
constexpr uint64_t kReportEvery = 1 << 20;
constexpr double kBytesPerPoint = 3 * sizeof(double) + sizeof(uint8_t);

int header_size_of_version(int minor) { return minor >= 4 ? 375 : minor == 3 ? 235 : 227; }

struct Header {
  int minor = 0;
  uint16_t header_size = 0;
  uint32_t point_offset = 0;
  uint32_t vlr_count = 0;
  int format = 0;
  uint16_t record_length = 0;
  uint64_t point_count = 0;
  double scale[3] = {}, offset[3] = {};
  uint64_t evlr_start = 0;
  uint32_t evlr_count = 0;
  bool laz = false;  // LASzip-compressed points
};

class LasReader {
public:
  explicit LasReader(std::string path) : path_(std::move(path)) {
    require_input_file(path_);
    fd_ = ::open(path_.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd_ < 0) fail("", std::string("cannot open: ") + std::strerror(errno));
    struct stat info {};
    if (::fstat(fd_, &info) != 0) fail("", std::string("cannot read: ") + std::strerror(errno));
    if (S_ISDIR(info.st_mode)) fail("", "is a directory, not a LAS file");
    size_ = static_cast<uint64_t>(info.st_size);
  }
  ~LasReader() { ::close(fd_); }
  LasReader(const LasReader&) = delete;
  LasReader& operator=(const LasReader&) = delete;

  Header header() const;
  Crs crs(const Header& h) const;
  std::vector<unsigned char> laszip_vlr(const Header& h) const;
  void points(const Header& h, PointCloud& cloud, const Progress& progress) const;

private:
  [[noreturn]] void fail(const std::string& place, const std::string& problem) const {
    throw InputError(path_, place, problem);
  }

  // Reads bytes the header validation has already placed inside the file; a short read now
  // means the file changed underneath us or the disk failed.
  void read(uint64_t offset, void* buffer, size_t bytes, const std::string& place) const {
    auto* out = static_cast<unsigned char*>(buffer);
    while (bytes > 0) {
      ssize_t got = ::pread(fd_, out, bytes, static_cast<off_t>(offset));
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) fail(place, std::string("cannot read: ") + std::strerror(errno));
      if (got == 0) fail(place, "the file ended early (was it changed while being read?)");
      out += got;
      offset += static_cast<uint64_t>(got);
      bytes -= static_cast<size_t>(got);
    }
  }

  std::string read_string(uint64_t offset, uint64_t bytes, const std::string& place) const {
    std::string text(bytes, '\0');
    read(offset, text.data(), bytes, place);
    return text;
  }

  Crs crs_record(const unsigned char* record_header, uint64_t payload_offset, uint64_t payload_bytes,
                 const std::string& place) const;

  std::string path_;
  int fd_ = -1;
  uint64_t size_ = 0;
};

Header LasReader::header() const {
  unsigned char b[375] = {};
  const size_t available = static_cast<size_t>(std::min<uint64_t>(size_, sizeof b));
  if (available == 0) fail("", "the file is empty");
  read(0, b, available, "header");

  if (available >= 4 && std::memcmp(b, "LASF", 4) != 0) {
    std::string found;
    for (int i = 0; i < 4; ++i) found += (b[i] >= 32 && b[i] < 127) ? static_cast<char>(b[i]) : '?';
    fail(field(0, "signature"), "not a LAS file: it starts with '" + found + "' instead of 'LASF'");
  }
  if (available < 227)
    fail("header", "truncated: the file has " + std::to_string(size_) + " bytes, a LAS header needs at least 227");

  Header h;
  if (b[24] != 1 || b[25] > 4)
    fail(field(24, "version"),
         "unsupported LAS version " + std::to_string(b[24]) + "." + std::to_string(b[25]) + " (dsmplan reads 1.0-1.4)");
  h.minor = b[25];
  const std::string version = "LAS 1." + std::to_string(h.minor);
  const int needed = header_size_of_version(h.minor);
  if (size_ < static_cast<uint64_t>(needed))
    fail("header", "truncated: the file has " + std::to_string(size_) + " bytes, a " + version + " header needs " +
                       std::to_string(needed));

  h.header_size = u16(b + 94);
  if (h.header_size < needed)
    fail(field(94, "header size"), std::to_string(h.header_size) + " is smaller than the " + std::to_string(needed) +
                                       " bytes of a " + version + " header");
  if (h.header_size > size_)
    fail(field(94, "header size"), std::to_string(h.header_size) + " bytes of header, but the file has only " +
                                       std::to_string(size_) + " (truncated file)");

  h.point_offset = u32(b + 96);
  if (h.point_offset < h.header_size)
    fail(field(96, "offset to point data"),
         std::to_string(h.point_offset) + " lies inside the " + std::to_string(h.header_size) + "-byte header");
  if (h.point_offset > size_)
    fail(field(96, "offset to point data"), std::to_string(h.point_offset) + " lies beyond the end of the file (" +
                                                std::to_string(size_) + " bytes; truncated file?)");
  h.vlr_count = u32(b + 100);

  const int format_byte = b[104];
  // LASzip marks compressed points with bit 7 (and, in some writers, bit 6) of this byte.
  h.laz = (format_byte & 0xC0) != 0;
  const int format = format_byte & (h.laz ? 0x3F : 0xFF);
  if (format > kMaxFormat)
    fail(field(104, "point data format"), "unknown point data format " + std::to_string(format) +
                                              (h.laz ? " (LAZ-compressed)" : "") + " (LAS 1.4 defines 0-10)");
  h.format = format;

  h.record_length = u16(b + 105);
  if (h.record_length < kMinRecordLength[h.format])
    fail(field(105, "point record length"), std::to_string(h.record_length) + " bytes is shorter than the " +
                                                std::to_string(kMinRecordLength[h.format]) + " bytes of point format " +
                                                std::to_string(h.format));

  // LAS 1.4 moved the count to 64 bits and leaves the legacy field 0 when it cannot hold it
  // (and for formats 6-10); both present and different means one of them lies.
  int count_byte = 107;
  h.point_count = u32(b + 107);
  if (h.minor >= 4) {
    const uint64_t count64 = u64(b + 247);
    if (h.point_count == 0) {
      h.point_count = count64;
      count_byte = 247;
    } else if (count64 != 0 && count64 != h.point_count) {
      fail(field(247, "point count"), std::to_string(count64) + " disagrees with the legacy count " +
                                          std::to_string(h.point_count) + " at byte 107");
    }
  }
  // Compressed points have no fixed size: bound the count by what the coder could possibly
  // pack into the bytes (the decoder checks the real count against its chunk table).
  const uint64_t room =
      h.laz ? (size_ - h.point_offset) * laz::kMaxPointsPerByte : (size_ - h.point_offset) / h.record_length;
  if (h.point_count > room)
    fail(field(count_byte, "point count"),
         std::to_string(h.point_count) + " points of " + std::to_string(h.record_length) + " bytes from byte " +
             std::to_string(h.point_offset) + " do not fit in the " + std::to_string(size_) +
             "-byte file, which holds at most " + std::to_string(room) + (h.laz ? " compressed points" : "") +
             " (truncated file?)");

  static const char* axes[3] = {"x", "y", "z"};
  for (int i = 0; i < 3; ++i) {
    h.scale[i] = f64(b + 131 + 8 * i);
    h.offset[i] = f64(b + 155 + 8 * i);
    if (!std::isfinite(h.scale[i]) || h.scale[i] == 0)
      fail(field(131 + 8 * i, std::string(axes[i]) + " scale factor"),
           h.scale[i] == 0 ? "is 0, which would put every point at the offset" : "is not a finite number");
    if (!std::isfinite(h.offset[i]))
      fail(field(155 + 8 * i, std::string(axes[i]) + " offset"), "is not a finite number");
  }

  if (h.minor >= 4) {
    h.evlr_start = u64(b + 235);
    h.evlr_count = u32(b + 243);
    // Fits: <= size_. LAZ points end at the chunk table, which the decoder checks.
    const uint64_t point_end = h.laz ? h.point_offset : h.point_offset + h.point_count * h.record_length;
    if (h.evlr_count > 0 && (h.evlr_start < point_end || h.evlr_start > size_))
      fail(field(235, "start of first EVLR"),
           std::to_string(h.evlr_start) + " is not between the end of the point data (byte " +
               std::to_string(point_end) + ") and the end of the file (byte " + std::to_string(size_) + ")");
  }
  return h;
}

// A LASF_Projection record: 2112 is OGC WKT, 34735 the GeoTIFF key directory. Returns an
// unknown Crs for every other record.
Crs LasReader::crs_record(const unsigned char* record_header, uint64_t payload_offset, uint64_t payload_bytes,
                          const std::string& place) const {
  const std::string user_id(reinterpret_cast<const char*>(record_header + 2),
                            strnlen(reinterpret_cast<const char*>(record_header + 2), 16));
  const uint16_t record_id = u16(record_header + 18);
  Crs crs;
  if (user_id != "LASF_Projection" || (record_id != 2112 && record_id != 34735)) return crs;
  if (payload_bytes > kMaxCrsRecord)
    fail(place, "a " + std::to_string(payload_bytes) + "-byte CRS record is implausibly long (corrupt length?)");
  std::string payload = read_string(payload_offset, payload_bytes, place);

  if (record_id == 2112) {
    // Writers pad the WKT with NULs (the spec requires one terminating NUL).
    while (!payload.empty() && (payload.back() == '\0' || std::isspace(static_cast<unsigned char>(payload.back()))))
      payload.pop_back();
    crs.definition = payload;
    return crs;
  }

  const auto* keys = reinterpret_cast<const unsigned char*>(payload.data());
  if (payload.size() < 8) fail(place, "GeoKeyDirectory of " + std::to_string(payload.size()) + " bytes has no header");
  const size_t key_count = u16(keys + 6);
  if (8 + 8 * key_count > payload.size())
    fail(place, "GeoKeyDirectory says it has " + std::to_string(key_count) + " keys but holds only " +
                    std::to_string((payload.size() - 8) / 8));
  // Only keys stored in place (location 0) can carry an EPSG code; 0 and 32767 mean
  // "undefined" and "user-defined", which name no code.
  int projected = 0, geographic = 0, vertical = 0;
  for (size_t k = 0; k < key_count; ++k) {
    const unsigned char* entry = keys + 8 + 8 * k;
    const uint16_t id = u16(entry), location = u16(entry + 2), value = u16(entry + 6);
    if (location != 0 || value == 0 || value == 32767) continue;
    if (id == 3072) projected = value;
    if (id == 2048) geographic = value;
    if (id == 4096) vertical = value;
  }
  const int horizontal = projected ? projected : geographic;
  if (horizontal) {
    crs.definition = "EPSG:" + std::to_string(horizontal);
    if (vertical) crs.definition += "+" + std::to_string(vertical);  // PROJ's compound CRS syntax
  }
  return crs;
}

Crs LasReader::crs(const Header& h) const {
  // WKT is complete where GeoTIFF keys only carry EPSG codes, so it wins when both are present.
  Crs wkt, keys;
  auto keep = [&](Crs found, uint16_t record_id) {
    Crs& slot = record_id == 2112 ? wkt : keys;
    if (!slot.known() && found.known()) slot = std::move(found);
  };

  uint64_t pos = h.header_size;
  for (uint32_t k = 0; k < h.vlr_count; ++k) {
    const std::string place = "VLR " + std::to_string(k + 1) + " at byte " + std::to_string(pos);
    const std::string overrun = "runs past the start of the point data at byte " + std::to_string(h.point_offset) +
                                " (byte 100 says there are " + std::to_string(h.vlr_count) + " VLRs)";
    if (pos + kVlrHeader > h.point_offset) fail(place, overrun);
    unsigned char record[kVlrHeader];
    read(pos, record, kVlrHeader, place);
    const uint64_t length = u16(record + 20);
    if (pos + kVlrHeader + length > h.point_offset) fail(place, overrun);
    keep(crs_record(record, pos + kVlrHeader, length, place), u16(record + 18));
    pos += kVlrHeader + length;
  }

  pos = h.evlr_start;
  for (uint32_t k = 0; k < h.evlr_count; ++k) {
    const std::string place = "EVLR " + std::to_string(k + 1) + " at byte " + std::to_string(pos);
    const std::string overrun = "runs past the end of the file at byte " + std::to_string(size_) +
                                " (byte 243 says there are " + std::to_string(h.evlr_count) + " EVLRs)";
    if (pos > size_ || size_ - pos < kEvlrHeader) fail(place, overrun);
    unsigned char record[kEvlrHeader];
    read(pos, record, kEvlrHeader, place);
    const uint64_t length = u64(record + 20);
    if (length > size_ - pos - kEvlrHeader) fail(place, overrun);
    keep(crs_record(record, pos + kEvlrHeader, length, place), u16(record + 18));
    pos += kEvlrHeader + length;
  }
  return wkt.known() ? wkt : keys;
}

std::vector<unsigned char> LasReader::laszip_vlr(const Header& h) const {
  // crs() has walked these records already: their lengths stay inside the VLR area.
  uint64_t pos = h.header_size;
  for (uint32_t k = 0; k < h.vlr_count; ++k) {
    const std::string place = "VLR " + std::to_string(k + 1) + " at byte " + std::to_string(pos);
    unsigned char record[kVlrHeader];
    read(pos, record, kVlrHeader, place);
    const uint64_t length = u16(record + 20);
    if (strncmp(reinterpret_cast<const char*>(record + 2), laz::kLaszipUserId, 16) == 0 &&
        u16(record + 18) == laz::kLaszipRecordId) {
      std::vector<unsigned char> payload(length);
      read(pos + kVlrHeader, payload.data(), length, place);
      return payload;
    }
    pos += kVlrHeader + length;
  }
  fail(field(104, "point data format"),
       "the points are LAZ-compressed, but the file has no 'laszip encoded' VLR (user id 'laszip encoded', record "
       "22204) to say how");
}

void LasReader::points(const Header& h, PointCloud& cloud, const Progress& progress) const {
  // LAZ: the decoder reads and checks the chunk table first, so a count the table does not back
  // is refused before anything is reserved.
  std::unique_ptr<laz::Decoder> decoder;
  if (h.laz) {
    try {
      const std::vector<unsigned char> payload = laszip_vlr(h);
      laz::PointSource source;
      source.read_at = [this](uint64_t offset, void* buffer, size_t bytes) {
        if (offset > size_ || bytes > size_ - offset)
          fail("byte " + std::to_string(offset), "past the end of the " + std::to_string(size_) + "-byte file");
        read(offset, buffer, bytes, "byte " + std::to_string(offset));
      };
      source.file_size = size_;
      source.point_offset = h.point_offset;
      source.point_count = h.point_count;
      source.record_length = h.record_length;
      source.points_end = h.evlr_count > 0 && h.evlr_start > h.point_offset ? h.evlr_start : size_;
      decoder = std::make_unique<laz::Decoder>(
          laz::parse_laszip_vlr(payload.data(), payload.size(), h.format, h.record_length), std::move(source));
    } catch (const laz::LazError& e) {
      fail(e.place(), e.problem());
    }
  }

  // A PointCloud keeps x, y, z as doubles and a class byte: 25 bytes a point, reserved exactly.
  // The count is already bounded by the file's size; a big enough file can still outgrow memory.
  require_memory(path_, std::to_string(h.point_count) + " points", double(h.point_count) * kBytesPerPoint);
  cloud.x.reserve(h.point_count);
  cloud.y.reserve(h.point_count);
  cloud.z.reserve(h.point_count);
  cloud.classification.reserve(h.point_count);

  // Formats 6-10 gave the class a whole byte; before, it shares byte 15 with three flag bits.
  const size_t class_byte = h.format >= 6 ? 16 : 15;
  const uint8_t class_mask = h.format >= 6 ? 0xFF : 0x1F;
  const size_t length = h.record_length;
  // Records into the cloud, however they arrive (decoded LAZ chunks or blocks read from the LAS).
  uint64_t done = 0, next_report = kReportEvery;
  auto add_records = [&](const unsigned char* records, size_t n) {
    for (size_t i = 0; i < n; ++i) {
      const unsigned char* record = records + i * length;
      cloud.add(i32(record) * h.scale[0] + h.offset[0], i32(record + 4) * h.scale[1] + h.offset[1],
                i32(record + 8) * h.scale[2] + h.offset[2], record[class_byte] & class_mask);
    }
    done += n;
    if (done >= next_report) {
      report(progress, static_cast<double>(done) / static_cast<double>(h.point_count));
      next_report += kReportEvery;
    }
  };
  if (decoder) {
    try {
      decoder->decode(add_records);
    } catch (const laz::LazError& e) {
      fail(e.place(), e.problem());
    }
    report(progress, 1.0);
    return;
  }

  const uint64_t block = std::max<uint64_t>(1, (uint64_t{4} << 20) / length);  // ~4 MB per read
  std::vector<unsigned char> buffer(static_cast<size_t>(std::min(block, std::max<uint64_t>(h.point_count, 1))) *
                                    length);
  while (done < h.point_count) {
    const size_t n = static_cast<size_t>(std::min(block, h.point_count - done));
    const uint64_t offset = h.point_offset + done * length;
    read(offset, buffer.data(), n * length,
         "point " + std::to_string(done + 1) + " (byte " + std::to_string(offset) + ")");
    add_records(buffer.data(), n);
  }
  report(progress, 1.0);
}

}  // namespace

PointCloud read_las(const std::string& path, const Progress& progress) {
  LasReader reader(path);
  const Header header = reader.header();
  PointCloud cloud;
  cloud.crs = reader.crs(header);
  reader.points(header, cloud, progress);
  return cloud;
}

}  // namespace dsmplan
