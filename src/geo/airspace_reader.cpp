// The no-fly zones authorities publish, read into the mesh's CRS (airspace_io.hpp). ED-269's
// shape as EUROCONTROL's "Guidelines for GeoZones data sets" and the published files follow it
// (features with a `geometry` array of volumes, each a `horizontalProjection` Polygon or Circle
// with its limits; e.g. the parser of openutm/flight-blender, GeoZoneParser); GeoJSON as RFC
// 7946 with dsmplan's own properties (docs/formats.md). Circles: Karney, "Algorithms for
// geodesics", J. Geodesy 87, 2013 (PROJ's geodesic.h), projected, then circumscribed.
#include <geodesic.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>

#include "core/json_parse.hpp"
#include "core/text.hpp"
#include "dsmplan/airspace_io.hpp"

namespace dsmplan {

namespace {

using Json = nlohmann::json;
using LonLat = std::array<double, 2>;

constexpr size_t kMaxBytes = 256u << 20;
constexpr size_t kMaxZones = 100000;
constexpr double kFoot = 0.3048;
constexpr double kCircleExcess = 0.05;  // metres a circle's polygon may stand beyond it, at its corners

// A limit as the file gives it, in metres.
struct RawLimit {
  bool given = false;
  double metres = 0;
  std::string reference;  // AGL, AMSL, WGS84
};

class Reader {
public:
  Reader(const std::string& path, const Crs& crs, const VerticalOptions& vertical)
      : path_(path), crs_(crs), vertical_(vertical) {}

  std::vector<AirspaceZone> read() {
    const Json doc = parse();
    const Json* features = nullptr;
    if (doc.is_array()) features = &doc;
    if (doc.is_object() && doc.contains("features") && doc["features"].is_array()) features = &doc["features"];
    if (!features) fail("", "neither an ED-269 zone file nor a GeoJSON FeatureCollection: no 'features' array");
    for (size_t k = 0; k < features->size(); ++k) feature((*features)[k], k);
    if (zones_.empty())
      fail("",
           "holds no zone (its 'features' array is empty): a plan would keep out of nothing; leave the file "
           "out to plan without zones");
    return std::move(zones_);
  }

private:
  [[noreturn]] void fail(const std::string& place, const std::string& problem) const {
    throw InputError(path_, place, problem);
  }

  Json parse() const {
    require_input_file(path_, kMaxBytes, "a no-fly zone file");
    std::ifstream in(path_, std::ios::binary);
    if (!in) fail("", "cannot open the no-fly zone file");
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (in.bad()) fail("", "cannot read the no-fly zone file");
    try {
      return parse_json_strict<Json>(bytes);
    } catch (const Json::parse_error& e) {
      fail("byte " + std::to_string(e.byte), "not JSON");
    } catch (const Json::out_of_range&) {
      fail("", "a number beyond the range of a double");
    } catch (const DuplicateJsonKey& twice) {
      fail("", "the key " + shown(twice.key) + " twice in one object: which one is meant is not said");
    }
  }

  static std::string text_of(const Json& object, const char* key) {
    if (!object.contains(key)) return {};
    const Json& v = object[key];
    if (v.is_string()) return v.get<std::string>();
    if (v.is_number_integer()) return std::to_string(v.get<long long>());
    return {};
  }

  void feature(const Json& f, size_t index) {
    std::string place = "feature " + std::to_string(index + 1);
    if (!f.is_object()) fail(place, "not a JSON object");
    if (!f.contains("geometry")) fail(place, "no 'geometry'");
    if (f["geometry"].is_array())
      ed269_feature(f, place);
    else
      geojson_feature(f, place);
  }

  // ---- ED-269 ----------------------------------------------------------------------------

  void ed269_feature(const Json& f, std::string place) {
    AirspaceZone zone;
    zone.id = text_of(f, "identifier");
    zone.name = text_of(f, "name");
    if (!zone.name.empty() || !zone.id.empty()) place += " '" + (zone.name.empty() ? zone.id : zone.name) + "'";
    zone.restriction = text_of(f, "restriction");
    check_restriction(zone.restriction, place, "restriction");
    const Json& volumes = f["geometry"];
    if (volumes.empty()) fail(place, "an empty 'geometry' array: no volume");
    for (size_t k = 0; k < volumes.size(); ++k) {
      const std::string where = volumes.size() > 1 ? place + ", geometry " + std::to_string(k + 1) : place;
      const Json& g = volumes[k];
      if (!g.is_object()) fail(where, "a geometry item that is not a JSON object");
      const double unit = uom(g, "uomDimensions", where, false);
      const RawLimit lower = raw_limit(g, "lowerLimit", "lowerVerticalReference", unit, where);
      const RawLimit upper = raw_limit(g, "upperLimit", "upperVerticalReference", unit, where);
      if (!g.contains("horizontalProjection") || !g["horizontalProjection"].is_object())
        fail(where, "no 'horizontalProjection' object");
      const Json& h = g["horizontalProjection"];
      const std::string type = text_of(h, "type");
      std::vector<std::vector<LonLat>> rings;
      AirspaceZone z = zone;
      if (type == "Polygon") {
        if (!h.contains("coordinates")) fail(where, "a Polygon without 'coordinates'");
        rings = polygon(h["coordinates"], where);
        z.rings = project(rings, where);
      } else if (type == "Circle") {
        circle(h, unit, where, z, rings);
      } else {
        fail(where, "a horizontalProjection is a Polygon or a Circle, got '" + type + "'");
      }
      add(std::move(z), rings, lower, upper, where);
    }
  }

  // ---- GeoJSON ---------------------------------------------------------------------------

  void geojson_feature(const Json& f, std::string place) {
    const Json& g = f["geometry"];
    static const Json empty = Json::object();
    const Json& props = f.contains("properties") && f["properties"].is_object() ? f["properties"] : empty;
    AirspaceZone zone;
    zone.id = text_of(props, "id");
    if (zone.id.empty()) zone.id = text_of(f, "id");
    zone.name = text_of(props, "name");
    if (!zone.name.empty() || !zone.id.empty()) place += " '" + (zone.name.empty() ? zone.id : zone.name) + "'";
    zone.restriction = props.contains("restriction") ? text_of(props, "restriction") : "PROHIBITED";
    check_restriction(zone.restriction, place, "restriction");
    if (!g.is_object() || !g.contains("coordinates")) fail(place, "expected a geometry with 'type' and 'coordinates'");
    const double unit = uom(props, "uom", place, true);
    const RawLimit lower = raw_limit(props, "lower", "lower_ref", unit, place);
    const RawLimit upper = raw_limit(props, "upper", "upper_ref", unit, place);
    const std::string type = text_of(g, "type");
    const Json& c = g["coordinates"];
    if (type == "Polygon") {
      AirspaceZone z = zone;
      const auto rings = polygon(c, place);
      z.rings = project(rings, place);
      add(std::move(z), rings, lower, upper, place);
    } else if (type == "MultiPolygon") {
      if (!c.is_array() || c.empty()) fail(place, "a MultiPolygon needs an array of polygons");
      for (size_t k = 0; k < c.size(); ++k) {
        const std::string where = c.size() > 1 ? place + ", polygon " + std::to_string(k + 1) : place;
        AirspaceZone z = zone;
        const auto rings = polygon(c[k], where);
        z.rings = project(rings, where);
        add(std::move(z), rings, lower, upper, where);
      }
    } else {
      fail(place, "zones are Polygon or MultiPolygon geometries, got '" + type + "'");
    }
  }

  // ---- shared ----------------------------------------------------------------------------

  void check_restriction(const std::string& value, const std::string& place, const char* key) const {
    for (const std::string& known : zone_restrictions())
      if (value == known) return;
    const std::string best = nearest_name(value, zone_restrictions());
    fail(place, std::string("'") + key + "' must be " + choice_list(zone_restrictions()) + ", got " + shown(value) +
                    (best.empty() ? "" : " (did you mean " + best + "?)"));
  }

  // Metres per unit of the file's `key`: "M" or "FT"; absent: metres when `optional`.
  double uom(const Json& object, const char* key, const std::string& place, bool optional) const {
    if (!object.contains(key) && optional) return 1;
    const std::string u = text_of(object, key);
    if (u == "M") return 1;
    if (u == "FT") return kFoot;
    if (!object.contains(key)) fail(place, std::string("no '") + key + "' (M or FT)");
    fail(place, std::string("unknown unit '") + key + "': " + object[key].dump().substr(0, 40) + " (M or FT)");
  }

  RawLimit raw_limit(const Json& object, const char* key, const char* ref_key, double unit,
                     const std::string& place) const {
    RawLimit limit;
    if (!object.contains(key) || object[key].is_null()) return limit;
    if (!object[key].is_number() || !std::isfinite(object[key].get<double>()))
      fail(place, std::string("'") + key + "' must be a number");
    limit.given = true;
    limit.metres = object[key].get<double>() * unit;
    limit.reference = text_of(object, ref_key);
    if (limit.reference != "AGL" && limit.reference != "AMSL" && limit.reference != "WGS84")
      fail(place, std::string("'") + ref_key + "' must be AGL, AMSL or WGS84, got '" + limit.reference + "'");
    return limit;
  }

  LonLat position(const Json& p, const std::string& place) const {
    if (!p.is_array() || p.size() < 2 || !p[0].is_number() || !p[1].is_number())
      fail(place, "a position must be [longitude, latitude]");
    const LonLat out{p[0].get<double>(), p[1].get<double>()};
    if (!std::isfinite(out[0]) || !std::isfinite(out[1]) || std::abs(out[0]) > 180 || std::abs(out[1]) > 90)
      fail(place, "a position that is not longitude, latitude in degrees: " + p.dump().substr(0, 60));
    return out;
  }

  std::vector<std::vector<LonLat>> polygon(const Json& c, const std::string& place) const {
    if (!c.is_array() || c.empty()) fail(place, "missing coordinates: a polygon needs an array of rings");
    std::vector<std::vector<LonLat>> rings;
    for (size_t k = 0; k < c.size(); ++k) {
      const std::string where = place + ", ring " + std::to_string(k + 1);
      if (!c[k].is_array()) fail(where, "a ring must be an array of positions");
      std::vector<LonLat> ring;
      for (const Json& p : c[k]) ring.push_back(position(p, where));
      if (ring.size() > 1 && ring.front() == ring.back()) ring.pop_back();
      if (ring.size() < 3)
        fail(where, "a ring with " + std::to_string(ring.size()) + " corners: at least 3 are needed");
      rings.push_back(std::move(ring));
    }
    return rings;
  }

  const Wgs84Transform& horizontal() {
    if (!horizontal_) horizontal_.emplace(Wgs84Transform::horizontal_only(crs_));  // x, y only: no heights
    return *horizontal_;
  }

  std::vector<std::vector<std::array<double, 2>>> project(const std::vector<std::vector<LonLat>>& rings,
                                                          const std::string& place) {
    std::vector<std::vector<std::array<double, 2>>> out;
    for (const auto& ring : rings) {
      std::vector<Point3> points;
      for (const LonLat& p : ring) points.push_back({p[0], p[1], 0});
      horizontal().from_wgs84(points);
      std::vector<std::array<double, 2>> xy;
      for (const Point3& p : points) {
        if (!std::isfinite(p[0]) || !std::isfinite(p[1])) fail(place, "a corner PROJ cannot transform into the CRS");
        xy.push_back({p[0], p[1]});
      }
      out.push_back(std::move(xy));
    }
    return out;
  }

  // The polygon around an ED-269 circle (see airspace_io.hpp); `corners` gets its lon, lat.
  void circle(const Json& h, double unit, const std::string& place, AirspaceZone& zone,
              std::vector<std::vector<LonLat>>& corners) {
    if (!h.contains("center")) fail(place, "a Circle without 'center'");
    const LonLat centre = position(h["center"], place);
    if (!h.contains("radius") || !h["radius"].is_number()) fail(place, "a Circle without a 'radius'");
    const double radius = h["radius"].get<double>() * unit;
    if (!(radius > 0) || !std::isfinite(radius) || radius > 1e6)
      fail(place, "a Circle's radius must be positive and at most 1000 km");
    geod_geodesic wgs84;
    geod_init(&wgs84, 6378137, 1 / 298.257223563);
    const int samples = 2048;
    std::vector<Point3> rim;
    rim.push_back({centre[0], centre[1], 0});
    for (int k = 0; k < samples; ++k) {
      double lat = 0, lon = 0;
      geod_direct(&wgs84, centre[1], centre[0], 360.0 * k / samples, radius, &lat, &lon, nullptr);
      rim.push_back({lon, lat, 0});
    }
    horizontal().from_wgs84(rim);
    double reach = 0;
    for (const Point3& p : rim) {
      if (!std::isfinite(p[0]) || !std::isfinite(p[1])) fail(place, "a Circle PROJ cannot transform into the CRS");
      reach = std::max(reach, std::hypot(p[0] - rim[0][0], p[1] - rim[0][1]));
    }
    reach *= 1 + 1e-6;  // the farthest point between two samples
    int n = 32;
    while (n < 1024 && reach / std::cos(M_PI / n) - reach > kCircleExcess) ++n;
    const double corner = reach / std::cos(M_PI / n);
    std::vector<std::array<double, 2>> ring;
    std::vector<LonLat> lonlat;
    for (int k = 0; k < n; ++k) {
      const double a = 2 * M_PI * k / n;
      ring.push_back({rim[0][0] + corner * std::cos(a), rim[0][1] + corner * std::sin(a)});
      const Point3 g = horizontal().to_wgs84({ring.back()[0], ring.back()[1], 0});
      lonlat.push_back({g[0], g[1]});
    }
    zone.rings = {std::move(ring)};
    corners = {std::move(lonlat)};
  }

  // A limit in the CRS: AGL as is, AMSL and WGS84 heights converted at every corner.
  ZoneLimit limit(const RawLimit& raw, const std::vector<std::vector<LonLat>>& corners, bool lower,
                  const std::string& place) {
    if (!raw.given) return ZoneLimit::none();
    if (raw.reference == "AGL") return ZoneLimit::agl(raw.metres);
    const bool msl = raw.reference == "AMSL";
    std::optional<Wgs84Transform>& t = msl ? msl_ : ellipsoid_;
    if (!t) {
      try {
        t.emplace(crs_, msl ? HeightReference::MeanSeaLevel : HeightReference::Ellipsoid, vertical_);
      } catch (const ArgumentError& e) {
        fail(place, "its " + raw.reference + " limit needs the DSM's heights in a known vertical reference (" +
                        e.field() + "): " + e.problem());
      }
    }
    double z = lower ? INFINITY : -INFINITY;
    for (const auto& ring : corners)
      for (const LonLat& c : ring) {
        const double h = t->from_wgs84({c[0], c[1], raw.metres})[2];
        if (!std::isfinite(h)) fail(place, "PROJ cannot convert its " + raw.reference + " limit into the CRS");
        z = lower ? std::min(z, h) : std::max(z, h);
      }
    return ZoneLimit::crs_height(z);
  }

  void add(AirspaceZone zone, const std::vector<std::vector<LonLat>>& corners, const RawLimit& lower,
           const RawLimit& upper, const std::string& place) {
    if (lower.given && upper.given && lower.reference == upper.reference && lower.metres > upper.metres)
      fail(place, "its lower limit lies above its upper limit");
    zone.lower = limit(lower, corners, true, place);
    zone.upper = limit(upper, corners, false, place);
    if (zone.lower.reference == ZoneLimit::Reference::crs && zone.upper.reference == ZoneLimit::Reference::crs &&
        zone.lower.height > zone.upper.height)
      fail(place, "its lower limit lies above its upper limit");
    zone.source_file = path_;
    if (zones_.size() >= kMaxZones) fail(place, "more than 100000 zones");
    zones_.push_back(std::move(zone));
  }

  std::string path_;
  const Crs& crs_;
  VerticalOptions vertical_;
  std::optional<Wgs84Transform> horizontal_, ellipsoid_, msl_;
  std::vector<AirspaceZone> zones_;
};

}  // namespace

std::vector<AirspaceZone> read_airspace(const std::string& path, const Crs& crs, const VerticalOptions& vertical) {
  return Reader(path, crs, vertical).read();
}

}  // namespace dsmplan
