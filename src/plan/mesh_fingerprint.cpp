// The keys kept indexes and roadmaps are named by (flight.hpp): what they were built from, so
// that a later run can tell whether a kept file still fits without rebuilding it.
#include <bit>

#include "dsmplan/flight.hpp"

namespace dsmplan {

namespace {

// splitmix64's finaliser over a running hash (Steele, Lea, Flood, "Fast splittable pseudorandom
// number generators", OOPSLA 2014).
uint64_t mix(uint64_t h, uint64_t word) {
  h ^= word + 0x9e3779b97f4a7c15ull + (h << 6) + (h >> 2);
  h ^= h >> 30;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 27;
  h *= 0x94d049bb133111ebull;
  return h ^ (h >> 31);
}

}  // namespace

uint64_t mesh_fingerprint(const Mesh& mesh) {
  uint64_t h = mix(mesh.vertices.size(), mesh.triangles.size());
  for (const Vertex& v : mesh.vertices) {
    h = mix(h, std::bit_cast<uint64_t>(v.x));
    h = mix(h, std::bit_cast<uint64_t>(v.y));
    h = mix(h, std::bit_cast<uint64_t>(v.z));
  }
  for (const Triangle& t : mesh.triangles)
    h = mix(h, (static_cast<uint64_t>(t[0]) << 32 | t[1]) ^ (static_cast<uint64_t>(t[2]) * 0x9e3779b97f4a7c15ull));
  return h;
}

uint64_t obstacle_key(uint64_t mesh_key, const Grid* dsm) {
  return dsm ? mesh_key ^ (GroundGrid(*dsm).fingerprint() * 0x9E3779B97F4A7C15ull) : mesh_key;
}

}  // namespace dsmplan
