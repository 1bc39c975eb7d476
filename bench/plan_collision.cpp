// The planner's validity checker (dsmplan/plan.hpp, ClearanceIndex) on the full NRW DOM1 tile:
// the XY-3 mesh at 1 m (1000 x 1000 cells, 1,996,002 triangles), the query a PRM makes for
// every roadmap edge: is a straight 20-35 m segment at least d = 2 m (the paper's safety
// distance, Section 5) from every triangle?
//   1. Build time and size of the index.
//   2. segment_clear() per second on random segments whose ends are 2-120 m above ground, on
//      one thread and with TBB's parallel_for on every core; also by altitude band (near the
//      ground most segments need triangles measured; high up the bucket heights decide).
//   3. Brute force over all triangles on a sample of the same segments: its speed, and that it
//      agrees with the index on every one of them.
//   4. The alternative: a textbook BVH over the same triangles with the same exact distance,
//      by altitude band (it must agree with the index on every segment).
//   5. The bucket size: build time, listings and single-thread speed for a few sizes around the
//      automatic one. Items 2, 4 and 5 are the numbers in bench/README.md.
// Timing (bench/bench_kit.hpp): whatever is compared runs in interleaved pairs or rounds (one
// thread / all threads, index / brute force, index / BVH, the bucket sizes one after another in
// every round), at least 5; a rate is the median with its min-max, a ratio the median of the
// per-pair ratios, and the 1-minute load average at the pairs' starts is printed. Never a best-of.
//   build/bench/bench_plan_collision [PAIRS = 5] [--queries [N = 200000]]
// --queries: items 1 and 2 only, on N segments, for paired runs of two builds (or callgrind's
// cache simulation of them) against each other.
// Exit code 1 on any disagreement with brute force or the BVH.
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "bench_kit.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"

using namespace dsmplan;
using namespace bench;

namespace {

constexpr double safety = 2.0;

struct Query {
  Point3 p, q;
};

// Both ends lo-hi m above the mesh, 20-35 m apart, climbing or sinking at most 30 degrees.
std::vector<Query> make_queries(const ClearanceIndex& index, const Grid& grid, size_t count, double lo, double hi,
                                uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> ux(grid.x0, grid.x1()), uy(grid.y1(), grid.y0), agl(lo, hi), len(20, 35),
      heading(0, 2 * M_PI), pitch(-M_PI / 6, M_PI / 6);
  std::vector<Query> out;
  while (out.size() < count) {
    const double x = ux(rng), y = uy(rng), g = index.ground(x, y);
    if (std::isnan(g)) continue;
    const Point3 p{x, y, g + agl(rng)};
    const double l = len(rng), h = heading(rng), c = pitch(rng);
    const Point3 q{p[0] + l * std::cos(h) * std::cos(c), p[1] + l * std::sin(h) * std::cos(c), p[2] + l * std::sin(c)};
    const double gq = index.ground(q[0], q[1]);
    if (std::isnan(gq) || q[2] - gq < lo || q[2] - gq > hi) continue;
    out.push_back({p, q});
  }
  return out;
}

// segment_clear() per second over all queries, one thread, one run; `clear` counts the clear ones.
double single(const ClearanceIndex& index, const std::vector<Query>& queries, size_t& clear) {
  const auto start = std::chrono::steady_clock::now();
  clear = 0;
  for (const Query& s : queries) clear += index.segment_clear(s.p, s.q, safety);
  return queries.size() / seconds_since(start);
}

// The same on every core (TBB).
double parallel(const ClearanceIndex& index, const std::vector<Query>& queries, size_t& clear) {
  const auto start = std::chrono::steady_clock::now();
  clear = tbb::parallel_reduce(
      tbb::blocked_range<size_t>(0, queries.size(), 256), size_t(0),
      [&](const tbb::blocked_range<size_t>& r, size_t n) {
        for (size_t i = r.begin(); i != r.end(); ++i) n += index.segment_clear(queries[i].p, queries[i].q, safety);
        return n;
      },
      [](size_t a, size_t b) { return a + b; });
  return queries.size() / seconds_since(start);
}

// The alternative the header weighs: a textbook bounding volume hierarchy (Ericson, ch. 6;
// median split on the longest axis of the centroids, 4 triangles a leaf, axis-aligned boxes),
// queried by descending into every box that the segment passes within d of (slab test on the
// box grown by d) and measuring each leaf triangle exactly. Same local coordinates as the index.
class Bvh {
public:
  Bvh(const Mesh& mesh, const Point3& o) {
    tris_.resize(mesh.triangles.size());
    for (size_t t = 0; t < tris_.size(); ++t)
      for (int k = 0; k < 3; ++k) {
        const Vertex& v = mesh.vertices[mesh.triangles[t][k]];
        tris_[t][k] = {v.x - o[0], v.y - o[1], v.z - o[2]};
      }
    order_.resize(tris_.size());
    for (uint32_t t = 0; t < order_.size(); ++t) order_[t] = t;
    nodes_.reserve(2 * tris_.size() / leaf + 2);
    nodes_.emplace_back();
    build(0, static_cast<uint32_t>(order_.size()), 0);
  }

  bool clear(const Point3& p, const Point3& q, double d) const {
    uint32_t stack[128];
    int top = 0;
    stack[top++] = 0;
    const double dir[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
    while (top) {
      const Node& node = nodes_[stack[--top]];
      double t0 = 0, t1 = 1;
      bool hit = true;
      for (int k = 0; k < 3 && hit; ++k) {
        const double lo = node.lo[k] - d, hi = node.hi[k] + d;
        if (dir[k] == 0) {
          hit = p[k] >= lo && p[k] <= hi;
        } else {
          double a = (lo - p[k]) / dir[k], b = (hi - p[k]) / dir[k];
          if (a > b) std::swap(a, b);
          t0 = std::max(t0, a), t1 = std::min(t1, b);
          hit = t0 <= t1;
        }
      }
      if (!hit) continue;
      if (node.count) {
        for (uint32_t i = node.first; i < node.first + node.count; ++i) {
          const auto& t = tris_[order_[i]];
          if (std::sqrt(segment_triangle_squared_distance(p, q, t[0], t[1], t[2])) < d) return false;
        }
      } else {
        stack[top++] = node.first;
        stack[top++] = node.first + 1;
      }
    }
    return true;
  }
  size_t nodes() const { return nodes_.size(); }

private:
  static constexpr uint32_t leaf = 4;
  struct Node {
    double lo[3], hi[3];
    uint32_t first, count;  ///< leaf: order_[first, first+count); inner: children first, first+1
  };
  // Fills the reserved slot nodes_[slot] with the subtree of order_[begin, end).
  void build(uint32_t begin, uint32_t end, uint32_t slot) {
    Node node{{INFINITY, INFINITY, INFINITY}, {-INFINITY, -INFINITY, -INFINITY}, begin, end - begin};
    double clo[3] = {INFINITY, INFINITY, INFINITY}, chi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (uint32_t i = begin; i < end; ++i)
      for (int k = 0; k < 3; ++k) {
        const auto& t = tris_[order_[i]];
        const double c = (t[0][k] + t[1][k] + t[2][k]) / 3;
        clo[k] = std::min(clo[k], c), chi[k] = std::max(chi[k], c);
        for (int v = 0; v < 3; ++v)
          node.lo[k] = std::min(node.lo[k], t[v][k]), node.hi[k] = std::max(node.hi[k], t[v][k]);
      }
    if (end - begin > leaf) {
      const int axis = chi[0] - clo[0] >= chi[1] - clo[1] ? (chi[0] - clo[0] >= chi[2] - clo[2] ? 0 : 2)
                                                          : (chi[1] - clo[1] >= chi[2] - clo[2] ? 1 : 2);
      const uint32_t mid = begin + (end - begin) / 2;
      std::nth_element(order_.begin() + begin, order_.begin() + mid, order_.begin() + end, [&](uint32_t a, uint32_t b) {
        return tris_[a][0][axis] + tris_[a][1][axis] + tris_[a][2][axis] <
               tris_[b][0][axis] + tris_[b][1][axis] + tris_[b][2][axis];
      });
      // Children are allocated as a pair, so an inner node needs only the first one's index.
      const uint32_t left = static_cast<uint32_t>(nodes_.size());
      nodes_.emplace_back();
      nodes_.emplace_back();
      build(begin, mid, left);
      build(mid, end, left + 1);
      node.first = left;
      node.count = 0;
    }
    nodes_[slot] = node;
  }
  std::vector<std::array<Point3, 3>> tris_;
  std::vector<uint32_t> order_;
  std::vector<Node> nodes_;
};

}  // namespace

int main(int argc, char** argv) {
  const int pairs = argc > 1 ? std::max(5, std::atoi(argv[1])) : 5;
  const bool queries_only = argc > 2 && std::string(argv[2]) == "--queries";
  const unsigned cores = std::max(1u, std::thread::hardware_concurrency());
  const Grid grid = read_raster(tile);
  const Mesh mesh = triangulate_xy3(grid);
  std::printf("NRW DOM1 tile, XY-3 mesh at 1 m: %zu vertices, %zu triangles; d = %.1f m; %u cores; %s\n",
              mesh.vertices.size(), mesh.triangles.size(), safety, cores, cpu_model().c_str());
  std::printf("%d pairs (or rounds) per comparison; rates and seconds: median (min-max); ratios: the median\n", pairs);
  std::printf("(min-max) of the per-pair ratios; load average %s at the start\n\n", load_average().c_str());

  // 1. and 4.: the index's build and the BVH's, in pairs.
  Samples build, bvh_build;
  LoadLog build_loads;
  std::unique_ptr<ClearanceIndex> index;
  std::unique_ptr<Bvh> bvh;
  for (int pair = 0; pair < pairs; ++pair) {
    build_loads.note();
    index.reset();
    const auto start = std::chrono::steady_clock::now();
    index = std::make_unique<ClearanceIndex>(mesh);
    build.add(seconds_since(start));
    if (queries_only) continue;
    bvh.reset();
    const auto bvh_start = std::chrono::steady_clock::now();
    bvh = std::make_unique<Bvh>(mesh, index->origin());
    bvh_build.add(seconds_since(bvh_start));
  }
  const double megabytes = static_cast<double>(index->memory_bytes()) / 1e6;
  std::printf("index: bucket %.2f m, %d x %d buckets, %zu listings (%.2f per triangle), %.0f MB, build %s s\n",
              index->bucket_size(), index->bucket_columns(), index->bucket_rows(), index->bucket_listings(),
              double(index->bucket_listings()) / mesh.triangles.size(), megabytes, build.text().c_str());
  std::printf("(build paired with the BVH's: load average %s at the pairs' starts)\n\n", build_loads.text().c_str());

  // 2. One thread against all, per band.
  const size_t n = queries_only && argc > 3 ? std::max(1000, std::atoi(argv[3])) : 200000;
  const std::vector<Query> all = make_queries(*index, grid, n, 2, 120, 1);
  struct Band {
    const char* name;
    double lo, hi;
  };
  const Band bands[] = {{"2-120 m (all)", 2, 120}, {"2-10 m", 2, 10}, {"10-30 m", 10, 30}, {"30-120 m", 30, 120}};
  LoadLog thread_loads;
  std::printf(
      "| segments 20-35 m, ends above ground | clear | segment_clear/s, 1 thread | %u threads (TBB) | speed-up |\n",
      cores);
  std::printf("|---|---|---|---|---|\n");
  for (const Band& band : bands) {
    const std::vector<Query> queries =
        band.lo == 2 && band.hi == 120 ? all : make_queries(*index, grid, n / 2, band.lo, band.hi, 2);
    Samples one, many;
    size_t clear = 0, clear_many = 0;
    for (int pair = 0; pair < pairs; ++pair) {
      thread_loads.note();
      one.add(single(*index, queries, clear));
      many.add(parallel(*index, queries, clear_many));
    }
    std::printf("| %s | %.1f %% | %s | %s | %s |\n", band.name, 100.0 * clear / queries.size(),
                one.text("%.0f").c_str(), many.text("%.0f").c_str(), ratios(many, one).text("%.2f").c_str());
  }
  std::printf("(load average %s at the pairs' starts)\n", thread_loads.text().c_str());
  if (queries_only) return 0;

  // 3. Brute force: every triangle, the same exact distance, in the index's local coordinates;
  // `sample` segments in all, a slice of them in each pair, beside the index on all segments.
  std::vector<std::array<Point3, 3>> local(mesh.triangles.size());
  const Point3 o = index->origin();
  for (size_t t = 0; t < mesh.triangles.size(); ++t)
    for (int k = 0; k < 3; ++k) {
      const Vertex& v = mesh.vertices[mesh.triangles[t][k]];
      local[t][k] = {v.x - o[0], v.y - o[1], v.z - o[2]};
    }
  const size_t per_pair = 8, sample = per_pair * pairs;
  size_t disagree = 0, brute_clear = 0;
  Samples brute_rate, index_rate;
  LoadLog brute_loads;
  for (int pair = 0; pair < pairs; ++pair) {
    brute_loads.note();
    const auto start = std::chrono::steady_clock::now();
    for (size_t i = pair * per_pair; i < (pair + 1) * per_pair; ++i) {
      const Query& s = all[i * (all.size() / sample)];
      const Point3 p{s.p[0] - o[0], s.p[1] - o[1], s.p[2] - o[2]}, q{s.q[0] - o[0], s.q[1] - o[1], s.q[2] - o[2]};
      bool clear = true;
      for (const auto& t : local)
        if (segment_triangle_distance(p, q, t[0], t[1], t[2]) < safety) {
          clear = false;
          break;
        }
      brute_clear += clear;
      disagree += clear != index->segment_clear(s.p, s.q, safety);
    }
    brute_rate.add(per_pair / seconds_since(start));
    size_t ignored = 0;
    index_rate.add(single(*index, all, ignored));
  }
  std::printf("\n| method | segment_clear/s, 1 thread | vs brute force |\n|---|---|---|\n");
  std::printf("| brute force (all %zu triangles, stops at the first hit; %zu segments a pair) | %s | 1 |\n",
              mesh.triangles.size(), per_pair, brute_rate.text("%.1f").c_str());
  std::printf("| ClearanceIndex | %s | %s x |\n", index_rate.text("%.0f").c_str(),
              ratios(index_rate, brute_rate).text("%.0f").c_str());
  std::printf("(load average %s at the pairs' starts)\n", brute_loads.text().c_str());
  std::printf("disagreements with brute force: %zu of %zu (%zu clear)\n\n", disagree, sample, brute_clear);

  // 4. The BVH against the index, per band: agreement once, then pairs.
  std::printf(
      "| structure | build s | segment_clear/s 2-120 m | 2-10 m | 10-30 m | 30-120 m |\n|---|---|---|---|---|---|\n");
  size_t bvh_disagree = 0;
  Samples bvh_rates[4], index_rates[4];
  LoadLog bvh_loads;
  const auto bvh_pass = [&](const std::vector<Query>& queries) {
    const auto start = std::chrono::steady_clock::now();
    size_t clear = 0;
    for (const Query& s : queries) {
      const Point3 p{s.p[0] - o[0], s.p[1] - o[1], s.p[2] - o[2]}, q{s.q[0] - o[0], s.q[1] - o[1], s.q[2] - o[2]};
      clear += bvh->clear(p, q, safety);
    }
    const double rate = queries.size() / seconds_since(start);
    return clear == size_t(-1) ? 0 : rate;  // keeps `clear` alive
  };
  for (int b = 0; b < 4; ++b) {
    const std::vector<Query> queries = make_queries(*index, grid, 20000, bands[b].lo, bands[b].hi, 4 + b);
    for (const Query& s : queries) {
      const Point3 p{s.p[0] - o[0], s.p[1] - o[1], s.p[2] - o[2]}, q{s.q[0] - o[0], s.q[1] - o[1], s.q[2] - o[2]};
      bvh_disagree += bvh->clear(p, q, safety) != index->segment_clear(s.p, s.q, safety);
    }
    for (int pair = 0; pair < pairs; ++pair) {
      bvh_loads.note();
      bvh_rates[b].add(bvh_pass(queries));
      size_t ignored = 0;
      index_rates[b].add(single(*index, queries, ignored));
    }
  }
  std::printf("| ClearanceIndex (bucket grid, height bounds) | %s | %s | %s | %s | %s |\n", build.text().c_str(),
              index_rates[0].text("%.0f").c_str(), index_rates[1].text("%.0f").c_str(),
              index_rates[2].text("%.0f").c_str(), index_rates[3].text("%.0f").c_str());
  std::printf("| BVH (median split, 4 a leaf, %zu nodes) | %s | %s | %s | %s | %s |\n", bvh->nodes(),
              bvh_build.text().c_str(), bvh_rates[0].text("%.0f").c_str(), bvh_rates[1].text("%.0f").c_str(),
              bvh_rates[2].text("%.0f").c_str(), bvh_rates[3].text("%.0f").c_str());
  std::printf("| index / BVH, per pair | %s | %s | %s | %s | %s |\n", ratios(bvh_build, build).text("%.2f").c_str(),
              ratios(index_rates[0], bvh_rates[0]).text("%.2f").c_str(),
              ratios(index_rates[1], bvh_rates[1]).text("%.2f").c_str(),
              ratios(index_rates[2], bvh_rates[2]).text("%.2f").c_str(),
              ratios(index_rates[3], bvh_rates[3]).text("%.2f").c_str());
  std::printf("(build: BVH seconds / index seconds; rates: index / BVH; load average %s at the pairs' starts)\n",
              bvh_loads.text().c_str());
  std::printf("BVH disagreements with the index: %zu of %d\n\n", bvh_disagree, 4 * 20000);
  disagree += bvh_disagree;
  bvh.reset();

  // 5. Bucket sizes: every round builds and queries each size once, in turn.
  const std::vector<Query> some(all.begin(), all.begin() + 50000);
  const std::vector<Query> low = make_queries(*index, grid, 20000, 2, 10, 3);
  const double sizes[] = {0.0, 1.0, 2.0, 4.0, 5.66, 8.0, 11.3, 16.0};
  constexpr int size_count = sizeof sizes / sizeof sizes[0];
  Samples size_build[size_count], size_rate[size_count], size_low[size_count];
  double size_bucket[size_count] = {};
  int size_buckets[size_count] = {};
  double size_listings[size_count] = {};
  LoadLog size_loads;
  index.reset();
  for (int round = 0; round < pairs; ++round) {
    size_loads.note();
    for (int k = 0; k < size_count; ++k) {
      ClearanceOptions options;
      options.bucket_size = sizes[k];
      const auto t0 = std::chrono::steady_clock::now();
      const ClearanceIndex sized(mesh, options);
      size_build[k].add(seconds_since(t0));
      size_t ignored = 0;
      size_rate[k].add(single(sized, some, ignored));
      size_low[k].add(single(sized, low, ignored));
      size_bucket[k] = sized.bucket_size();
      size_buckets[k] = sized.bucket_columns() * sized.bucket_rows();
      size_listings[k] = double(sized.bucket_listings()) / mesh.triangles.size();
    }
  }
  std::printf("| bucket m | buckets | listings per triangle | build s | segment_clear/s 2-120 m | 2-10 m |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (int k = 0; k < size_count; ++k) {
    std::printf("| %.2f%s | %d | %.2f | %s | %s | %s |\n", size_bucket[k], sizes[k] == 0 ? " (auto)" : "",
                size_buckets[k], size_listings[k], size_build[k].text().c_str(), size_rate[k].text("%.0f").c_str(),
                size_low[k].text("%.0f").c_str());
  }
  std::printf("(%d rounds, every size once a round; load average %s at the rounds' starts, %s at the end)\n", pairs,
              size_loads.text().c_str(), load_average().c_str());
  return disagree == 0 ? 0 : 1;
}
