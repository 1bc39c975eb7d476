// Images for the stereo stage read through GDAL (dsmplan/stereo_io.hpp): ImageReader over a
// GDALDataset, and a satellite image's camera and pixels.
#include <cpl_error.h>
#include <gdal_priv.h>

#include "dsmplan/rpc_io.hpp"
#include "dsmplan/stereo_io.hpp"
#include "raster_inputs.hpp"

namespace dsmplan {
namespace {

struct DatasetCloser {
  void operator()(GDALDataset* d) const { GDALClose(d); }
};

class GdalImage final : public ImageReader {
public:
  GdalImage(std::string path, std::unique_ptr<GDALDataset, DatasetCloser> dataset)
      : path_(std::move(path)), dataset_(std::move(dataset)) {}
  const std::string& path() const override { return path_; }
  int width() const override { return dataset_->GetRasterXSize(); }
  int height() const override { return dataset_->GetRasterYSize(); }
  int bands() const override { return dataset_->GetRasterCount(); }
  std::optional<double> nodata(int band) const override {
    int has = 0;
    const double value = dataset_->GetRasterBand(band)->GetNoDataValue(&has);
    if (!has) return std::nullopt;
    return value;
  }
  std::string read(int band, int col0, int row0, int cols, int rows, float* out) const override {
    CPLErrorReset();
    if (dataset_->GetRasterBand(band)->RasterIO(GF_Read, col0, row0, cols, rows, out, cols, rows, GDT_Float32, 0, 0,
                                                nullptr) == CE_None)
      return {};
    return CPLGetLastErrorMsg();
  }

private:
  std::string path_;
  std::unique_ptr<GDALDataset, DatasetCloser> dataset_;
};

}  // namespace

std::unique_ptr<ImageReader> open_image_file(const std::string& path, const std::string& place) {
  require_raster_files(path);
  GDALAllRegister();
  CPLPushErrorHandler(CPLQuietErrorHandler);
  std::unique_ptr<GDALDataset, DatasetCloser> dataset(
      GDALDataset::Open(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY));
  CPLPopErrorHandler();
  if (!dataset || dataset->GetRasterCount() < 1) throw InputError(path, place, "is not a raster image GDAL can read");
  const GDALDataType type = dataset->GetRasterBand(1)->GetRasterDataType();
  if (type != GDT_Byte && type != GDT_UInt16 && type != GDT_Int16)
    throw InputError(path, place, std::string("image is ") + GDALGetDataTypeName(type) + ": give 8- or 16-bit images");
  return std::make_unique<GdalImage>(path, std::move(dataset));
}

SatelliteImage open_satellite_image(const std::string& path) {
  require_input_file(path);
  RpcCamera camera = read_rpc_camera(path);  // InputError: no RPC, a bad .geom, not a raster
  return {std::move(camera), open_image_file(path)};
}

}  // namespace dsmplan
