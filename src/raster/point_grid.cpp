// Grids point clouds into a DSM with one height per cell, the median of the points that fall in
// it: the fusion rule of Adolf & Hirschmueller, "Meshing and Simplification of High Resolution
// Urban Surface Data for UAV Path Planning", Section 2 (median per DSM cell). Max is offered as
// the conservative alternative that never lowers an obstacle.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <string>
#include <vector>

#include "dsmplan/points.hpp"
#include "dsmplan/raster.hpp"

namespace dsmplan {
namespace {

constexpr size_t kReportEvery = size_t{1} << 20;
// Bounds the grid so that an absurdly fine resolution is a message, not an allocation failure.
constexpr double kMaxCells = double(std::numeric_limits<int32_t>::max());

std::string crs_text(const Crs& crs) { return crs.definition.empty() ? crs.wkt : crs.definition; }

std::string shortened(const std::string& text) { return text.size() <= 60 ? text : text.substr(0, 60) + "..."; }

std::string number(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.10g", value);
  return text;
}

// The cell rule of raster.hpp: a cell covers x in [west, east) and y in (south, north], so a
// point on a cell's west or north edge belongs to it. With x0 = floor(min_x/res)*res and
// y0 = ceil(max_y/res)*res the westmost point lands in column 0 and the northmost in row 0,
// also when max_y is an exact multiple of res (it then lies on row 0's north edge). Both index
// formulas are monotonic in floating point, so bounding the extreme points bounds every point.
struct Lattice {
  double x0, y0, res;
  int64_t column(double x) const { return static_cast<int64_t>(std::floor((x - x0) / res)); }
  int64_t row(double y) const { return static_cast<int64_t>(std::floor((y0 - y) / res)); }
};

}  // namespace

const char* to_string(Fusion fusion) { return fusion == Fusion::Max ? "max" : "median"; }

Fusion parse_fusion(const std::string& name) {
  for (Fusion fusion : {Fusion::Median, Fusion::Max}) {
    if (name == to_string(fusion)) return fusion;
  }
  require_choice("fusion", name, {"median", "max"});
  return Fusion::Median;  // not reached: require_choice() threw
}

void choose_classes(GridPointsOptions& options, const std::vector<int>& keep,
                    const std::optional<std::vector<int>>& drop, bool keep_all) {
  if (keep_all && !keep.empty())
    throw ArgumentError("keep_classes", "keeps only the classes listed, --keep-all-classes every class: give one");
  options.keep_classes = keep;
  const bool drop_given = drop && !drop->empty();
  if (keep_all || (!keep.empty() && !drop_given)) {
    options.drop_classes.clear();  // the classes listed alone: exactly those, noise too if listed
  } else if (drop_given) {
    options.drop_classes = *drop;
  }
}

Grid grid_points(const std::vector<PointCloud>& clouds, const GridPointsOptions& options, const Progress& progress) {
  const double res = options.resolution;
  if (!(res > 0) || !std::isfinite(res))
    throw ArgumentError("resolution", "the resolution must be a positive number, got " + number(res));
  // dropped[c]: points of class c are left out (not kept by keep_classes, or dropped).
  std::array<bool, 256> dropped{};
  std::string kept_list;
  if (!options.keep_classes.empty()) {
    dropped.fill(true);
    for (int cls : options.keep_classes) {
      if (cls < 0 || cls > 255)
        throw ArgumentError("keep_classes", "class " + std::to_string(cls) + " is not in 0-255");
      if (dropped[cls]) kept_list += (kept_list.empty() ? "" : ", ") + std::to_string(cls);
      dropped[cls] = false;
    }
  }
  std::string dropped_list;
  for (int cls : options.drop_classes) {
    if (cls < 0 || cls > 255) throw ArgumentError("drop_classes", "class " + std::to_string(cls) + " is not in 0-255");
    if (!options.keep_classes.empty() &&
        std::find(options.keep_classes.begin(), options.keep_classes.end(), cls) != options.keep_classes.end())
      throw ArgumentError("keep_classes", "class " + std::to_string(cls) +
                                              " is both kept (--classes) and dropped (--drop-classes); give it to one");
    dropped[cls] = true;
    dropped_list += (dropped_list.empty() ? "" : ", ") + std::to_string(cls);
  }

  const Crs* crs = nullptr;
  size_t total = 0;
  for (const PointCloud& cloud : clouds) {
    if (cloud.y.size() != cloud.size() || cloud.z.size() != cloud.size() || cloud.classification.size() != cloud.size())
      throw ArgumentError("points", "a point cloud has coordinate and class arrays of different lengths");
    total += cloud.size();
    if (!cloud.crs.known()) continue;
    if (!crs)
      crs = &cloud.crs;
    else if (crs_text(cloud.crs) != crs_text(*crs))
      throw ArgumentError("points", "the point clouds are in different CRSs ('" + shortened(crs_text(*crs)) +
                                        "' and '" + shortened(crs_text(cloud.crs)) + "'); reproject them to one first");
  }

  // Every pass visits the kept points in the same order and reports its share of the progress.
  auto for_each_kept = [&](double begin, double end, auto&& visit) {
    size_t seen = 0;
    for (const PointCloud& cloud : clouds) {
      for (size_t i = 0; i < cloud.size(); ++i) {
        if (++seen % kReportEvery == 0) report(progress, begin + (end - begin) * double(seen) / double(total));
        if (!dropped[cloud.classification[i]]) visit(cloud.x[i], cloud.y[i], cloud.z[i]);
      }
    }
  };

  size_t kept = 0;
  double min_x = INFINITY, max_x = -INFINITY, min_y = INFINITY, max_y = -INFINITY;
  for_each_kept(0.0, 0.2, [&](double x, double y, double z) {
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z))
      throw ArgumentError(
          "points", "a point has a non-finite coordinate (" + number(x) + " " + number(y) + " " + number(z) + ")");
    ++kept;
    min_x = std::min(min_x, x);
    max_x = std::max(max_x, x);
    min_y = std::min(min_y, y);
    max_y = std::max(max_y, y);
  });
  if (kept == 0)
    throw InputError("", "",
                     total == 0           ? "the point clouds hold no points"
                     : !kept_list.empty() ? "no point of classes " + kept_list + " (--classes) among the " +
                                                std::to_string(total) + " points"
                                          : "no points left after dropping classes " + dropped_list + " (all " +
                                                std::to_string(total) + " points had them)");
  if (kept >= std::numeric_limits<uint32_t>::max())
    throw ArgumentError("points", std::to_string(kept) + " points are more than one grid can take; grid them in tiles");

  Lattice lattice{std::floor(min_x / res) * res, std::ceil(max_y / res) * res, res};
  // floor(v/res)*res can round past v; one cell more keeps the extreme point inside.
  if (lattice.x0 > min_x) lattice.x0 -= res;
  if (lattice.y0 < max_y) lattice.y0 += res;
  const double columns = std::floor((max_x - lattice.x0) / res) + 1, rows = std::floor((lattice.y0 - min_y) / res) + 1;
  if (!(columns >= 1 && rows >= 1 && columns * rows <= kMaxCells))  // also catches overflow to inf
    throw ArgumentError("resolution", "a resolution of " + number(res) + " gives " + number(columns) + " x " +
                                          number(rows) + " cells for the points' extent; choose a coarser one");
  // The grid's float and the counting sort's bound per cell, a double per kept point.
  const std::string memory =
      memory_problem(columns * rows * (sizeof(float) + sizeof(uint32_t) + options.other_bytes_per_cell) +
                     double(kept) * sizeof(double) + options.other_bytes);
  if (!memory.empty())
    throw ArgumentError("resolution", "a resolution of " + number(res) + " gives " + number(columns) + " x " +
                                          number(rows) + " cells for " + std::to_string(kept) + " points, which " +
                                          memory);
  Grid grid(static_cast<int>(columns), static_cast<int>(rows), lattice.x0, lattice.y0, res, res);
  // What dsmplan's readers would refuse is not made (points at 1e12, cells too fine for them).
  if (const std::string problem = frame_problem(grid); !problem.empty())
    throw ArgumentError("points", "the points' extent (x " + number(min_x) + " to " + number(max_x) + ", y " +
                                      number(min_y) + " to " + number(max_y) + ") at a resolution of " + number(res) +
                                      ": " + problem);
  grid.crs = crs ? *crs : Crs{};
  auto cell_of = [&](double x, double y) { return grid.index(int(lattice.column(x)), int(lattice.row(y))); };

  // Counting sort by cell: bound[c] first counts the points of cell c, then becomes the end of
  // its bucket; filling each bucket from its end leaves bound[c] at the bucket's start, so
  // cell c's heights are heights[bound[c] .. bound[c+1]).
  std::vector<uint32_t> bound(grid.cells() + 1, 0);
  for_each_kept(0.2, 0.4, [&](double x, double y, double) { ++bound[cell_of(x, y)]; });
  for (size_t c = 1; c < grid.cells(); ++c) bound[c] += bound[c - 1];
  bound[grid.cells()] = static_cast<uint32_t>(kept);
  std::vector<double> heights(kept);
  for_each_kept(0.4, 0.7, [&](double x, double y, double z) { heights[--bound[cell_of(x, y)]] = z; });

  size_t fused = 0;
  for (size_t c = 0; c < grid.cells(); ++c) {
    const auto begin = heights.begin() + bound[c], end = heights.begin() + bound[c + 1];
    if (begin == end) continue;  // no point: a hole, left for an explicit filling step
    double z;
    if (options.fusion == Fusion::Max) {
      z = *std::max_element(begin, end);
    } else {
      const auto middle = begin + (end - begin) / 2;
      std::nth_element(begin, middle, end);
      z = *middle;
      if ((end - begin) % 2 == 0) z = (z + *std::max_element(begin, middle)) / 2;
    }
    grid.z[c] = static_cast<float>(z);
    fused += static_cast<size_t>(end - begin);
    if (fused >= kReportEvery) {
      report(progress, 0.7 + 0.3 * double(bound[c + 1]) / double(kept));
      fused = 0;
    }
  }
  report(progress, 1.0);
  return grid;
}

}  // namespace dsmplan
