// No-fly zones (dsmplan/airspace.hpp, dsmplan/airspace_io.hpp): the reader against GDAL's own
// transformer and PROJ's geodesic inverse on the hand-made zone files of tests/data/airspace,
// the constraint against brute-force sampling every 5 cm, and the planner on the NRW crop.
#include "dsmplan/airspace.hpp"

#include <geodesic.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>

#include <cmath>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <random>

#include "dsmplan/airspace_io.hpp"
#include "dsmplan/mesh.hpp"
#include "dsmplan/plan.hpp"
#include "dsmplan/raster.hpp"
#include "dsmplan/raster_io.hpp"
#include "testkit.hpp"

using namespace dsmplan;
using Json = nlohmann::json;
using Xy = std::array<double, 2>;

namespace {

std::string zones_file(const std::string& name) { return std::string(DSMPLAN_TESTS_DIR) + "/data/airspace/" + name; }

Crs crs_of(const char* epsg) {
  Crs crs;
  crs.definition = epsg;
  resolve_crs(crs);
  return crs;
}

VerticalOptions egm96() {
  VerticalOptions v;
  v.vertical_crs = "EPSG:5773";  // the DSM's heights taken as EGM96: an exact operation PROJ has the grid of
  return v;
}

// GDAL's transformer from `from` to `to` (traditional GIS order: longitude first).
std::unique_ptr<OGRCoordinateTransformation> gdal_transform(const char* from, const char* to) {
  OGRSpatialReference a, b;
  a.SetFromUserInput(from);
  b.SetFromUserInput(to);
  a.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  b.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return std::unique_ptr<OGRCoordinateTransformation>(OGRCreateCoordinateTransformation(&a, &b));
}

// ---- oracles, written without the library's code ------------------------------------------

double segment_distance(const Xy& p, const Xy& a, const Xy& b) {
  const double dx = b[0] - a[0], dy = b[1] - a[1], l = dx * dx + dy * dy;
  const double t = l > 0 ? std::clamp(((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / l, 0.0, 1.0) : 0;
  return std::hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy);
}

// Horizontal distance from p to the area (0 inside): winding parity over all rings.
double area_distance(const std::vector<std::vector<Xy>>& rings, const Xy& p) {
  bool odd = false;
  double best = INFINITY;
  for (const auto& r : rings)
    for (size_t i = 0; i < r.size(); ++i) {
      const Xy &a = r[i], &b = r[(i + 1) % r.size()];
      best = std::min(best, segment_distance(p, a, b));
      if ((a[1] <= p[1] && b[1] > p[1]) || (b[1] <= p[1] && a[1] > p[1]))
        if (p[0] < a[0] + (p[1] - a[1]) / (b[1] - a[1]) * (b[0] - a[0])) odd = !odd;
    }
  return odd ? 0 : best;
}

Point3 lerp(const Point3& a, const Point3& b, double t) {
  return {a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]), a[2] + t * (b[2] - a[2])};
}

// Samples every 5 cm (both ends included).
template <class F>
void each_sample(const Point3& p, const Point3& q, F&& f) {
  const double len = std::hypot(q[0] - p[0], q[1] - p[1], q[2] - p[2]);
  const int n = std::max(1, static_cast<int>(std::ceil(len / 0.05)));
  for (int k = 0; k <= n; ++k) f(lerp(p, q, double(k) / n));
}

std::vector<std::vector<Xy>> open_rings(const AirspaceZone& zone) {
  std::vector<std::vector<Xy>> out;
  for (auto r : zone.rings) {
    if (r.front() == r.back()) r.pop_back();
    out.push_back(r);
  }
  return out;
}

const Grid& nrw_crop() { return testkit::nrw_crop(); }

}  // namespace

// ---- the reader --------------------------------------------------------------------------

TEST(AirspaceReader, Ed269OverNrwAgreesWithGdalAndGeodesics) {
  const std::string path = zones_file("nrw_zones_ed269.json");
  const std::vector<AirspaceZone> zones = read_airspace(path, crs_of("EPSG:25832"), egm96());
  std::ifstream in(path);
  const Json doc = Json::parse(in);
  ASSERT_EQ(zones.size(), doc["features"].size());
  const auto to_utm = gdal_transform("EPSG:4326", "EPSG:25832");
  const auto to_lonlat = gdal_transform("EPSG:25832", "EPSG:4326");
  geod_geodesic wgs84;
  geod_init(&wgs84, 6378137, 1 / 298.257223563);
  for (size_t k = 0; k < zones.size(); ++k) {
    const Json& f = doc["features"][k];
    const AirspaceZone& z = zones[k];
    EXPECT_EQ(z.id, f["identifier"].get<std::string>());
    EXPECT_EQ(z.name, f["name"].get<std::string>());
    EXPECT_EQ(z.restriction, f["restriction"].get<std::string>());
    EXPECT_EQ(z.source_file, path);
    const Json& h = f["geometry"][0]["horizontalProjection"];
    if (h["type"] == "Polygon") {
      ASSERT_EQ(z.rings.size(), h["coordinates"].size());
      for (size_t r = 0; r < z.rings.size(); ++r) {
        const Json& ring = h["coordinates"][r];
        ASSERT_EQ(z.rings[r].size(), ring.size() - 1);  // the closing corner left out
        for (size_t c = 0; c < z.rings[r].size(); ++c) {
          double x = ring[c][0], y = ring[c][1];
          ASSERT_TRUE(to_utm->Transform(1, &x, &y));
          EXPECT_NEAR(z.rings[r][c][0], x, 1e-3);
          EXPECT_NEAR(z.rings[r][c][1], y, 1e-3);
        }
      }
    } else {  // the circle: every point of its polygon's edges at least the radius from the centre
      const double lon0 = h["center"][0], lat0 = h["center"][1], radius = h["radius"];
      ASSERT_EQ(z.rings.size(), 1u);
      const auto& ring = z.rings[0];
      EXPECT_GE(ring.size(), 32u);
      double nearest = INFINITY, farthest = 0;
      for (size_t c = 0; c < ring.size(); ++c) {
        const Xy &a = ring[c], &b = ring[(c + 1) % ring.size()];
        for (double t : {0.0, 0.25, 0.5, 0.75}) {
          double x = a[0] + t * (b[0] - a[0]), y = a[1] + t * (b[1] - a[1]), s12 = 0;
          ASSERT_TRUE(to_lonlat->Transform(1, &x, &y));
          geod_inverse(&wgs84, lat0, lon0, y, x, &s12, nullptr, nullptr);
          nearest = std::min(nearest, s12);
          if (t == 0) farthest = std::max(farthest, s12);
        }
      }
      EXPECT_GE(nearest, radius);
      EXPECT_LE(farthest, radius + 0.06);  // corners at most 5 cm beyond (+ rounding)
      EXPECT_LE(nearest, radius + 0.01);   // and the edges touch it
    }
  }
  // The limits: AGL as given, feet converted, AMSL (EGM96) into EGM96 heights: the same numbers.
  EXPECT_EQ(zones[0].lower.reference, ZoneLimit::Reference::unlimited);
  EXPECT_EQ(zones[0].upper.reference, ZoneLimit::Reference::above_ground);
  EXPECT_EQ(zones[0].upper.height, 60);
  EXPECT_EQ(zones[2].lower.reference, ZoneLimit::Reference::above_ground);
  EXPECT_EQ(zones[2].lower.height, 90);
  EXPECT_EQ(zones[3].lower.reference, ZoneLimit::Reference::crs);
  EXPECT_NEAR(zones[3].lower.height, 240, 1e-6);
  EXPECT_NEAR(zones[3].upper.height, 270, 1e-6);
  EXPECT_NEAR(zones[4].upper.height, 400 * 0.3048, 1e-9);  // 121.92 m
  EXPECT_EQ(zones[4].upper.reference, ZoneLimit::Reference::above_ground);
  // Blocking by default: PROHIBITED and REQ_AUTHORISATION, not NO_RESTRICTION.
  EXPECT_TRUE(zone_blocks(zones[2]));
  EXPECT_FALSE(zone_blocks(zones[5]));
  AirspaceOptions all;
  all.blocking.push_back("NO_RESTRICTION");
  EXPECT_TRUE(zone_blocks(zones[5], all));
}

TEST(AirspaceReader, AmslLimitsNeedTheDsmsVerticalReferenceAndNameTheZone) {
  const std::string path = zones_file("nrw_zones_ed269.json");
  try {
    read_airspace(path, crs_of("EPSG:25832"), {});
    ADD_FAILURE() << "an AMSL limit converted with no vertical reference";
  } catch (const InputError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find(path), std::string::npos) << m;
    EXPECT_NE(m.find("feature 4 'East band'"), std::string::npos) << m;
    EXPECT_NE(m.find("AMSL"), std::string::npos) << m;
    EXPECT_EQ(m.find('\n'), std::string::npos) << m;
  }
}

TEST(AirspaceReader, GeoJsonOverDelftAgreesWithGdal) {
  const std::string path = zones_file("delft_zones.geojson");
  const std::vector<AirspaceZone> zones = read_airspace(path, crs_of("EPSG:28992"), egm96());
  ASSERT_EQ(zones.size(), 5u);  // the MultiPolygon gives two
  std::ifstream in(path);
  const Json doc = Json::parse(in);
  const auto to_rd = gdal_transform("EPSG:4326", "EPSG:28992");
  // Each polygon's corners, in file order (the MultiPolygon's two polygons are zones 1 and 2).
  std::vector<const Json*> polygons;
  for (const Json& f : doc["features"]) {
    if (f["geometry"]["type"] == "Polygon")
      polygons.push_back(&f["geometry"]["coordinates"]);
    else
      for (const Json& p : f["geometry"]["coordinates"]) polygons.push_back(&p);
  }
  ASSERT_EQ(polygons.size(), zones.size());
  for (size_t k = 0; k < zones.size(); ++k)
    for (size_t c = 0; c + 1 < (*polygons[k])[0].size(); ++c) {
      double x = (*polygons[k])[0][c][0], y = (*polygons[k])[0][c][1];
      ASSERT_TRUE(to_rd->Transform(1, &x, &y));
      EXPECT_NEAR(zones[k].rings[0][c][0], x, 1e-3);
      EXPECT_NEAR(zones[k].rings[0][c][1], y, 1e-3);
    }
  // No limits: from below the ground to no top; restriction PROHIBITED when none is given.
  EXPECT_EQ(zones[0].lower.reference, ZoneLimit::Reference::unlimited);
  EXPECT_EQ(zones[0].upper.reference, ZoneLimit::Reference::unlimited);
  EXPECT_EQ(zones[0].restriction, "PROHIBITED");
  EXPECT_EQ(zones[0].id, "DLF-1");
  EXPECT_EQ(zones[1].id, "DLF-2");
  EXPECT_EQ(zones[2].id, "DLF-2");
  EXPECT_EQ(zones[2].upper.reference, ZoneLimit::Reference::above_ground);
  EXPECT_EQ(zones[2].upper.height, 30);
  EXPECT_EQ(zones[4].restriction, "CONDITIONAL");
  // WGS84 heights in feet (200 and 400 ft above the ellipsoid) into EGM96 heights: GDAL's compound
  // transformation at every corner; the lower limit the least, the upper the greatest.
  const auto to_msl = gdal_transform("EPSG:4979", "EPSG:28992+5773");
  ASSERT_TRUE(to_msl);
  double low = INFINITY, high = -INFINITY;
  const Json& mast = doc["features"][2]["geometry"]["coordinates"][0];
  for (size_t c = 0; c + 1 < mast.size(); ++c)
    for (double h : {200 * 0.3048, 400 * 0.3048}) {
      double x = mast[c][0], y = mast[c][1], z = h;
      ASSERT_TRUE(to_msl->Transform(1, &x, &y, &z));
      (h < 100 ? low : high) = h < 100 ? std::min(low, z) : std::max(high, z);
    }
  EXPECT_EQ(zones[3].lower.reference, ZoneLimit::Reference::crs);
  EXPECT_NEAR(zones[3].lower.height, low, 1e-3);
  EXPECT_NEAR(zones[3].upper.height, high, 1e-3);
  EXPECT_GT(60.96 - low, 35);  // the geoid stands about 43 m above the ellipsoid at Delft
  EXPECT_LT(60.96 - low, 50);
}

TEST(AirspaceReader, BadInputIsOneLineNamingTheFileThePlaceAndTheProblem) {
  const testkit::TempDir dir;
  const std::string square = "[[[4.36,52.01],[4.361,52.01],[4.361,52.011],[4.36,52.01]]]";
  auto ed269 = [&](const std::string& geometry, const std::string& restriction = "PROHIBITED") {
    return R"({"features":[{"identifier":"A","name":"Okay","restriction":"PROHIBITED","geometry":[{"uomDimensions":"M",
      "horizontalProjection":{"type":"Polygon","coordinates":)" +
           square + R"(}}]},
      {"identifier":"P7","name":"Prison X","restriction":")" +
           restriction + R"(","geometry":[)" + geometry + "]}]}";
  };
  const std::string poly = R"("horizontalProjection":{"type":"Polygon","coordinates":)" + square + "}";
  const std::vector<std::tuple<std::string, std::string, std::string>> cases = {
      {ed269(R"({"uomDimensions":"KM",)" + poly + "}"), "feature 2 'Prison X'", "unknown unit"},
      {ed269(R"({"uomDimensions":"M","horizontalProjection":{"type":"Polygon"}})"), "feature 2 'Prison X'",
       "without 'coordinates'"},
      {ed269(
           R"({"uomDimensions":"M","horizontalProjection":{"type":"Polygon","coordinates":[[[4.36,52.01],[4.37,52.01],[4.36,52.01]]]}})"),
       "feature 2 'Prison X', ring 1", "at least 3"},
      {ed269(R"({"uomDimensions":"M","lowerLimit":50,"lowerVerticalReference":"AGL","upperLimit":20,
         "upperVerticalReference":"AGL",)" +
             poly + "}"),
       "feature 2 'Prison X'", "lower limit lies above"},
      {ed269(R"({"uomDimensions":"M","horizontalProjection":{"type":"Circle","center":[4.36,52.01]}})"),
       "feature 2 'Prison X'", "without a 'radius'"},
      {ed269(R"({"uomDimensions":"M","lowerLimit":0,"lowerVerticalReference":"QNH",)" + poly + "}"),
       "feature 2 'Prison X'", "AGL, AMSL or WGS84"},
      {ed269(R"({"uomDimensions":"M",)" + poly + "}", "MAYBE"), "feature 2 'Prison X'",
       "PROHIBITED, REQ_AUTHORISATION"},
      {ed269(
           R"({"uomDimensions":"M","horizontalProjection":{"type":"Polygon","coordinates":[[[400,52],[4.37,52.01],[4.36,52.02]]]}})"),
       "feature 2 'Prison X', ring 1", "longitude, latitude"},
      {R"({"type":"FeatureCollection","features":[{"type":"Feature","properties":{"name":"Mast"},
         "geometry":{"type":"Point","coordinates":[4.36,52.01]}}]})",
       "feature 1 'Mast'", "Polygon or MultiPolygon"},
      {R"({"type":"FeatureCollection","features":[{"type":"Feature","properties":{"lower":10},
         "geometry":{"type":"Polygon","coordinates":)" +
           square + "}}]}",
       "feature 1", "'lower_ref' must be"},
      {R"({"features": [)", "byte", "not JSON"},
      {R"({"zones": []})", "", "no 'features' array"},
  };
  for (size_t k = 0; k < cases.size(); ++k) {
    const auto& [text, place, phrase] = cases[k];
    const std::string path = dir.path("bad" + std::to_string(k) + ".json");
    testkit::write_file(path, text);
    try {
      read_airspace(path, crs_of("EPSG:28992"), egm96());
      ADD_FAILURE() << "case " << k << " accepted";
    } catch (const InputError& e) {
      const std::string m = e.what();
      EXPECT_EQ(m.rfind(path + ": " + place, 0), 0u) << "case " << k << ": " << m;
      EXPECT_NE(m.find(phrase), std::string::npos) << "case " << k << ": " << m;
      EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
  }
}

// ---- the constraint ------------------------------------------------------------------------

TEST(AirspaceConstraint, NeverPassesAMotionThatComesWithinSafetyOfAZoneWithAHole) {
  // A concave outer ring (clockwise) with a hole (counter-clockwise), between 20 and 50 m.
  AirspaceZone zone;
  zone.name = "ring";
  zone.rings = {{{0, 0}, {0, 60}, {30, 40}, {60, 60}, {60, 0}}, {{20, 10}, {40, 10}, {40, 25}, {20, 25}}};
  zone.lower = ZoneLimit::crs_height(20);
  zone.upper = ZoneLimit::crs_height(50);
  const double safety = 2;
  const AirspaceConstraint kept(zone, safety, nullptr);
  const auto rings = open_rings(zone);
  auto dz = [&](double z) { return std::max({0.0, 20 - z, z - 50}); };
  std::mt19937_64 rng(35);
  std::uniform_real_distribution<double> x(-10, 70), y(-10, 70), z(10, 60), step(-15, 15);
  int near = 0, refused = 0, disagreements = 0;
  const int n = 3000;
  for (int i = 0; i < n; ++i) {
    const Point3 p{x(rng), y(rng), z(rng)}, q{p[0] + step(rng), p[1] + step(rng), p[2] + step(rng) / 3};
    double euclid = INFINITY, box = INFINITY;  // least over the samples: 3D, and max(horizontal, vertical)
    each_sample(p, q, [&](const Point3& s) {
      const double h = area_distance(rings, {s[0], s[1]}), v = dz(s[2]);
      euclid = std::min(euclid, std::hypot(h, v));
      box = std::min(box, std::max(h, v));
    });
    const bool valid = kept.motion_valid(p, q);
    if (euclid <= safety) {
      EXPECT_FALSE(valid) << i;  // never optimistic
    }
    // The constraint refuses exactly what comes within safety horizontally and vertically at
    // once: a motion whose samples all stay 5 cm farther (a step of 5 cm moves 2.5 cm) passes.
    if (box > safety + 0.05) {
      EXPECT_TRUE(valid) << i;
    }
    if (euclid <= safety) ++near;
    refused += !valid;
    disagreements += valid != (box > safety);
    EXPECT_EQ(kept.state_valid(p), std::max(area_distance(rings, {p[0], p[1]}), dz(p[2])) > safety + 1e-5) << i;
  }
  EXPECT_GT(near, n / 5);  // the oracle had work to do
  EXPECT_GT(n - refused, n / 5);
  EXPECT_LE(disagreements, n / 100);
}

TEST(AirspaceConstraint, AglLimitsOverTheRealDsmAreNeverOptimistic) {
  // A zone 25 to 60 m above the DSM of the NRW crop (1 m cells): roofs and streets step under it.
  const auto ground = std::make_shared<const GroundGrid>(nrw_crop());
  const double cx = 356550, cy = 5699500;
  AirspaceZone zone;
  zone.id = "agl";
  zone.rings = {{{cx - 60, cy - 50}, {cx + 70, cy - 40}, {cx + 50, cy + 60}, {cx - 40, cy + 40}}};
  zone.lower = ZoneLimit::agl(25);
  zone.upper = ZoneLimit::agl(60);
  const double safety = 2;
  const AirspaceConstraint kept(zone, safety, ground);
  const auto rings = open_rings(zone);
  const Grid& g = nrw_crop();
  auto ground_at = [&](double x, double y) {
    const int c = static_cast<int>(std::floor((x - g.x0) / g.cell_x)),
              r = static_cast<int>(std::floor((g.y0 - y) / g.cell_y));
    return double(g.z[static_cast<size_t>(r) * g.width + c]);
  };
  // A point is near the zone when a point of the zone lies within safety of it: tried at the
  // point's own x, y and 16 around it at safety/2 and safety, at the nearest allowed height.
  auto near_zone = [&](const Point3& p) {
    for (double radius : {0.0, safety / 2, safety * 0.999})
      for (int k = 0; k < (radius == 0 ? 1 : 8); ++k) {
        const double a = k * M_PI / 4, x = p[0] + radius * std::cos(a), y = p[1] + radius * std::sin(a);
        if (area_distance(rings, {x, y}) > 0) continue;
        const double base = ground_at(x, y), z = std::clamp(p[2], base + 25, base + 60);
        if (std::hypot(radius, z - p[2]) <= safety) return true;
      }
    return false;
  };
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> x(cx - 80, cx + 90), y(cy - 70, cy + 80), step(-12, 12), u(0, 1);
  int near = 0, valid_count = 0;
  const int n = 1500;
  for (int i = 0; i < n; ++i) {
    const double px = x(rng), py = y(rng);
    const Point3 p{px, py, ground_at(px, py) + 80 * u(rng)};
    const Point3 q{px + step(rng), py + step(rng), p[2] + step(rng)};
    bool sampled_near = false;
    each_sample(p, q, [&](const Point3& s) { sampled_near = sampled_near || near_zone(s); });
    const bool valid = kept.motion_valid(p, q);
    if (sampled_near) {
      EXPECT_FALSE(valid) << i;
    }
    if (near_zone(p)) {
      EXPECT_FALSE(kept.state_valid(p)) << i;
    }
    near += sampled_near;
    valid_count += valid;
  }
  EXPECT_GT(near, n / 5);
  EXPECT_GT(valid_count, n / 5);
}

TEST(AirspaceConstraint, ZoneDistanceIsALowerBoundWithinRootTwo) {
  AirspaceZone zone;
  zone.rings = {{{0, 0}, {40, 0}, {40, 30}, {0, 30}}, {{10, 10}, {20, 10}, {20, 20}, {10, 20}}};
  zone.lower = ZoneLimit::crs_height(10);
  zone.upper = ZoneLimit::crs_height(30);
  const auto rings = open_rings(zone);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> x(-30, 70), z(-10, 50);
  for (int i = 0; i < 200; ++i) {
    const std::vector<Point3> path{{x(rng), x(rng), z(rng)}, {x(rng), x(rng), z(rng)}, {x(rng), x(rng), z(rng)}};
    double sampled = INFINITY;  // at least the true least distance, at most 2.5 cm more
    for (size_t k = 1; k < path.size(); ++k)
      each_sample(path[k - 1], path[k], [&](const Point3& s) {
        sampled =
            std::min(sampled, std::hypot(area_distance(rings, {s[0], s[1]}), std::max({0.0, 10 - s[2], s[2] - 30})));
      });
    const double d = zone_distance(zone, path, nullptr);
    EXPECT_LE(d, sampled + 1e-6) << i;
    // Failing at the bisection's upper end proves no more than that end times sqrt(2); the end
    // lies within 1 cm or 1 % of the distance above it (airspace_distance.cpp).
    // Bisected below 10 m only: from there on the lower bound of the heights over the area is
    // given, which may be looser (airspace.hpp).
    const double upper_end = d + 0.01 * std::max(1.0, d);
    if (d < 10) EXPECT_GE(upper_end * std::sqrt(2.0) + 0.025, sampled) << i;
    if (sampled == 0) {
      EXPECT_EQ(d, 0) << i;
    }
  }
  EXPECT_EQ(zone_distance(zone, {}, nullptr), INFINITY);
  EXPECT_NEAR(zone_distance(zone, {{15, 15, 20}}, nullptr), 5, 0.051);  // in the hole, 5 m from its walls (1 %)
}

TEST(AirspaceConstraint, ZoneDistanceOfAZoneWithoutLimitsIsItsHorizontalDistance) {
  AirspaceZone zone;
  zone.rings = {{{0, 0}, {40, 0}, {40, 30}, {0, 30}}, {{10, 10}, {20, 10}, {20, 20}, {10, 20}}};
  const auto rings = open_rings(zone);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> x(-60, 100), z(-10, 50);
  for (int i = 0; i < 200; ++i) {
    const std::vector<Point3> path{{x(rng), x(rng), z(rng)}, {x(rng), x(rng), z(rng)}, {x(rng), x(rng), z(rng)}};
    double sampled = INFINITY;  // at least the true distance, at most 2.5 cm more
    for (size_t k = 1; k < path.size(); ++k)
      each_sample(path[k - 1], path[k], [&](const Point3& s) {
        sampled = std::min(sampled, area_distance(rings, {s[0], s[1]}));
      });
    const double d = zone_distance(zone, path, nullptr);
    EXPECT_LE(d, sampled + 1e-9) << i;
    EXPECT_GE(d, sampled - 0.026) << i;  // exact, not within sqrt(2)
  }
}

// A ZoneSet answers every point and motion as its zones asked one by one (the oracle), and names
// the first zone that refuses, whatever the motion's length: 300 zones over 400 m, some with
// holes, some with CRS limits, 20,000 motions from 0 to 500 m long.
TEST(ZoneSet, AnswersAsItsZonesOneByOne) {
  std::mt19937_64 rng(49);
  std::uniform_real_distribution<double> at(0, 400), size(1, 15), height(0, 60);
  std::vector<std::shared_ptr<const AirspaceConstraint>> zones;
  for (int i = 0; i < 300; ++i) {
    AirspaceZone zone;
    zone.name = "z" + std::to_string(i);
    zone.restriction = "PROHIBITED";
    const double cx = at(rng), cy = at(rng), h = size(rng);
    zone.rings = {{{cx - h, cy - h}, {cx + h, cy - h}, {cx + h, cy + h}, {cx - h, cy + h}}};
    if (i % 5 == 0) zone.rings.push_back({{cx - h / 3, cy - h / 3}, {cx + h / 3, cy - h / 3}, {cx, cy + h / 3}});
    if (i % 3 == 0) zone.lower = ZoneLimit::crs_height(height(rng)), zone.upper = ZoneLimit::crs_height(70);
    zones.push_back(std::make_shared<AirspaceConstraint>(zone, 2.0, nullptr));
  }
  const ZoneSet set(zones);
  const auto first_refusing = [&](const Point3& p, const Point3& q) -> const FlightConstraint* {
    for (const auto& zone : zones)
      if (p == q ? !zone->state_valid(p) : !zone->motion_valid(p, q)) return zone.get();
    return nullptr;
  };
  std::uniform_real_distribution<double> where(-20, 420), z(-5, 80), length(0, 1);
  int refused = 0;
  for (int i = 0; i < 20000; ++i) {
    const Point3 p{where(rng), where(rng), z(rng)};
    const double scale = i % 10 == 0 ? 500 : 20, angle = 2 * M_PI * length(rng), l = scale * length(rng);
    const Point3 q = i % 7 == 0 ? p : Point3{p[0] + l * std::cos(angle), p[1] + l * std::sin(angle), z(rng)};
    const FlightConstraint* expected = first_refusing(p, q);
    ASSERT_EQ(set.refused_by(p, q), expected) << i;
    ASSERT_EQ(p == q ? set.state_valid(p) : set.motion_valid(p, q), expected == nullptr) << i;
    refused += expected != nullptr;
  }
  EXPECT_GT(refused, 2000);  // the zones were met, not only missed
  // Past kZoneSetFrom blocking zones the library hands the planner one set.
  std::vector<AirspaceZone> many;
  for (const auto& zone : zones) many.push_back(zone->zone());
  EXPECT_EQ(airspace_constraints(many, 2.0, nullptr).size(), 1u);
  many.resize(kZoneSetFrom - 1);
  EXPECT_EQ(airspace_constraints(many, 2.0, nullptr).size(), kZoneSetFrom - 1);
}

TEST(AirspaceZone, LabelShowsControlCharactersAndBadBytesVisibly) {
  AirspaceZone zone;
  zone.name = "\x1b[31mred\a";
  zone.id = std::string("a\0b\xff", 4);
  zone.source_file = "z\n.json";
  EXPECT_EQ(zone_label(zone), "zone '\\x1b[31mred\\x07' (a\\x00b\\xff) of z\\x0a.json");
  zone.name = "\u00fcber \u65e5";  // UTF-8 stays as it is
  EXPECT_EQ(zone_label(zone).substr(0, 16), "zone '\u00fcber \u65e5'");
}

TEST(AirspaceConstraint, RefusesBadZonesNamingThem) {
  AirspaceZone zone;
  zone.name = "flat";
  zone.source_file = "zones.json";
  zone.rings = {{{0, 0}, {1, 1}, {0, 0}}};
  try {
    AirspaceConstraint(zone, 2, nullptr);
    ADD_FAILURE();
  } catch (const ArgumentError& e) {
    EXPECT_NE(std::string(e.what()).find("zone 'flat' of zones.json"), std::string::npos) << e.what();
  }
  zone.rings = {{{0, 0}, {1, 0}, {1, 1}}};
  zone.lower = ZoneLimit::agl(30), zone.upper = ZoneLimit::agl(20);
  EXPECT_THROW(AirspaceConstraint(zone, 2, nullptr), ArgumentError);
  zone.upper = ZoneLimit::none();
  EXPECT_THROW(AirspaceConstraint(zone, -1, nullptr), ArgumentError);
}

// ---- planning around zones on the real mesh ------------------------------------------------

TEST(AirspacePlan, FliesAroundTheZonesOfTheNrwFileAndRefusesWaypointsUnderAFloor) {
  const Grid dsm2 = resample(nrw_crop(), 2.0, Resampling::Median);
  const Mesh mesh = triangulate_xy3(dsm2);
  const ClearanceIndex index(mesh);
  const auto ground = std::make_shared<const GroundGrid>(nrw_crop());  // AGL counted from the DSM
  PlanOptions options;
  options.max_agl = 45;
  options.spacing = 15;
  options.ground = ground;
  auto waypoint = [&](double x, double y) {
    for (int ring = 0; ring < 8; ++ring)
      for (int dx = -ring; dx <= ring; ++dx)
        for (int dy = -ring; dy <= ring; ++dy) {
          const double px = x + 3 * dx, py = y + 3 * dy, base = index.ground(px, py);
          const Point3 p{px, py, base + 35};
          if (std::max(std::abs(dx), std::abs(dy)) == ring && !std::isnan(base) && index.point_clear(p, 2.5) &&
              ground->height_above(p) <= 40)
            return p;
        }
    ADD_FAILURE() << "no waypoint near " << x << ", " << y;
    return Point3{x, y, 0};
  };
  const std::vector<Point3> waypoints{waypoint(356330, 5699280), waypoint(356770, 5699720)};
  const std::vector<AirspaceZone> zones =
      read_airspace(zones_file("nrw_zones_ed269.json"), crs_of("EPSG:25832"), egm96());
  const AirspaceZone& circle = zones[1];
  const PlanResult free = plan_path(index, waypoints, options);
  ASSERT_EQ(free.status, PlanStatus::Solved) << free.reason;
  bool entered = false;
  for (size_t k = 1; k < free.path.size(); ++k)
    each_sample(free.path[k - 1], free.path[k],
                [&](const Point3& s) { entered = entered || zone_contains(circle, s, ground.get()); });
  ASSERT_TRUE(entered) << "the free path does not cross the circle: the test proves nothing";

  options.constraints = airspace_constraints(zones, options.safety, ground);
  ASSERT_EQ(options.constraints.size(), 5u);  // NO_RESTRICTION does not block
  const PlanResult around = plan_path(index, waypoints, options);
  ASSERT_EQ(around.status, PlanStatus::Solved) << around.reason;
  for (const auto* path : {&around.path, &around.raw_path})
    for (size_t k = 1; k < path->size(); ++k) {
      EXPECT_TRUE(index.segment_clear((*path)[k - 1], (*path)[k], options.safety));
      each_sample((*path)[k - 1], (*path)[k], [&](const Point3& s) {
        for (const AirspaceZone& z : zones)
          if (zone_blocks(z)) {
            EXPECT_FALSE(zone_contains(z, s, ground.get())) << z.name;
          }
        // The circle from 0 to 120 m AGL, above which the ceiling forbids flight: kept 2 m aside.
        EXPECT_GE(area_distance(open_rings(circle), {s[0], s[1]}), options.safety - 1e-6);
      });
    }
  for (const AirspaceZone& z : zones)
    if (zone_blocks(z)) {
      EXPECT_GE(zone_distance(z, around.path, ground.get()), options.safety - 0.011) << z.name;
    }
  EXPECT_EQ(zone_distance(circle, free.path, ground.get()), 0);

  // A zone over the whole crop from 10 m above the DSM: the waypoints, 35 m up, are inside it.
  AirspaceZone everything;
  everything.name = "Everything";
  everything.source_file = "hand.json";
  everything.restriction = "PROHIBITED";
  everything.rings = {{{356290, 5699240}, {356810, 5699240}, {356810, 5699760}, {356290, 5699760}}};
  everything.lower = ZoneLimit::agl(10);
  for (const Point3& w : waypoints) {
    EXPECT_TRUE(zone_contains(everything, w, ground.get()));
  }
  options.constraints = airspace_constraints({everything}, options.safety, ground);
  const PlanResult refused = plan_path(index, waypoints, options);
  EXPECT_EQ(refused.status, PlanStatus::InvalidWaypoint);
  EXPECT_NE(refused.reason.find("no-fly zone 'Everything' of hand.json"), std::string::npos) << refused.reason;
  // Unblocked: a zone whose restriction is not blocking is no constraint.
  everything.restriction = "CONDITIONAL";
  EXPECT_TRUE(airspace_constraints({everything}, options.safety, ground).empty());
}

// A mission's flat geofence (issue 52): path_meets_zone_rings() against samples every 5 cm along
// random two-leg paths, each ring by itself (the concave outer ring, and the hole, which a path
// through it meets); paths that pass within 5 cm of an edge are left out (the samples cannot
// tell). Heights play no part.
TEST(AirspaceZone, APathMeetsTheRingsExactlyWhereItsSamplesDo) {
  AirspaceZone zone;
  zone.rings = {{{0, 0}, {0, 60}, {30, 40}, {60, 60}, {60, 0}, {0, 0}}, {{20, 10}, {40, 10}, {40, 25}, {20, 25}}};
  const auto rings = open_rings(zone);
  std::mt19937_64 rng(52);
  std::uniform_real_distribution<double> x(-30, 90), step(-40, 40), z(0, 200);
  int met = 0, missed = 0;
  for (int i = 0; i < 2000; ++i) {
    const Point3 a{x(rng), x(rng), z(rng)}, b{a[0] + step(rng), a[1] + step(rng), z(rng)},
        c{b[0] + step(rng), b[1] + step(rng), z(rng)};
    double nearest = INFINITY;  // least distance of a sample to one ring's area, over the rings
    for (const auto& ring : rings)
      for (const auto& [p, q] : {std::pair{a, b}, std::pair{b, c}})
        each_sample(p, q, [&](const Point3& s) { nearest = std::min(nearest, area_distance({ring}, {s[0], s[1]})); });
    if (nearest > 0 && nearest < 0.05) continue;
    const bool meets = path_meets_zone_rings(zone, {a, b, c});
    EXPECT_EQ(meets, nearest == 0) << i;
    (meets ? met : missed)++;
  }
  EXPECT_GT(met, 200);
  EXPECT_GT(missed, 200);
  EXPECT_TRUE(path_meets_zone_rings(zone, {{25, 15, 0}, {35, 20, 0}}));   // wholly in the hole
  EXPECT_FALSE(path_meets_zone_rings(zone, {{30, 45, 0}, {30, 55, 0}}));  // in the notch, outside
}
