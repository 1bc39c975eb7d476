// The roadmap of the probabilistic roadmap planner: Kavraki, Svestka, Latombe, Overmars,
// "Probabilistic roadmaps for path planning in high-dimensional configuration spaces", IEEE
// Trans. Robotics and Automation 12(4), 1996, with the Halton quasi-random samples of
// Adolf & Hirschmueller, Section 5 (Halton, Numerische Mathematik 2, 1960).
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>

#include "core/text.hpp"
#include "dsmplan/plan.hpp"
#include "plan/prm_parts.hpp"

namespace dsmplan {

using detail::halton;
using detail::squared_distance;

void check_plan_options(const PlanOptions& o) {
  // Lengths in CRS units (metres): positive and at most `most` (a city's scale; beyond it a value
  // is a typo, and 1e300 would overflow the sample count or the grids built from it).
  auto positive = [](double v, const char* name, double most) {
    if (!(v > 0) || !(v <= most))
      throw ArgumentError(name, "must be more than 0 and at most " + short_number(most) + ", got " + short_number(v));
  };
  if (!(o.safety >= 0) || !(o.safety <= 1000))
    throw ArgumentError("safety", "must be from 0 to 1000, got " + short_number(o.safety));
  if (!std::isnan(o.no_fly_buffer) && !(o.no_fly_buffer >= 0 && o.no_fly_buffer <= 1000))
    throw ArgumentError("no_fly_buffer", "must be from 0 to 1000, got " + short_number(o.no_fly_buffer));
  positive(o.spacing, "--spacing", 1e4);
  positive(o.max_edge, "--max-edge", 1e4);
  positive(o.max_agl, "--max-agl", 1e5);
  if (o.connections < 1) throw ArgumentError("connections", "must be at least 1");
  if (o.threads < 0) throw ArgumentError("threads", "must be >= 0");
  if (o.refine_rounds < 0) throw ArgumentError("refine_rounds", "must be >= 0");
  if (o.refine_max_samples < 1 || o.refine_max_lattice_nodes < 1 || o.refine_max_search_work < 1)
    throw ArgumentError("refine_max_samples", "refinement's bounds (samples, lattice nodes, search work) must be >= 1");
}

Roadmap build_roadmap(const ClearanceIndex& index, const PlanOptions& options, const Progress& progress) {
  check_plan_options(options);
  Roadmap map;
  map.start.assign(1, 0);
  if (index.triangles() == 0) return map;
  const ClearanceIndex::Footprint& e = index.footprint();
  const double wx = e.xmax - e.xmin, wy = e.ymax - e.ymin;
  const double count = std::round(wx * wy * options.max_agl / std::pow(options.spacing, 3));
  if (!(count < 2147483648.0))
    throw ArgumentError("spacing", "asks for " + std::to_string(count) + " samples; at most 2^31");
  // A sample, its grid listing and its share of the edges (about 10 a node, both ways): about
  // 128 bytes (14,510 samples and 124,018 edges on the NRW tile take 1.6 MB).
  require_memory("--spacing", "a roadmap of " + std::to_string(static_cast<size_t>(count)) + " samples", count * 128);
  const auto n = static_cast<size_t>(count);

  tbb::task_arena arena(options.threads > 0 ? options.threads : tbb::task_arena::automatic);
  arena.execute([&] {
    // Samples, each kept or dropped on its own, then compacted in Halton order: the same
    // roadmap for every thread count.
    std::vector<Point3> candidates(n);
    std::vector<double> room(n, -1);  // a lower bound of each kept sample's clearance, -1 dropped
    const double cap = options.safety + options.max_edge;
    const FlightSpace space = detail::flight_space(index, options);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 512), [&](const tbb::blocked_range<size_t>& r) {
      // The ground under a range of samples in one call, which overlaps their memory reads.
      std::vector<double> xy(3 * r.size());
      double *x = xy.data(), *y = x + r.size(), *g = y + r.size();
      for (size_t i = r.begin(); i < r.end(); ++i) {
        x[i - r.begin()] = e.xmin + halton(i + 1, 2) * wx;
        y[i - r.begin()] = e.ymin + halton(i + 1, 3) * wy;
      }
      index.ground(x, y, g, r.size());
      for (size_t i = r.begin(); i < r.end(); ++i) {
        const size_t k = i - r.begin();
        space.check_stop();  // a sample's check grows with the safety distance: stopped between two
        if (std::isnan(g[k])) continue;
        // Under the ceiling by construction; kept when the constraints allow it and it is clear
        // of the mesh.
        if (space.place(x[k], y[k], g[k], halton(i + 1, 5), candidates[i]) && !space.broken_by(candidates[i]) &&
            index.point_clear(candidates[i], options.safety))
          room[i] = std::max(options.safety, index.clearance_bound(candidates[i], cap));
        else
          room[i] = -1;
      }
    });
    std::vector<double> node_room;
    for (size_t i = 0; i < n; ++i)
      if (room[i] >= 0) {
        map.nodes.push_back(candidates[i]);
        node_room.push_back(room[i]);
      }
    // The ceiling's certificate of each node: the lowest ground within max_edge of it. Every
    // edge of the node lies over that square, so one whose higher end is at most max_agl above
    // it is under the ceiling without a walk.
    std::vector<double> node_low(map.nodes.size());
    tbb::parallel_for(size_t{0}, map.nodes.size(), [&](size_t i) {
      node_low[i] = space.ground().lowest_near(map.nodes[i][0], map.nodes[i][1], options.max_edge);
    });
    report(progress, 0.2);

    // A uniform grid of max_edge cells: the neighbours within max_edge of a node lie in the 27
    // cells around its own. The nodes are copied in cell order (a counting sort), so a cell's
    // nodes are one contiguous run found through a dense table of cell starts.
    const size_t m = map.nodes.size();
    const double cell = options.max_edge;
    double zmin = INFINITY, zmax = -INFINITY;
    for (const Point3& p : map.nodes) zmin = std::min(zmin, p[2]), zmax = std::max(zmax, p[2]);
    const int64_t nx = static_cast<int64_t>(wx / cell) + 1, ny = static_cast<int64_t>(wy / cell) + 1;
    const int64_t nz = m ? static_cast<int64_t>((zmax - zmin) / cell) + 1 : 0;
    if (static_cast<double>(nx) * static_cast<double>(ny) * static_cast<double>(nz) > 4e8)
      throw ArgumentError("max_edge", "is too small for the flight volume (more than 4e8 grid cells)");
    auto coord = [&](const Point3& p, int k) {
      const double lo = k == 0 ? e.xmin : k == 1 ? e.ymin : zmin;
      const int64_t n = k == 0 ? nx : k == 1 ? ny : nz;
      return std::clamp<int64_t>(static_cast<int64_t>(std::floor((p[k] - lo) / cell)), 0, n - 1);
    };
    auto key = [&](int64_t ix, int64_t iy, int64_t iz) { return static_cast<size_t>((iz * ny + iy) * nx + ix); };
    std::vector<uint32_t> cell_start(static_cast<size_t>(nx * ny * nz) + 1, 0);
    std::vector<size_t> node_cell(m);
    for (size_t i = 0; i < m; ++i) {
      const Point3& p = map.nodes[i];
      node_cell[i] = key(coord(p, 0), coord(p, 1), coord(p, 2));
      ++cell_start[node_cell[i] + 1];
    }
    for (size_t c = 1; c < cell_start.size(); ++c) cell_start[c] += cell_start[c - 1];
    struct Member {
      Point3 p;
      double room;
      uint32_t id;
    };
    std::vector<Member> members(m);
    {
      std::vector<uint32_t> fill(cell_start.begin(), cell_start.end() - 1);
      for (size_t i = 0; i < m; ++i)
        members[fill[node_cell[i]]++] = {map.nodes[i], node_room[i], static_cast<uint32_t>(i)};
    }

    const double reach2 = cell * cell;
    // Rounding of the clearances and the length: far below any safety distance that matters.
    const double certificate_slack = 1e-9 * (1 + cap);
    // Nodes in cell order, in chunks of `grain`: the next node reads the cells this one has
    // just read. A chunk's edges (j > i of each node i) go to its own list, in node order.
    constexpr size_t grain = 64;
    struct NodeEdges {
      uint32_t chunk, begin, count;
    };
    std::vector<NodeEdges> up(m);
    std::vector<std::vector<uint32_t>> chunk_edges((m + grain - 1) / grain);
    struct Near {
      uint32_t id;
      double room, length2;
      bool operator<(const Near& o) const { return id < o.id; }
    };
    tbb::enumerable_thread_specific<std::vector<Near>> buffers;
    tbb::parallel_for(size_t{0}, chunk_edges.size(), [&](size_t chunk) {
      std::vector<Near>& near = buffers.local();
      std::vector<uint32_t>& edges = chunk_edges[chunk];
      for (size_t member = chunk * grain; member < std::min(m, (chunk + 1) * grain); ++member) {
        space.check_stop();
        const uint32_t i = members[member].id;
        const Point3& p = members[member].p;
        const int64_t cx = coord(p, 0), cy = coord(p, 1), cz = coord(p, 2);
        size_t count = 0;
        for (int64_t z = std::max<int64_t>(cz - 1, 0); z <= std::min(cz + 1, nz - 1); ++z)
          for (int64_t y = std::max<int64_t>(cy - 1, 0); y <= std::min(cy + 1, ny - 1); ++y) {
            // The three cells of a row along x are consecutive: one run.
            const size_t first = key(std::max<int64_t>(cx - 1, 0), y, z);
            const size_t last = key(std::min(cx + 1, nx - 1), y, z);
            const uint32_t k0 = cell_start[first], k1 = cell_start[last + 1];
            if (near.size() < count + (k1 - k0)) near.resize(2 * (count + (k1 - k0)));
            for (uint32_t k = k0; k < k1; ++k) {
              // Written always, kept when near and j > i: a branch here would be mispredicted
              // for one member in ten, and cost three times the loop (bench/plan_ompl).
              const Member& q = members[k];
              const double length2 = squared_distance(p, q.p);
              near[count] = {q.id, q.room, length2};
              count += (length2 < reach2) & (q.id > i);
            }
          }
        std::sort(near.begin(), near.begin() + static_cast<std::ptrdiff_t>(count));
        up[i] = {static_cast<uint32_t>(chunk), static_cast<uint32_t>(edges.size()), 0};
        for (size_t k = 0; k < count; ++k) {
          const Near& q = near[k];
          // Free-space balls (Quinlan & Khatib, "Elastic bands", ICRA 1993): no mesh point lies
          // within room[i] of p or room[j] of q, so every point of [p, q] is at least
          // (room[i] + room[j] - |pq|) / 2 from the mesh. When that is the safety distance the
          // exact check can only agree: the same edges, most of them high above the roofs
          // without reading a triangle.
          // The ceiling is measured on every edge: the balls say nothing of it.
          if ((std::max(p[2], map.nodes[q.id][2]) - node_low[i] <= options.max_agl ||
               space.below_ceiling(p, map.nodes[q.id])) &&
              !space.broken_by(p, map.nodes[q.id]) &&
              (node_room[i] + q.room - std::sqrt(q.length2) >= 2 * options.safety + certificate_slack ||
               index.segment_clear(p, map.nodes[q.id], options.safety)))
            edges.push_back(q.id);
        }
        up[i].count = static_cast<uint32_t>(edges.size()) - up[i].begin;
      }
    });
    report(progress, 0.9);
    auto up_of = [&](size_t i) {
      const uint32_t* first = chunk_edges[up[i].chunk].data() + up[i].begin;
      return std::make_pair(first, first + up[i].count);
    };

    // Both directions, ascending per node.
    std::vector<uint32_t> degree(m, 0);
    for (size_t i = 0; i < m; ++i) {
      degree[i] += up[i].count;
      for (auto [j, end] = up_of(i); j != end; ++j) ++degree[*j];
    }
    size_t listings = 0;
    for (size_t i = 0; i < m; ++i) listings += degree[i];
    if (listings > UINT32_MAX) throw ArgumentError("max_edge", "gives 2^32 or more edge listings; use a smaller one");
    map.start.assign(m + 1, 0);
    for (size_t i = 0; i < m; ++i) map.start[i + 1] = map.start[i] + degree[i];
    map.neighbour.resize(map.start[m]);
    std::vector<uint32_t> fill(map.start.begin(), map.start.end() - 1);
    // Visiting i in ascending order writes the lower neighbours (from their up lists) before
    // the upper ones, so each list comes out ascending.
    for (size_t i = 0; i < m; ++i)
      for (auto [j, end] = up_of(i); j != end; ++j) map.neighbour[fill[*j]++] = static_cast<uint32_t>(i);
    for (size_t i = 0; i < m; ++i)
      for (auto [j, end] = up_of(i); j != end; ++j) map.neighbour[fill[i]++] = *j;
    // Each edge once, from its lower end: half of label_components()'s listings.
    map.component = detail::components(m, [&](auto&& join) {
      for (size_t i = 0; i < m; ++i)
        for (auto [j, end] = up_of(i); j != end; ++j) join(static_cast<uint32_t>(i), *j);
    });
  });
  report(progress, 1);
  return map;
}

void label_components(Roadmap& map) {
  // Every listing taken as an undirected edge (a roadmap file's lists need not be symmetric: a
  // label must never part two nodes a directed path joins).
  map.component = detail::components(map.nodes.size(), [&](auto&& join) {
    for (uint32_t u = 0; u < map.nodes.size(); ++u)
      for (uint32_t k = map.start[u]; k < map.start[u + 1]; ++k) join(u, map.neighbour[k]);
  });
}

}  // namespace dsmplan
