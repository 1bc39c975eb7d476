// dsmplan/rpc.hpp: satellite cameras given as rational polynomial coefficients (RPC00B).
//
// Model (NIMA STDI-0002, "The Compendium of Controlled Extensions (CE) for the National Imagery
// Transmission Format (NITF)", v2.1, appendix E: the RPC00B tagged record extension; the same
// model and term order as GDAL's RPC metadata domain, gdal/alg/gdal_rpc.cpp, which the tests use
// as the independent oracle). Ground (longitude, latitude in degrees on WGS 84, height in metres
// above the WGS 84 ellipsoid) is normalised
//   P = (lat - LAT_OFF) / LAT_SCALE,  L = (lon - LONG_OFF) / LONG_SCALE,  H = (h - HEIGHT_OFF) / HEIGHT_SCALE
// and the normalised image position is a ratio of two 20-term cubics,
//   r = LINE_NUM(P, L, H) / LINE_DEN(P, L, H),  c = SAMP_NUM(P, L, H) / SAMP_DEN(P, L, H),
// line = r * LINE_SCALE + LINE_OFF, sample = c * SAMP_SCALE + SAMP_OFF, the terms in RPC00B order
//   1, L, P, H, LP, LH, PH, L², P², H², PLH, L³, LP², LH², L²P, P³, PH², L²H, P²H, H³.
//
// Pixel convention. RPC line and sample are those of the full scene the RPC was made for, with
// the centre of its first pixel at (0, 0) (RPC00B; GDAL reads it so; Airbus's Pléiades RPCs put it
// at (1, 1), which the sensor offset absorbs). dsmplan's image coordinates are GDAL's, of the image
// at hand (often a crop of the scene): (col, row) = (0, 0) is the top-left corner of the top-left
// pixel, the centre of pixel (i, j) is (i + 0.5, j + 0.5). A crop the centre of whose first pixel
// is at the RPC's (sample, line) = (sensor_col, sensor_row) (its sensor offset; whole numbers for
// a crop cut on the pixel grid) maps by
//   col = sample + 0.5 - sensor_col,  row = line + 0.5 - sensor_row.
// How the readers find the sensor offset of a crop (and the half-pixel question, proven on the
// data) is told with read_rpc_camera below.
//
// Accuracy. project() is the polynomial evaluated in double (exact to rounding: ~1e-9 px).
// localize() inverts it at a given height by Newton's method on (lon, lat) with the analytic
// Jacobian, started from the inverse of the linear part (a few steps; speed: bench/README.md); it
// returns the first point whose projection is within 1e-6 px of the target (~0.5 µm on the
// ground at 0.5 m pixels; the round trip ground -> image -> ground is tested below 1 cm on a grid
// over the real Pléiades crops). It throws InputError when Newton does not converge in 30 steps
// (the point is far outside the RPC's domain, or the denominator vanishes).
//
// Domain. RPCs are fitted over |P|, |L|, |H| <= 1 (a little beyond is fine); outside the model is
// extrapolated and meaningless. in_domain() tells whether a ground point is inside by a margin.
//
// Errors (dsmplan/core.hpp): InputError naming the file and the key for a reader's bad
// input (a missing or non-numeric coefficient, a zero scale, an image without RPCs, a crop offset
// that is not on the pixel grid); ArgumentError for an RpcModel with a zero scale or non-finite
// value built by hand.
#pragma once

#include <array>
#include <string>

namespace dsmplan {

/// The 90 numbers of an RPC00B model (the names are those of GDAL's RPC metadata domain).
struct RpcModel {
  double line_off = 0, samp_off = 0, lat_off = 0, long_off = 0, height_off = 0;
  double line_scale = 1, samp_scale = 1, lat_scale = 1, long_scale = 1, height_scale = 1;
  std::array<double, 20> line_num{}, line_den{}, samp_num{}, samp_den{};
};

/// A point on the ground: degrees on WGS 84 and metres above its ellipsoid.
struct GeoPoint {
  double lon = 0, lat = 0, height = 0;
};

/// A position in an image, in GDAL's pixel convention (see above).
struct PixelPoint {
  double col = 0, row = 0;
};

/// The 20 RPC00B monomials of normalised (P, L, H) in the standard order (see above).
std::array<double, 20> rpc_terms(double P, double L, double H);

/// An RPC camera for one image: the model plus the sensor offset of the image within the scene.
class RpcCamera {
public:
  /// Checks the model (finite values, non-zero scales): ArgumentError otherwise.
  explicit RpcCamera(const RpcModel& model, double sensor_col = 0, double sensor_row = 0);

  /// Ground to image, exact (see Accuracy).
  PixelPoint project(const GeoPoint& ground) const;
  /// The derivatives of (col, row) by (lon, lat) in pixels per degree, at a ground point:
  /// {dcol/dlon, dcol/dlat, drow/dlon, drow/dlat}.
  std::array<double, 4> jacobian(const GeoPoint& ground) const;
  /// Image to ground at the given height, by Newton iteration (see Accuracy); InputError when it
  /// does not converge.
  GeoPoint localize(const PixelPoint& pixel, double height) const;
  /// Whether the ground point is inside the model's fitted domain, the normalised coordinates
  /// allowed to exceed 1 by `margin`.
  bool in_domain(const GeoPoint& ground, double margin = 0.1) const;

  const RpcModel& model() const { return model_; }
  double sensor_col() const { return sensor_col_; }
  double sensor_row() const { return sensor_row_; }
  /// The same model for a window of this image starting at its pixel (col0, row0).
  RpcCamera crop(double col0, double row0) const { return RpcCamera(model_, sensor_col_ + col0, sensor_row_ + row0); }

private:
  RpcModel model_;
  double sensor_col_, sensor_row_;
  // The inverse of the linear part of the normalised model, for localize's first guess.
  std::array<double, 4> linear_inverse_{};
};

}  // namespace dsmplan
