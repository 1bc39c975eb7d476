// PNG out through libpng (the PNG specification, ISO/IEC 15948), written atomically like every
// dsmplan output. libpng reports errors by longjmp, which must not cross C++ frames with
// destructors: the libpng calls live in one function with only plain locals.
#include <png.h>

#include <cerrno>
#include <csetjmp>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "core/atomic_file.hpp"
#include "dsmplan/picture.hpp"

namespace dsmplan {

namespace {

struct PngFailure {
  char message[256] = "libpng failed";
  int error = 0;  // errno when libpng gave up: its "Write Error" does not say why (disk full?)
};

void on_error(png_structp png, png_const_charp message) {
  auto* failure = static_cast<PngFailure*>(png_get_error_ptr(png));
  failure->error = errno;
  std::snprintf(failure->message, sizeof failure->message, "%s", message ? message : "libpng failed");
  png_longjmp(png, 1);
}

void on_warning(png_structp, png_const_charp) {}  // nothing a user could act on

// Returns false with `failure` filled when libpng gave up. Only plain locals below the setjmp.
bool write_rows(std::FILE* stream, int width, int height, png_bytepp rows, PngFailure* failure) {
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, failure, on_error, on_warning);
  if (!png) return false;
  png_infop info = png_create_info_struct(png);
  if (!info) {
    png_destroy_write_struct(&png, nullptr);
    return false;
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return false;
  }
  png_init_io(png, stream);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_text text{};
  text.compression = PNG_TEXT_COMPRESSION_NONE;
  text.key = const_cast<png_charp>("Software");
  text.text = const_cast<png_charp>("dsmplan " DSMPLAN_VERSION);
  png_set_text(png, info, &text, 1);
  png_set_rows(png, info, rows);
  png_write_png(png, info, PNG_TRANSFORM_IDENTITY, nullptr);
  png_destroy_write_struct(&png, &info);
  return true;
}

}  // namespace

void write_png(const Image& image, const std::string& path) {
  if (image.width <= 0 || image.height <= 0) throw ArgumentError("image", "is empty: nothing to write");
  if (image.rgb.size() != static_cast<size_t>(image.width) * image.height * 3) {
    throw ArgumentError("image", "its pixel array does not hold width x height x 3 bytes");
  }
  std::vector<png_bytep> rows(image.height);
  for (int r = 0; r < image.height; ++r) {
    // libpng only reads the rows; its API is not const-correct.
    rows[r] = const_cast<png_bytep>(image.rgb.data() + static_cast<size_t>(r) * image.width * 3);
  }
  AtomicFile file(path);
  PngFailure failure;
  if (!write_rows(file.stream(), image.width, image.height, rows.data(), &failure)) {
    const bool io_error = std::ferror(file.stream()) && failure.error != 0;
    throw OutputError(path,
                      std::string("cannot write: ") + (io_error ? std::strerror(failure.error) : failure.message));
  }
  file.commit();
}

}  // namespace dsmplan
