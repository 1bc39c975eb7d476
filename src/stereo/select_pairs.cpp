// Pair selection: which images to match. The seed paper (Adolf & Hirschmüller, Section 2)
// matches "all overlapping images in flight-direction as well as perpendicular to it"; `auto`
// takes every pair whose footprints overlap enough and whose base-to-height ratio B/H makes a
// useful intersection angle (too small: depth noise grows as H/B; too large: occlusions and
// perspective distortion defeat the matching; aerial photogrammetry works with B/H of about
// 0.1 (dense multi-view blocks) to 1).
#include <algorithm>
#include <cmath>
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

std::vector<std::pair<int, int>> select_pairs_auto(const std::vector<FrameCamera>& cameras,
                                                   const PairSelectionOptions& options) {
  if (options.max_partners < 1) throw ArgumentError("max_partners", "must be at least 1");
  // Below this B/H a pair's depth noise (as H/B) outweighs its overlap: such partners rank lower.
  constexpr double kPreferredBaseToHeight = 0.3;
  const int n = static_cast<int>(cameras.size());
  std::vector<std::vector<std::pair<double, int>>> partners(n);  // (score, camera)
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j) {
      const double ratio = base_to_height(cameras[i], cameras[j], options.ground_height);
      if (!(ratio >= options.min_base_to_height && ratio <= options.max_base_to_height)) continue;
      const double overlap = std::min(footprint_overlap(cameras[i], cameras[j], options.ground_height),
                                      footprint_overlap(cameras[j], cameras[i], options.ground_height));
      if (!(overlap >= options.min_overlap)) continue;
      const double score = overlap * std::min(1.0, ratio / kPreferredBaseToHeight);
      partners[i].emplace_back(score, j);
      partners[j].emplace_back(score, i);
    }
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < n; ++i) {
    auto& mine = partners[i];
    const size_t kept = std::min(mine.size(), static_cast<size_t>(options.max_partners));
    // Best score first; the nearer index breaks ties, so the choice does not depend on order.
    std::partial_sort(
        mine.begin(), mine.begin() + static_cast<std::ptrdiff_t>(kept), mine.end(),
        [](const auto& a, const auto& b) { return a.first > b.first || (a.first == b.first && a.second < b.second); });
    for (size_t k = 0; k < kept; ++k) pairs.emplace_back(std::min(i, mine[k].second), std::max(i, mine[k].second));
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
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
