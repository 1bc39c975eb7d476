// The roadmap file: a built roadmap kept for later queries on the same mesh, the multi-query
// half of Kavraki et al. 1996 ("learning phase" once, "query phase" many times). A small binary
// format of our own, read defensively: every count is checked against the file's size before
// anything is allocated, and a checksum catches damage.
//
// Layout (little-endian):
//   magic "DSMPLAN-ROADMAP\n" (16 bytes), version u32 = 1,
//   mesh fingerprint u64, safety f64, spacing f64, max_edge f64, max_agl f64,
//   nodes u64, listings u64, nodes * 3 f64 (x, y, z), (nodes + 1) u32 start, listings u32,
//   checksum u64 (FNV-1a of every byte before it).
#include "dsmplan/roadmap_file.hpp"

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "core/atomic_file.hpp"
#include "dsmplan/plan.hpp"

namespace dsmplan {

namespace {

constexpr char kMagic[16] = {'D', 'S', 'M', 'P', 'L', 'A', 'N', '-', 'R', 'O', 'A', 'D', 'M', 'A', 'P', '\n'};
constexpr uint32_t kVersion = 1;
constexpr size_t kHeaderBytes = 16 + 4 + 8 + 4 * 8 + 8 + 8;

static_assert(std::endian::native == std::endian::little, "the roadmap file is written in native little-endian");

uint64_t fnv1a(const unsigned char* data, size_t bytes, uint64_t hash = 14695981039346656037ull) {
  for (size_t i = 0; i < bytes; ++i) hash = (hash ^ data[i]) * 1099511628211ull;
  return hash;
}

template <class T>
void put(std::string& out, const T& value) {
  out.append(reinterpret_cast<const char*>(&value), sizeof value);
}

struct Reader {
  const std::string& bytes;
  const std::string& file;
  size_t at = 0;
  template <class T>
  T get(const char* what) {
    if (bytes.size() - at < sizeof(T))
      throw InputError(file, "byte " + std::to_string(at), "ends inside " + std::string(what));
    T value;
    std::memcpy(&value, bytes.data() + at, sizeof value);
    at += sizeof value;
    return value;
  }
};

std::string mismatch(const char* option, double built, double asked) {
  char buffer[160];
  std::snprintf(buffer, sizeof buffer,
                "was built with %s %.17g, this run asks for %.17g; build it again (delete the file)", option, built,
                asked);
  return buffer;
}

}  // namespace

void write_roadmap(const std::string& path, const Roadmap& map, uint64_t fingerprint, const PlanOptions& options) {
  if (!options.constraints.empty())
    throw ArgumentError(
        "constraints",
        "a roadmap file does not record flight constraints (no-fly zones): build the roadmap where they are used");
  std::string out(kMagic, sizeof kMagic);
  put(out, kVersion);
  put(out, fingerprint);
  for (double v : {options.safety, options.spacing, options.max_edge, options.max_agl}) put(out, v);
  put(out, static_cast<uint64_t>(map.nodes.size()));
  put(out, static_cast<uint64_t>(map.neighbour.size()));
  out.append(reinterpret_cast<const char*>(map.nodes.data()), map.nodes.size() * sizeof(Point3));
  out.append(reinterpret_cast<const char*>(map.start.data()), map.start.size() * sizeof(uint32_t));
  out.append(reinterpret_cast<const char*>(map.neighbour.data()), map.neighbour.size() * sizeof(uint32_t));
  put(out, fnv1a(reinterpret_cast<const unsigned char*>(out.data()), out.size()));
  AtomicFile file(path);
  file.write(out);
  file.commit();
}

Roadmap read_roadmap(const std::string& path, uint64_t fingerprint, const PlanOptions& options) {
  if (!options.constraints.empty())
    throw ArgumentError(
        "constraints",
        "a roadmap file does not record flight constraints (no-fly zones): build the roadmap where they are used");
  RoadmapHeader header;
  Roadmap map = read_roadmap(path, &header);
  if (header.mesh_fingerprint != fingerprint)
    throw InputError(path, "",
                     "the roadmap was built for another mesh or another ground (--dsm, --dtm) (fingerprints differ); "
                     "build it again");
  const double built[4] = {header.safety, header.spacing, header.max_edge, header.max_agl};
  const double asked[4] = {options.safety, options.spacing, options.max_edge, options.max_agl};
  const char* names[4] = {"--safety", "--spacing", "--max-edge", "--max-agl"};
  for (int k = 0; k < 4; ++k)
    if (built[k] != asked[k]) throw InputError(path, "", "the roadmap " + mismatch(names[k], built[k], asked[k]));
  return map;
}

Roadmap read_roadmap(const std::string& path, RoadmapHeader* header) {
  require_input_file(path);
  // Read whole: a device or pipe (/dev/zero) would never end, and is no roadmap this wrote.
  std::error_code error;
  if (std::filesystem::exists(path, error) && !std::filesystem::is_regular_file(path, error))
    throw InputError(path, "", "not a regular file (a device, pipe or folder): not a roadmap file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, "", "cannot open the roadmap file");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, "", "cannot read the roadmap file");
  if (bytes.size() < sizeof kMagic || std::memcmp(bytes.data(), kMagic, sizeof kMagic) != 0)
    throw InputError(path, "", "not a dsmplan roadmap file (no DSMPLAN-ROADMAP signature)");
  if (bytes.size() < kHeaderBytes + 8)
    throw InputError(path, "", "truncated roadmap file (" + std::to_string(bytes.size()) + " bytes)");
  uint64_t stored_sum;
  std::memcpy(&stored_sum, bytes.data() + bytes.size() - 8, 8);
  if (stored_sum != fnv1a(reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size() - 8)) {
    // The counts sit at fixed places: a damaged file shorter than they declare was cut short,
    // which says more than "damaged" (a double, so that lying counts cannot overflow).
    uint64_t declared[2];
    std::memcpy(declared, bytes.data() + kHeaderBytes - 16, sizeof declared);
    const double declared_bytes = kHeaderBytes + double(declared[0]) * 28 + 4 + double(declared[1]) * 4 + 8;
    if (declared_bytes > double(bytes.size())) {
      char why[200];
      std::snprintf(why, sizeof why,
                    "truncated roadmap file: %zu bytes, its header declares %.0f (%llu nodes, %llu edge listings)",
                    bytes.size(), declared_bytes, static_cast<unsigned long long>(declared[0]),
                    static_cast<unsigned long long>(declared[1]));
      throw InputError(path, "", why);
    }
    throw InputError(path, "", "damaged roadmap file (checksum mismatch)");
  }

  Reader r{bytes, path, sizeof kMagic};
  if (const uint32_t version = r.get<uint32_t>("the version"); version != kVersion)
    throw InputError(path, "", "roadmap file version " + std::to_string(version) + ", this dsmplan reads version 1");
  RoadmapHeader stored;
  stored.mesh_fingerprint = r.get<uint64_t>("the mesh fingerprint");
  for (double* v : {&stored.safety, &stored.spacing, &stored.max_edge, &stored.max_agl})
    *v = r.get<double>("the options");
  if (header) *header = stored;

  const uint64_t nodes = r.get<uint64_t>("the node count"), listings = r.get<uint64_t>("the edge count");
  const uint64_t payload = bytes.size() - 8 - r.at;
  if (nodes >= UINT32_MAX || listings > UINT32_MAX || nodes * 28 + 4 + listings * 4 != payload)
    throw InputError(path, "header",
                     "declares " + std::to_string(nodes) + " nodes and " + std::to_string(listings) +
                         " edge listings, which do not fill the file's " + std::to_string(payload) + " bytes");
  Roadmap map;
  map.nodes.resize(nodes);
  map.start.resize(nodes + 1);
  map.neighbour.resize(listings);
  // An empty vector's data() may be null, and memcpy from or to null is undefined even for 0
  // bytes (UBSan, found by fuzz/fuzz_roadmap): no nodes or no edges copy nothing.
  if (nodes > 0) std::memcpy(map.nodes.data(), bytes.data() + r.at, nodes * sizeof(Point3));
  r.at += nodes * sizeof(Point3);
  std::memcpy(map.start.data(), bytes.data() + r.at, (nodes + 1) * 4);
  r.at += (nodes + 1) * 4;
  if (listings > 0) std::memcpy(map.neighbour.data(), bytes.data() + r.at, listings * 4);
  // The structure must be what build_roadmap() makes, or A* could read out of bounds.
  if (map.start[0] != 0 || map.start[nodes] != listings)
    throw InputError(path, "adjacency", "the edge lists do not span the edge listings");
  for (uint64_t i = 0; i < nodes; ++i) {
    if (map.start[i] > map.start[i + 1])
      throw InputError(path, "node " + std::to_string(i), "edge list ends before it starts");
    // Checked here, not only by the next node's order check: this node's listings are read next.
    if (map.start[i + 1] > listings)
      throw InputError(path, "node " + std::to_string(i), "edge list runs past the file's edge listings");
    for (double v : map.nodes[i])
      if (!std::isfinite(v)) throw InputError(path, "node " + std::to_string(i), "coordinate is not finite");
    for (uint32_t k = map.start[i]; k < map.start[i + 1]; ++k)
      if (map.neighbour[k] >= nodes || map.neighbour[k] == i)
        throw InputError(path, "node " + std::to_string(i), "edge to a node that does not exist");
  }
  label_components(map);
  return map;
}

}  // namespace dsmplan
