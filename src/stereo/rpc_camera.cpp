// The RPC00B camera (dsmplan/rpc.hpp).
//
// Spec: NIMA STDI-0002 v2.1 (16 Nov 2000), "The Compendium of Controlled Extensions (CE) for the
// National Imagery Transmission Format (NITF)", appendix E, RPC00B: normalisation, the 20-term
// cubic order and line/sample = ratio * SCALE + OFF. Checked against GDAL's reader and transformer
// (gdal/alg/gdal_rpc.cpp, RPCComputeTerms and RPCTransformPoint), which tests/rpc_test.cpp uses as
// the oracle. The inverse follows the usual practice (GDAL, OSSIM, rpcm): Newton on the two
// planimetric unknowns at a fixed height; here with the analytic derivatives of the cubic terms,
// so that one step costs two evaluations' worth of work and converges quadratically.
#include <array>
#include <cmath>
#include <string>

#include "dsmplan/core.hpp"
#include "dsmplan/rpc.hpp"

namespace dsmplan {

std::array<double, 20> rpc_terms(double P, double L, double H) {
  return {1.0,       L,         P,         H,         L * P,     L * H,     P * H,     L * L,     P * P,     H * H,
          P * L * H, L * L * L, L * P * P, L * H * H, L * L * P, P * P * P, P * H * H, L * L * H, P * P * H, H * H * H};
}

namespace {

// d(terms)/dL and d(terms)/dP, same order as rpc_terms.
std::array<double, 20> terms_dL(double P, double L, double H) {
  return {0, 1, 0, 0, P, H, 0, 2 * L, 0, 0, P * H, 3 * L * L, P * P, H * H, 2 * L * P, 0, 0, 2 * L * H, 0, 0};
}
std::array<double, 20> terms_dP(double P, double L, double H) {
  return {0, 0, 1, 0, L, 0, H, 0, 2 * P, 0, L * H, 0, 2 * L * P, 0, L * L, 3 * P * P, H * H, 0, 2 * P * H, 0};
}

double dot(const std::array<double, 20>& a, const std::array<double, 20>& b) {
  double s = 0;
  for (int i = 0; i < 20; ++i) s += a[i] * b[i];
  return s;
}

struct Normalised {
  double P, L, H;
};

Normalised normalise(const RpcModel& m, const GeoPoint& g) {
  return {(g.lat - m.lat_off) / m.lat_scale, (g.lon - m.long_off) / m.long_scale,
          (g.height - m.height_off) / m.height_scale};
}

// Position (col, row) and its derivatives by (lon, lat), the terms computed once.
struct Evaluation {
  double col, row;
  std::array<double, 4> J;  // dcol/dlon, dcol/dlat, drow/dlon, drow/dlat
};

Evaluation evaluate(const RpcModel& m, const GeoPoint& g, double sensor_col, double sensor_row) {
  const Normalised n = normalise(m, g);
  const auto t = rpc_terms(n.P, n.L, n.H);
  const auto tL = terms_dL(n.P, n.L, n.H), tP = terms_dP(n.P, n.L, n.H);
  const double Nc = dot(m.samp_num, t), Dc = dot(m.samp_den, t), Nr = dot(m.line_num, t), Dr = dot(m.line_den, t);
  auto derivative = [](double N, double D, double dN, double dD) { return (dN * D - N * dD) / (D * D); };
  const double cL = derivative(Nc, Dc, dot(m.samp_num, tL), dot(m.samp_den, tL));
  const double cP = derivative(Nc, Dc, dot(m.samp_num, tP), dot(m.samp_den, tP));
  const double rL = derivative(Nr, Dr, dot(m.line_num, tL), dot(m.line_den, tL));
  const double rP = derivative(Nr, Dr, dot(m.line_num, tP), dot(m.line_den, tP));
  // Chain rule: d/dlon = d/dL / LONG_SCALE, d/dlat = d/dP / LAT_SCALE; times the image scales.
  return {Nc / Dc * m.samp_scale + m.samp_off + 0.5 - sensor_col,
          Nr / Dr * m.line_scale + m.line_off + 0.5 - sensor_row,
          {cL * m.samp_scale / m.long_scale, cP * m.samp_scale / m.lat_scale, rL * m.line_scale / m.long_scale,
           rP * m.line_scale / m.lat_scale}};
}

}  // namespace

RpcCamera::RpcCamera(const RpcModel& model, double sensor_col, double sensor_row)
    : model_(model), sensor_col_(sensor_col), sensor_row_(sensor_row) {
  const RpcModel& m = model_;
  auto finite = [](double v) { return std::isfinite(v); };
  bool ok = finite(sensor_col) && finite(sensor_row);
  for (double v : {m.line_off, m.samp_off, m.lat_off, m.long_off, m.height_off, m.line_scale, m.samp_scale, m.lat_scale,
                   m.long_scale, m.height_scale})
    ok = ok && finite(v);
  for (const auto* a : {&m.line_num, &m.line_den, &m.samp_num, &m.samp_den})
    for (double v : *a) ok = ok && finite(v);
  if (!ok) throw ArgumentError("RPC", "a coefficient, offset or scale is not a finite number");
  for (double s : {m.line_scale, m.samp_scale, m.lat_scale, m.long_scale, m.height_scale})
    if (s == 0) throw ArgumentError("RPC", "a scale is zero");
  // Linear part at the origin of the normalised space (P = L = H = 0):
  // r ≈ (ln1 L + ln2 P) / ln0 - ..., by the quotient rule with the denominators' linear terms.
  auto lin = [](const std::array<double, 20>& num, const std::array<double, 20>& den, int k) {
    return (num[k] * den[0] - num[0] * den[k]) / (den[0] * den[0]);
  };
  const double a = lin(m.samp_num, m.samp_den, 1), b = lin(m.samp_num, m.samp_den, 2);  // dc/dL, dc/dP
  const double c = lin(m.line_num, m.line_den, 1), d = lin(m.line_num, m.line_den, 2);  // dr/dL, dr/dP
  const double det = a * d - b * c;
  if (m.samp_den[0] != 0 && m.line_den[0] != 0 && det != 0 && std::isfinite(det))
    linear_inverse_ = {d / det, -b / det, -c / det, a / det};  // (L, P) from (c, r)
}

PixelPoint RpcCamera::project(const GeoPoint& ground) const {
  const RpcModel& m = model_;
  const Normalised n = normalise(m, ground);
  const auto t = rpc_terms(n.P, n.L, n.H);
  const double r = dot(m.line_num, t) / dot(m.line_den, t);
  const double c = dot(m.samp_num, t) / dot(m.samp_den, t);
  // RPC: centre of the scene's first pixel at 0; dsmplan (GDAL): at 0.5.
  return {c * m.samp_scale + m.samp_off + 0.5 - sensor_col_, r * m.line_scale + m.line_off + 0.5 - sensor_row_};
}

std::array<double, 4> RpcCamera::jacobian(const GeoPoint& ground) const {
  return evaluate(model_, ground, sensor_col_, sensor_row_).J;
}

GeoPoint RpcCamera::localize(const PixelPoint& pixel, double height) const {
  const RpcModel& m = model_;
  // First guess: the inverse of the linear part (exact for an affine camera), the height's linear
  // term taken out first.
  const double Hn = (height - m.height_off) / m.height_scale;
  auto lin = [](const std::array<double, 20>& num, const std::array<double, 20>& den, int k) {
    return den[0] != 0 ? (num[k] * den[0] - num[0] * den[k]) / (den[0] * den[0]) : 0.0;
  };
  const double cn = (pixel.col - 0.5 + sensor_col_ - m.samp_off) / m.samp_scale;
  const double rn = (pixel.row - 0.5 + sensor_row_ - m.line_off) / m.line_scale;
  const double c0 = (m.samp_den[0] != 0 ? m.samp_num[0] / m.samp_den[0] : 0) + lin(m.samp_num, m.samp_den, 3) * Hn;
  const double r0 = (m.line_den[0] != 0 ? m.line_num[0] / m.line_den[0] : 0) + lin(m.line_num, m.line_den, 3) * Hn;
  const auto& li = linear_inverse_;
  GeoPoint g{m.long_off + (li[0] * (cn - c0) + li[1] * (rn - r0)) * m.long_scale,
             m.lat_off + (li[2] * (cn - c0) + li[3] * (rn - r0)) * m.lat_scale, height};
  if (!std::isfinite(g.lon) || !std::isfinite(g.lat)) g = {m.long_off, m.lat_off, height};
  // Newton: quadratic convergence, about 4 steps from the linear guess on the Pléiades RPCs.
  for (int it = 0; it < 30; ++it) {
    const Evaluation e = evaluate(m, g, sensor_col_, sensor_row_);
    const double ec = pixel.col - e.col, er = pixel.row - e.row;
    const auto& J = e.J;
    const double det = J[0] * J[3] - J[1] * J[2];
    if (!std::isfinite(det) || det == 0 || !std::isfinite(ec) || !std::isfinite(er)) break;
    // Converged: the residual is at the rounding of the evaluation (1e-6 px is ~0.5 µm here).
    if (std::abs(ec) < 1e-6 && std::abs(er) < 1e-6) return g;
    g.lon += (J[3] * ec - J[1] * er) / det;
    g.lat += (-J[2] * ec + J[0] * er) / det;
  }
  throw InputError("", "RPC",
                   "the position (" + std::to_string(pixel.col) + ", " + std::to_string(pixel.row) + ") at height " +
                       std::to_string(height) + " m does not localize: outside the model's domain");
}

bool RpcCamera::in_domain(const GeoPoint& ground, double margin) const {
  const Normalised n = normalise(model_, ground);
  const double limit = 1 + margin;
  return std::abs(n.P) <= limit && std::abs(n.L) <= limit && std::abs(n.H) <= limit;
}

}  // namespace dsmplan
