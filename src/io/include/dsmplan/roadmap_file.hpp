// dsmplan/roadmap_file.hpp: a roadmap (plan.hpp) kept in a file for many queries.
//
#pragma once

#include <cstdint>
#include <string>

#include "dsmplan/flight.hpp"  // mesh_fingerprint()
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"

namespace dsmplan {

// ---- multi-query: the roadmap file ---------------------------------------------------------
//
// A roadmap is built once and queried many times (Kavraki et al. 1996). write_roadmap() keeps
// it with what it depends on: the mesh's fingerprint and the four options that shape it
// (safety, spacing, max_edge, max_agl); read_roadmap() gives it back only when all of them are
// what this run uses, so a roadmap is never used on a mesh or with a safety distance it was not
// checked against. The format is dsmplan's own (src/io/roadmap_file.cpp), 28 bytes a node
// and 8 an edge, with a checksum; a file from a machine of the other byte order is refused.

/// Writes `map` atomically (the whole file or nothing). OutputError when it cannot.
/// Both functions throw ArgumentError("constraints") when options.constraints is not empty: the
/// file does not record them, so a roadmap built under them is not kept.
void write_roadmap(const std::string& path, const Roadmap& map, uint64_t mesh_fingerprint, const PlanOptions& options);

/// Reads a roadmap written by write_roadmap(). InputError(path, place, why) when the file
/// cannot be read, is not a roadmap file, is truncated or damaged (checksum), declares counts
/// that do not fit its size, has an edge to a node that does not exist, was built for another
/// mesh ("built for another mesh") or with other options ("was built with --spacing 20, this
/// run asks for 15"). O(file size).
Roadmap read_roadmap(const std::string& path, uint64_t mesh_fingerprint, const PlanOptions& options);

/// What a roadmap file says it was built for.
struct RoadmapHeader {
  uint64_t mesh_fingerprint = 0;
  double safety = 0, spacing = 0, max_edge = 0, max_agl = 0;
};

/// Reads a roadmap file without asking what it was built for (to draw it, say); the same checks
/// of the file itself as above. `header` (may be null) receives what it was built for.
Roadmap read_roadmap(const std::string& path, RoadmapHeader* header);

}  // namespace dsmplan
