// Synthetic aerial views of a real DSM, shared by tests/stereo_pipeline_test.cpp, bench_stereo
// and the sample (aerial_sample, scripts/sample.sh): the DSM's cells as solid columns on an
// endless floor, ray cast (a 2D DDA over the cells, J. Amanatides and A. Woo, "A Fast Voxel
// Traversal Algorithm for Ray Tracing", Eurographics 1987) from frame cameras
// (dsmplan/stereo_frames.hpp), with a texture that varies in x, y and z (two octaves of
// value noise, K. Perlin, "An Image Synthesizer", SIGGRAPH 1985, on a hashed lattice), 2 x 2 rays
// a pixel, plus Gaussian noise; optionally a low sun whose cast shadows are found by marching the
// same DDA from each surface point towards it, and a gain and offset per view (ViewLook). And the oracle of a DSM made
// from such views: completeness and |error| quantiles against the DSM they were rendered from.
//
// Deterministic: a pixel's value depends on the scene, the camera, the seed and the pixel only
// (the noise is hashed from them), not on the number of threads.
#pragma once

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>
#include <vector>

#include "dsmplan/raster.hpp"
#include "dsmplan/stereo_frames.hpp"

namespace aerial {

using dsmplan::FrameCamera;
using dsmplan::GreyImage;
using dsmplan::Grid;
using dsmplan::Mat3;
using dsmplan::Vec3;

inline Mat3 multiply(const Mat3& a, const Mat3& b) {
  Mat3 c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}

inline Mat3 rotation_xyz(double ax, double ay, double az) {  // R = Rz Ry Rx, radians
  const double cx = std::cos(ax), sx = std::sin(ax), cy = std::cos(ay), sy = std::sin(ay), cz = std::cos(az),
               sz = std::sin(az);
  const Mat3 Rx{{{1, 0, 0}, {0, cx, -sx}, {0, sx, cx}}}, Ry{{{cy, 0, sy}, {0, 1, 0}, {-sy, 0, cy}}},
      Rz{{{cz, -sz, 0}, {sz, cz, 0}, {0, 0, 1}}};
  return multiply(Rz, multiply(Ry, Rx));
}

/// A nadir camera (x east, y south, z down) at `center`, turned by small angles (radians) about
/// its x and y axes, with radial k1 (k2 = 0.3 k1) and tangential p1 (p2 = -0.5 p1) distortion.
inline FrameCamera nadir_camera(int size, double f, const Vec3& center, double tilt_x = 0, double tilt_y = 0,
                                double k1 = 0, double p1 = 0) {
  FrameCamera c;
  c.width = c.height = size;
  c.fx = c.fy = f;
  c.cx = c.cy = (size - 1) / 2.0;
  const Mat3 nadir{{{1, 0, 0}, {0, -1, 0}, {0, 0, -1}}};
  c.rotation = multiply(rotation_xyz(tilt_x, tilt_y, 0), nadir);
  c.center = center;
  c.distortion = {k1, 0.3 * k1, p1, -0.5 * p1, 0};
  return c;
}

inline std::uint64_t mix(std::int64_t x, std::int64_t y, std::int64_t z) {
  std::uint64_t h = static_cast<std::uint64_t>(x) * 0x9E3779B97F4A7C15ull ^
                    static_cast<std::uint64_t>(y) * 0xC2B2AE3D27D4EB4Full ^
                    static_cast<std::uint64_t>(z) * 0x165667B19E3779F9ull;
  h ^= h >> 29;
  h *= 0xBF58476D1CE4E5B9ull;
  h ^= h >> 32;
  return h;
}
inline double hash01(std::int64_t x, std::int64_t y, std::int64_t z) {
  return static_cast<double>(mix(x, y, z) & 0xFFFFFF) / 0xFFFFFF;
}

/// Value noise in 3D: a hash per lattice point (spacing `cell` metres), trilinear in between; 0..1.
inline double value_noise(double x, double y, double z, double cell) {
  const double fx = x / cell, fy = y / cell, fz = z / cell;
  const double ix = std::floor(fx), iy = std::floor(fy), iz = std::floor(fz);
  const double tx = fx - ix, ty = fy - iy, tz = fz - iz;
  double sum = 0;
  for (int dx = 0; dx < 2; ++dx)
    for (int dy = 0; dy < 2; ++dy)
      for (int dz = 0; dz < 2; ++dz)
        sum += (dx ? tx : 1 - tx) * (dy ? ty : 1 - ty) * (dz ? tz : 1 - tz) *
               hash01(static_cast<std::int64_t>(ix) + dx, static_cast<std::int64_t>(iy) + dy,
                      static_cast<std::int64_t>(iz) + dz);
  return sum;
}

/// The surface's grey value at world point p: 30..230, two octaves (0.45 m and 2.1 m).
inline double texture(const Vec3& p) {
  return 30 + 140 * value_noise(p[0], p[1], p[2], 0.45) + 60 * value_noise(p[0], p[1], p[2], 2.1);
}

/// The scene: the cells of `dsm` as solid columns on an endless floor at `floor` height; `top`
/// at or above the highest cell.
struct ColumnScene {
  const Grid& dsm;
  double floor;
  double top;
  double height_at(int col, int row) const {
    if (col < 0 || row < 0 || col >= dsm.width || row >= dsm.height) return floor;
    const float z = dsm.at(col, row);
    return std::isnan(z) ? floor : std::max<double>(floor, z);
  }
  /// The first surface point along C + t·dir (dir pointing down), by a 2D DDA over the cells.
  Vec3 hit(const Vec3& C, const Vec3& dir) const {
    const double t_floor = (floor - C[2]) / dir[2];
    double t = std::max(0.0, (top - C[2]) / dir[2]);
    // Cell coordinates: gx = (x - x0)/cell_x, gy = (y0 - y)/cell_y.
    const double gx = (C[0] + t * dir[0] - dsm.x0) / dsm.cell_x, gy = (dsm.y0 - (C[1] + t * dir[1])) / dsm.cell_y;
    const double vx = dir[0] / dsm.cell_x, vy = -dir[1] / dsm.cell_y;
    int col = static_cast<int>(std::floor(gx)), row = static_cast<int>(std::floor(gy));
    const int step_x = vx > 0 ? 1 : -1, step_y = vy > 0 ? 1 : -1;
    double next_x = std::abs(vx) < 1e-15 ? INFINITY : ((vx > 0 ? col + 1 - gx : gx - col) / std::abs(vx)) + t;
    double next_y = std::abs(vy) < 1e-15 ? INFINITY : ((vy > 0 ? row + 1 - gy : gy - row) / std::abs(vy)) + t;
    const double dt_x = std::abs(vx) < 1e-15 ? INFINITY : 1 / std::abs(vx);
    const double dt_y = std::abs(vy) < 1e-15 ? INFINITY : 1 / std::abs(vy);
    for (int guard = 0; guard < 100000; ++guard) {
      const double h = height_at(col, row);
      const double t_out = std::min({next_x, next_y, t_floor});
      const double z_in = C[2] + t * dir[2];
      if (z_in <= h) return {C[0] + t * dir[0], C[1] + t * dir[1], z_in};  // a wall
      const double t_top = (h - C[2]) / dir[2];
      if (t_top <= t_out) return {C[0] + t_top * dir[0], C[1] + t_top * dir[1], h};
      t = t_out;
      if (next_x < next_y) {
        col += step_x;
        next_x += dt_x;
      } else {
        row += step_y;
        next_y += dt_y;
      }
    }
    return {C[0] + t_floor * dir[0], C[1] + t_floor * dir[1], floor};
  }
};

/// A low sun over the scene: whether the surface point p (a hit() of this scene) lies in a
/// column's cast shadow, marching from p towards the sun (unit vector `to_sun`, z > 0) over the
/// cells by the same DDA as hit() until the ray rises above `top`. A wall facing away from the
/// sun is in its own column's shadow (the first step, 1 mm towards the sun, enters the column).
struct Sun {
  Vec3 to_sun{0, 0, 1};
  /// The sun at `elevation` degrees over the horizon, from `azimuth` degrees (clockwise from north).
  static Sun at(double elevation_deg, double azimuth_deg) {
    const double e = elevation_deg * std::numbers::pi / 180, a = azimuth_deg * std::numbers::pi / 180;
    return {{std::cos(e) * std::sin(a), std::cos(e) * std::cos(a), std::sin(e)}};
  }
};

inline bool in_shadow(const ColumnScene& scene, const Vec3& p, const Sun& sun) {
  const Vec3& d = sun.to_sun;
  const Grid& dsm = scene.dsm;
  const Vec3 s{p[0] + 1e-3 * d[0], p[1] + 1e-3 * d[1], p[2] + 1e-3 * d[2]};
  const double gx = (s[0] - dsm.x0) / dsm.cell_x, gy = (dsm.y0 - s[1]) / dsm.cell_y;
  const double vx = d[0] / dsm.cell_x, vy = -d[1] / dsm.cell_y;
  int col = static_cast<int>(std::floor(gx)), row = static_cast<int>(std::floor(gy));
  const int step_x = vx > 0 ? 1 : -1, step_y = vy > 0 ? 1 : -1;
  double next_x = std::abs(vx) < 1e-15 ? INFINITY : (vx > 0 ? col + 1 - gx : gx - col) / std::abs(vx);
  double next_y = std::abs(vy) < 1e-15 ? INFINITY : (vy > 0 ? row + 1 - gy : gy - row) / std::abs(vy);
  const double dt_x = std::abs(vx) < 1e-15 ? INFINITY : 1 / std::abs(vx);
  const double dt_y = std::abs(vy) < 1e-15 ? INFINITY : 1 / std::abs(vy);
  double t = 0;
  for (int guard = 0; guard < 100000; ++guard) {
    const double z = s[2] + t * d[2];  // the ray rises: its lowest point in a cell is where it enters
    if (z >= scene.top) return false;
    if (z < scene.height_at(col, row)) return true;
    if (next_x < next_y) {
      t = next_x, col += step_x, next_x += dt_x;
    } else {
      t = next_y, row += step_y, next_y += dt_y;
    }
  }
  return false;
}

/// How one view sees the scene besides its geometry: the camera's response (grey = gain · surface
/// + offset, then noise, rounded and clipped to 0..255, so a bright gain saturates) and the light
/// (without `sun` the surface is lit evenly; with it, points in cast shadow keep `shade` of their
/// brightness, the sky's light).
struct ViewLook {
  double gain = 1, offset = 0;
  double noise = 1.5;  ///< Gaussian, grey levels
  const Sun* sun = nullptr;
  double shade = 0.3;
};

/// A standard normal number hashed from (seed, u, v) (Box–Muller of two hashed uniforms).
inline double hashed_gauss(unsigned seed, int u, int v) {
  const double a = (static_cast<double>(mix(u, v, 2 * std::int64_t{seed}) >> 11) + 0.5) / 9007199254740992.0;
  const double b = (static_cast<double>(mix(u, v, 2 * std::int64_t{seed} + 1) >> 11) + 0.5) / 9007199254740992.0;
  return std::sqrt(-2 * std::log(a)) * std::cos(6.283185307179586 * b);
}

/// The camera's 8-bit image of the scene (values 0..255 as floats): 2 x 2 rays per pixel, each
/// ray's surface texture (dimmed where the look's sun casts a shadow) averaged, then the look's
/// gain and offset and its Gaussian noise, rounded. Rows in parallel (TBB).
inline GreyImage render(const ColumnScene& scene, const FrameCamera& camera, unsigned seed, const ViewLook& look) {
  GreyImage image;
  image.width = camera.width;
  image.height = camera.height;
  image.pixels.resize(static_cast<size_t>(camera.width) * camera.height);
  tbb::parallel_for(tbb::blocked_range<int>(0, camera.height), [&](const tbb::blocked_range<int>& rows) {
    for (int v = rows.begin(); v < rows.end(); ++v)
      for (int u = 0; u < camera.width; ++u) {
        double sum = 0;
        for (double du : {-0.25, 0.25})
          for (double dv : {-0.25, 0.25}) {
            const Vec3 p = scene.hit(camera.center, dsmplan::pixel_ray(camera, u + du, v + dv));
            sum += look.sun && in_shadow(scene, p, *look.sun) ? look.shade * texture(p) : texture(p);
          }
        const double grey = look.gain == 1 && look.offset == 0 ? sum / 4 : look.gain * (sum / 4) + look.offset;
        image.pixels[static_cast<size_t>(v) * camera.width + u] =
            static_cast<float>(std::clamp(std::round(grey + look.noise * hashed_gauss(seed, u, v)), 0.0, 255.0));
      }
  });
  return image;
}

/// The evenly lit view with `noise` grey levels of noise (gain 1, no offset).
inline GreyImage render(const ColumnScene& scene, const FrameCamera& camera, unsigned seed, double noise = 1.5) {
  ViewLook look;
  look.noise = noise;
  return render(scene, camera, seed, look);
}

/// Completeness and |error| quantiles of a DSM against the truth.
struct DsmErrors {
  double completeness = 0;      ///< share of the truth's cells the DSM has a height for
  double median = 0;            ///< median |DSM - truth| over those cells
  double over1 = 0, over3 = 0;  ///< share of those cells off by more than 1 m, 3 m
  /// Share of those cells more than 3 m below the truth, and the most below (m, >= 0): an
  /// obstacle shown lower than it is, what a planner on the DSM must not be given.
  double low3 = 0, lowest = 0;
};

/// `dsm` against `truth` at the truth's cell centres (the DSM's cell holding each centre; cells
/// outside the DSM count as not filled).
inline DsmErrors dsm_errors(const Grid& dsm, const Grid& truth) {
  std::vector<double> errors;
  std::size_t cells = 0, low3 = 0;
  double lowest = 0;
  for (int r = 0; r < truth.height; ++r)
    for (int c = 0; c < truth.width; ++c) {
      if (!truth.valid(c, r)) continue;
      ++cells;
      int cd, rd;
      if (dsm.cell_at(truth.center_x(c), truth.center_y(r), cd, rd) && dsm.valid(cd, rd)) {
        const double below = truth.at(c, r) - dsm.at(cd, rd);
        errors.push_back(std::abs(below));
        low3 += below > 3;
        lowest = std::max(lowest, below);
      }
    }
  DsmErrors e;
  if (errors.empty()) return e;
  e.low3 = low3 / static_cast<double>(errors.size());
  e.lowest = lowest;
  std::sort(errors.begin(), errors.end());
  const double count = static_cast<double>(errors.size());
  e.completeness = count / cells;
  e.median = errors[errors.size() / 2];
  e.over1 = (errors.end() - std::upper_bound(errors.begin(), errors.end(), 1.0)) / count;
  e.over3 = (errors.end() - std::upper_bound(errors.begin(), errors.end(), 3.0)) / count;
  return e;
}

/// The truth of a rendered scene: `n` x `n` cells of `dsm` centred on its cell (col, row).
inline Grid crop(const Grid& dsm, int col0, int row0, int n) {
  Grid out(n, n, dsm.x0 + col0 * dsm.cell_x, dsm.y0 - row0 * dsm.cell_y, dsm.cell_x, dsm.cell_y);
  out.crs = dsm.crs;
  for (int r = 0; r < n; ++r)
    for (int c = 0; c < n; ++c) out.z[out.index(c, r)] = dsm.at(col0 + c, row0 + r);
  return out;
}

/// A camera as its entry in CAMERAS.json (the contract in docs/stereo.md), reading `image`.
inline nlohmann::json camera_json(const dsmplan::FrameCamera& c, const std::string& image) {
  nlohmann::json rotation = nlohmann::json::array();
  for (const auto& row : c.rotation) rotation.push_back({row[0], row[1], row[2]});
  return {{"image", image},       {"width", c.width},  {"height", c.height}, {"fx", c.fx},
          {"fy", c.fy},           {"cx", c.cx},        {"cy", c.cy},         {"distortion", c.distortion},
          {"rotation", rotation}, {"center", c.center}};
}

}  // namespace aerial
