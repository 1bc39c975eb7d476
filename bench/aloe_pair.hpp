// The Middlebury Aloe pair (data/middlebury-aloe) read through GDAL, for bench_sgm and
// tests/stereo_test.cpp: grey = round(0.299 R + 0.587 G + 0.114 B), the ground truth as it is
// (disparity in pixels, 0 = unknown), and the bad-pixel rates of a disparity image against it.
#pragma once

#include <gdal_priv.h>

#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

namespace aloe {

struct Image {
  int width = 0, height = 0;
  std::vector<std::uint8_t> pixels;
};

inline Image read_grey(const std::string& path) {
  GDALAllRegister();
  GDALDataset* dataset = static_cast<GDALDataset*>(GDALOpen(path.c_str(), GA_ReadOnly));
  if (!dataset) throw std::runtime_error(path + ": cannot be opened");
  Image image;
  image.width = dataset->GetRasterXSize(), image.height = dataset->GetRasterYSize();
  const int bands = dataset->GetRasterCount();
  const std::size_t n = static_cast<std::size_t>(image.width) * image.height;
  std::vector<std::uint8_t> band(n);
  std::vector<double> grey(n, 0.0);
  const double weights[3] = {0.299, 0.587, 0.114};
  for (int b = 0; b < bands && b < 3; ++b) {
    if (dataset->GetRasterBand(b + 1)->RasterIO(GF_Read, 0, 0, image.width, image.height, band.data(), image.width,
                                                image.height, GDT_Byte, 0, 0) != CE_None)
      throw std::runtime_error(path + ": cannot be read");
    for (std::size_t i = 0; i < n; ++i) grey[i] += (bands >= 3 ? weights[b] : 1.0) * band[i];
  }
  GDALClose(dataset);
  image.pixels.resize(n);
  for (std::size_t i = 0; i < n; ++i)
    image.pixels[i] = static_cast<std::uint8_t>(std::lround(std::min(255.0, grey[i])));
  return image;
}

struct Pair {
  Image left, right, truth;
};

inline Pair read_pair(const std::string& folder) {
  return {read_grey(folder + "/aloeL.jpg"), read_grey(folder + "/aloeR.jpg"), read_grey(folder + "/aloeGT.png")};
}

/// Over the pixels with ground truth: the share of them matched (completeness), and among the
/// matched ones the share off by more than 1 and 2 px; `unmatched_or_bad1` counts an unmatched
/// pixel as wrong too.
struct Rates {
  double completeness = 0, bad1 = 0, bad2 = 0, unmatched_or_bad1 = 0;
  std::size_t truth_pixels = 0, matched = 0;
};

inline Rates rates(const std::vector<float>& disparity, const Image& truth) {
  Rates r;
  std::size_t bad1 = 0, bad2 = 0;
  for (std::size_t i = 0; i < truth.pixels.size(); ++i) {
    if (truth.pixels[i] == 0) continue;
    ++r.truth_pixels;
    if (std::isnan(disparity[i])) continue;
    ++r.matched;
    const double error = std::abs(disparity[i] - truth.pixels[i]);
    bad1 += error > 1, bad2 += error > 2;
  }
  r.completeness = double(r.matched) / r.truth_pixels;
  r.bad1 = double(bad1) / r.matched, r.bad2 = double(bad2) / r.matched;
  r.unmatched_or_bad1 = double(r.truth_pixels - r.matched + bad1) / r.truth_pixels;
  return r;
}

}  // namespace aloe
