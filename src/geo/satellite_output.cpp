// The satellite DSM's output CRS and its GeoTIFF (dsmplan/stereo_io.hpp): the CRS as given or
// the scene's UTM zone, checked, made 3D, and PROJ's operation from the RPCs' ground (WGS 84
// longitude, latitude, ellipsoidal height) to it; the file's statement of its heights.
#include <cpl_conv.h>
#include <cpl_error.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>

#include <algorithm>
#include <cmath>

#include "core/atomic_file.hpp"
#include "dsmplan/raster_io.hpp"
#include "dsmplan/stereo_io.hpp"
#include "dsmplan/wgs84.hpp"
#include "heights_statement.hpp"

namespace dsmplan {
namespace {

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};

// --crs, or WGS 84 / UTM of the point, parsed and checked, made 3D when it is 2D.
OGRSpatialReference output_srs(const std::string& definition) {
  OGRSpatialReference srs;
  CPLPushErrorHandler(CPLQuietErrorHandler);
  const OGRErr parsed = srs.SetFromUserInput(definition.c_str());
  CPLPopErrorHandler();
  if (parsed != OGRERR_NONE) throw ArgumentError("--crs", "'" + definition + "' is not a CRS GDAL/PROJ can read");
  if (!srs.IsProjected())
    throw ArgumentError("--crs", "'" + definition + "' is not a projected CRS: give one in metres, e.g. EPSG:32637");
  if (std::abs(srs.GetLinearUnits() - 1) > 1e-9)
    throw ArgumentError("--crs", "'" + definition + "' is not in metres: dsmplan measures in metres");
  if (!srs.IsCompound() && srs.GetAxesCount() == 2) srs.PromoteTo3D(nullptr);
  return srs;
}

std::string wkt2_of(const OGRSpatialReference& srs) {
  std::string text;
  char* wkt = nullptr;
  const char* wkt_options[] = {"FORMAT=WKT2_2019", "MULTILINE=NO", nullptr};
  if (srs.exportToWkt(&wkt, wkt_options) == OGRERR_NONE && wkt) text = wkt;
  CPLFree(wkt);
  return text;
}

// What a 2D CRS's DSM says of its heights: above the ellipsoid of its datum.

}  // namespace

SatelliteOutput satellite_output(const std::string& crs, const GeoPoint& centre, bool allow_approximate_vertical) {
  std::string definition = crs;
  if (definition.empty()) {
    const int zone = std::clamp(static_cast<int>(std::floor((centre.lon + 180) / 6)) + 1, 1, 60);
    definition = "EPSG:" + std::to_string((centre.lat >= 0 ? 32600 : 32700) + zone);
  }
  const OGRSpatialReference srs = output_srs(definition);
  SatelliteOutput out;
  // The file states the CRS as given; a 2D one's ellipsoidal heights go to its metadata.
  out.frame.crs.definition = definition;
  resolve_crs(out.frame.crs);
  if (!srs.IsCompound()) out.ellipsoidal_heights = ellipsoid_statement(srs);
  // The points go to the CRS as made 3D (ellipsoidal heights of its datum), or to the compound
  // CRS's heights through its geoid grid: never ellipsoidal heights labelled as the datum's.
  Crs heights_crs;
  heights_crs.definition = wkt2_of(srs);
  const std::array<double, 4> area{centre.lon - 0.5, centre.lat - 0.5, centre.lon + 0.5, centre.lat + 0.5};
  auto transform = [&] {
    try {
      return std::make_shared<const Wgs84Transform>(heights_crs, HeightReference::Ellipsoid,
                                                    VerticalOptions{"", allow_approximate_vertical}, area);
    } catch (const ArgumentError& error) {
      throw ArgumentError("--crs", "'" + definition + "': " + error.problem());
    }
  }();
  out.frame.transformation = transform->description();
  out.frame.from_wgs84 = [transform](std::vector<Point3>& points) { transform->from_wgs84(points); };
  return out;
}

void write_satellite_dsm(const Grid& dsm, const std::string& path, const std::string& ellipsoidal_heights,
                         const Progress& progress) {
  AtomicFile file(path);  // the GeoTIFF and its metadata, or nothing
  file.close_stream();
  write_geotiff(dsm, file.temp_path(), progress);
  if (!ellipsoidal_heights.empty()) {
    CPLErrorReset();
    std::unique_ptr<GDALDataset, DatasetCloser> written(
        GDALDataset::Open(file.temp_path().c_str(), GDAL_OF_RASTER | GDAL_OF_UPDATE));
    if (!written) throw OutputError(path, std::string("cannot reopen to state the heights: ") + CPLGetLastErrorMsg());
    written->SetMetadataItem(kEllipsoidalHeightsKey, ellipsoidal_heights.c_str());
    written.reset();
    if (CPLGetLastErrorType() >= CE_Failure)
      throw OutputError(path, std::string("cannot state the heights: ") + CPLGetLastErrorMsg());
  }
  file.commit();
}

}  // namespace dsmplan
