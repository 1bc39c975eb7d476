// Pair selection: which images to match. The seed paper (Adolf & Hirschmüller, Section 2)
// matches "all overlapping images in flight-direction as well as perpendicular to it"; `auto`
// takes the pairs whose footprints overlap enough and whose base-to-height ratio B/H makes a
// useful intersection angle (too small: depth noise grows as H/B; too large: occlusions and
// perspective distortion defeat the matching; aerial photogrammetry works with B/H of about
// 0.1 (dense multi-view blocks) to 1), each camera keeping its best few partners.
// So that a block of many views costs O(views), the footprints' bounding boxes on the ground are
// met first by sort and sweep (M. Shamos and D. Hoey, "Geometric intersection problems", FOCS
// 1976: the sweep over interval ends; the broad phase of collision detection), and only each
// camera's best candidates by the boxes have their footprints cut exactly.
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "core/text.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace dsmplan {

namespace {

// Where the ray of left pixel (u, v) meets the plane Z = ground, and the right camera's pixel
// (ur, vr) of that point; false when the ray runs parallel to the plane, meets it behind the
// camera, or the right camera does not face the point.
bool seen_on_plane(const FrameCamera& left, const FrameCamera& right, double u, double v, double ground, Vec3& X,
                   double& ur, double& vr) {
  const Vec3 ray = pixel_ray(left, u, v);
  if (std::abs(ray[2]) < 1e-12) return false;
  const double t = (ground - left.center[2]) / ray[2];
  if (!(t > 0)) return false;
  X = {left.center[0] + t * ray[0], left.center[1] + t * ray[1], ground};
  return project(right, X, ur, vr);
}

}  // namespace

double footprint_overlap(const FrameCamera& left, const FrameCamera& right, double ground_height) {
  // A 16 x 16 lattice of pixel centres, each standing for its cell of the image; seen when the
  // right camera's pixel lies within its image's area.
  int seen = 0, total = 0;
  for (int i = 0; i < 16; ++i)
    for (int j = 0; j < 16; ++j) {
      const double u = (i + 0.5) / 16 * left.width - 0.5, v = (j + 0.5) / 16 * left.height - 0.5;
      ++total;
      Vec3 X;
      double ur, vr;
      if (seen_on_plane(left, right, u, v, ground_height, X, ur, vr) && ur >= -0.5 && vr >= -0.5 &&
          ur <= right.width - 0.5 && vr <= right.height - 0.5)
        ++seen;
    }
  return static_cast<double>(seen) / total;
}

bool footprint_box(const FrameCamera& left, const FrameCamera& right, double ground_height,
                   std::array<double, 4>& box) {
  bool any = false;
  for (int i = 0; i <= 64; ++i)
    for (int j = 0; j <= 64; ++j) {
      Vec3 X;
      double u, v;
      if (!seen_on_plane(left, right, i / 64.0 * (left.width - 1), j / 64.0 * (left.height - 1), ground_height, X, u,
                         v) ||
          u < 0 || v < 0 || u > right.width - 1 || v > right.height - 1)
        continue;
      if (!any) box = {X[0], X[1], X[0], X[1]};
      any = true;
      box = {std::min(box[0], X[0]), std::min(box[1], X[1]), std::max(box[2], X[0]), std::max(box[3], X[1])};
    }
  return any;
}

double base_to_height(const FrameCamera& left, const FrameCamera& right, double ground_height) {
  const double dx = left.center[0] - right.center[0], dy = left.center[1] - right.center[1],
               dz = left.center[2] - right.center[2];
  const double H = (left.center[2] + right.center[2]) / 2 - ground_height;
  if (!(H > 0)) return INFINITY;
  return std::sqrt(dx * dx + dy * dy + dz * dz) / H;
}

std::array<double, 4> ground_box(const FrameCamera& camera, double ground_height) {
  constexpr double kInfinity = std::numeric_limits<double>::infinity();
  std::array<double, 4> box{kInfinity, kInfinity, -kInfinity, -kInfinity};
  const double w = camera.width, h = camera.height;
  for (int side = 0; side < 4; ++side)
    for (int k = 0; k <= 16; ++k) {
      const double t = k / 16.0;
      const double u = side < 2 ? t * w - 0.5 : (side == 2 ? -0.5 : w - 0.5);
      const double v = side < 2 ? (side == 0 ? -0.5 : h - 0.5) : t * h - 0.5;
      const Vec3 ray = pixel_ray(camera, u, v);
      const double along = std::abs(ray[2]) < 1e-12 ? -1 : (ground_height - camera.center[2]) / ray[2];
      if (!(along > 0)) return {-kInfinity, -kInfinity, kInfinity, kInfinity};  // sees the horizon
      const double x = camera.center[0] + along * ray[0], y = camera.center[1] + along * ray[1];
      box = {std::min(box[0], x), std::min(box[1], y), std::max(box[2], x), std::max(box[3], y)};
    }
  const double mx = 0.05 * (box[2] - box[0]), my = 0.05 * (box[3] - box[1]);  // a distorted edge bows
  return {box[0] - mx, box[1] - my, box[2] + mx, box[3] + my};
}

std::vector<std::pair<int, int>> select_pairs_auto(const std::vector<FrameCamera>& cameras,
                                                   const PairSelectionOptions& options, PairSelectionStats* stats) {
  if (options.max_partners < 1) throw ArgumentError("max_partners", "must be at least 1");
  if (!(options.min_overlap > 0 && options.min_overlap <= 1)) throw ArgumentError("min_overlap", "must lie in (0, 1]");
  // Below this B/H a pair's depth noise (as H/B) outweighs its overlap: such partners rank lower.
  constexpr double kPreferredBaseToHeight = 0.3;
  const int n = static_cast<int>(cameras.size());
  const double ground = options.ground_height;
  PairSelectionStats counts;

  // 1. Every camera's box on the ground (O(n)), and the pairs whose boxes meet, by a sweep along x
  //    (O(n log n + the pairs met)): no other pair can overlap (min_overlap > 0).
  std::vector<std::array<double, 4>> boxes(n);
  for (int i = 0; i < n; ++i) boxes[i] = ground_box(cameras[i], ground);
  std::vector<int> order(n);
  for (int i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return boxes[a][0] < boxes[b][0] || (boxes[a][0] == boxes[b][0] && a < b); });
  // Each camera's candidates: (the boxes' shared share, weighted as the score is, partner).
  std::vector<std::vector<std::pair<double, int>>> candidates(n);
  std::vector<int> active;
  const auto area = [](const std::array<double, 4>& b) { return (b[2] - b[0]) * (b[3] - b[1]); };
  for (const int i : order) {
    std::erase_if(active, [&](int j) { return boxes[j][2] < boxes[i][0]; });
    for (const int j : active) {
      const auto &bi = boxes[i], &bj = boxes[j];
      if (bj[1] > bi[3] || bi[1] > bj[3]) continue;
      ++counts.boxes_met;
      const double ratio = base_to_height(cameras[i], cameras[j], ground);
      if (!(ratio >= options.min_base_to_height && ratio <= options.max_base_to_height)) continue;
      const std::array<double, 4> both{std::max(bi[0], bj[0]), std::max(bi[1], bj[1]), std::min(bi[2], bj[2]),
                                       std::min(bi[3], bj[3])};
      const double largest = std::max(area(bi), area(bj));
      // An unbounded box (a camera that sees the horizon): ranked first, so cut exactly.
      const double share = std::isfinite(largest) ? area(both) / largest : 1.0;
      const double cheap = share * std::min(1.0, ratio / kPreferredBaseToHeight);
      candidates[i].emplace_back(cheap, j);
      candidates[j].emplace_back(cheap, i);
    }
    active.push_back(i);
  }

  // 2. Each camera's best candidates by that estimate have their footprints cut exactly (at most
  //    kCutPerPartner x max_partners a camera, each pair once); every pair cut counts for both.
  const auto better = [](const auto& a, const auto& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  };
  const size_t cut_each = static_cast<size_t>(kCutPerPartner) * options.max_partners;
  std::vector<std::pair<int, int>> to_cut;
  for (int i = 0; i < n; ++i) {
    auto& mine = candidates[i];
    const size_t kept = std::min(mine.size(), cut_each);
    std::partial_sort(mine.begin(), mine.begin() + static_cast<std::ptrdiff_t>(kept), mine.end(), better);
    for (size_t k = 0; k < kept; ++k) to_cut.emplace_back(std::min(i, mine[k].second), std::max(i, mine[k].second));
  }
  std::sort(to_cut.begin(), to_cut.end());
  to_cut.erase(std::unique(to_cut.begin(), to_cut.end()), to_cut.end());
  std::vector<std::vector<std::pair<double, int>>> partners(n);  // (score, camera)
  for (const auto& [i, j] : to_cut) {
    ++counts.footprints_cut;
    const double ratio = base_to_height(cameras[i], cameras[j], ground);
    const double overlap =
        std::min(footprint_overlap(cameras[i], cameras[j], ground), footprint_overlap(cameras[j], cameras[i], ground));
    if (!(overlap >= options.min_overlap)) continue;
    const double score = overlap * std::min(1.0, ratio / kPreferredBaseToHeight);
    partners[i].emplace_back(score, j);
    partners[j].emplace_back(score, i);
  }

  // 3. Each camera's max_partners best; a pair kept by either camera is kept.
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < n; ++i) {
    auto& mine = partners[i];
    const size_t kept = std::min(mine.size(), static_cast<size_t>(options.max_partners));
    // Best score first; the nearer index breaks ties, so the choice does not depend on order.
    std::partial_sort(mine.begin(), mine.begin() + static_cast<std::ptrdiff_t>(kept), mine.end(), better);
    for (size_t k = 0; k < kept; ++k) pairs.emplace_back(std::min(i, mine[k].second), std::max(i, mine[k].second));
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  if (stats) *stats = counts;
  return pairs;
}

void check_pair_baselines(const std::vector<FrameCamera>& cameras, const std::vector<std::pair<int, int>>& pairs,
                          double ground_height) {
  for (const auto& [a, b] : pairs) {
    const double ratio = base_to_height(cameras.at(a), cameras.at(b), ground_height);
    if (ratio >= kMinPairBaseToHeight) continue;
    const double height = cameras[a].center[2] - ground_height;
    throw ArgumentError("pairs", "cameras " + std::to_string(a) + " and " + std::to_string(b) + " stand " +
                                     short_number(ratio * height) + " m apart for " + short_number(height) +
                                     " m above the ground (B/H " + short_number(ratio) + ", less than " +
                                     short_number(kMinPairBaseToHeight) +
                                     "): no depth can be measured; pair cameras farther apart");
  }
}

std::vector<std::pair<int, int>> parse_pairs(const std::string& text, int cameras, const std::string& flag) {
  std::vector<std::pair<int, int>> pairs;
  std::stringstream stream(text);
  std::string token;
  while (std::getline(stream, token, ',')) {
    const std::size_t dash = token.find('-');
    int a = -1, b = -1;
    try {
      std::size_t used_a = 0, used_b = 0;
      if (dash == std::string::npos) throw std::invalid_argument("");
      a = std::stoi(token.substr(0, dash), &used_a);
      b = std::stoi(token.substr(dash + 1), &used_b);
      if (used_a != dash || used_b != token.size() - dash - 1) throw std::invalid_argument("");
    } catch (const std::exception&) {
      throw ArgumentError(flag, "must be auto or pairs like 0-1,1-2, got '" + token + "'");
    }
    if (a < 0 || b < 0 || a >= cameras || b >= cameras)
      throw ArgumentError(flag, "pair '" + token + "' names a camera outside 0.." + std::to_string(cameras - 1));
    if (a == b) throw ArgumentError(flag, "pair '" + token + "' matches a camera with itself");
    pairs.emplace_back(a, b);
  }
  if (pairs.empty()) throw ArgumentError(flag, "names no pair");
  return pairs;
}

}  // namespace dsmplan
