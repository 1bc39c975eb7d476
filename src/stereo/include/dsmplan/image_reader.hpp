// dsmplan/image_reader.hpp: how the stereo pipelines read their images: an image file opened for
// reading by windows. The stage knows no file format; src/geo implements this with GDAL
// (open_image_file(), dsmplan/stereo_io.hpp) and the jobs hand that in.
#pragma once

#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace dsmplan {

/// One image, open for reading by windows. Pixels are read as float intensities, unscaled (an
/// 8-bit image gives 0..255, a 16-bit one 0..65535). Not safe for concurrent reads: the
/// pipelines read one window at a time.
class ImageReader {
public:
  virtual ~ImageReader() = default;
  /// The image's file, as given: the file the stage's InputErrors name.
  virtual const std::string& path() const = 0;
  virtual int width() const = 0;   ///< pixels, at least 1
  virtual int height() const = 0;  ///< pixels, at least 1
  virtual int bands() const = 0;   ///< at least 1
  /// The value band `band` (1-based) declares as no data, if any.
  virtual std::optional<double> nodata(int band) const = 0;
  /// Reads columns [col0, col0 + cols) x rows [row0, row0 + rows) of band `band` (1-based),
  /// row-major, into `out` (cols x rows floats), values as stored (no data not replaced). The
  /// window must lie inside the image. Returns an empty string on success, else why it could not
  /// be read (one line, the reader's words) for the caller's InputError.
  [[nodiscard]] virtual std::string read(int band, int col0, int row0, int cols, int rows, float* out) const = 0;
};

/// Opens the image file `path` for reading: InputError naming `path` and `place` (e.g. "camera
/// 2") when it is no image the reader can read, or not 8- or 16-bit.
using ImageOpener = std::function<std::unique_ptr<ImageReader>(const std::string& path, const std::string& place)>;

}  // namespace dsmplan
