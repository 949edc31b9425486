// Frank constants from binned <|Qk_m3|^2> (see the header). A white background B (molecular
// disorder, the i = j terms) adds to <|Q|^2>: 1/E_obs = 1/E + B/c, c = (9/4) S^2 V kT, so
// E_obs = E - (B/c) E^2 + ...: the slope at k = 0 is unbiased, but a plane over k^2 < 0.1
// reads a secant, low by ~ (B/c) E there. The cubic absorbs the E^2, E^3 terms (the paper's
// route); subtract_self_term removes the self part of B. Per bin, E is corrected to second
// order for the bias of 1/<|Q|^2> and for the spread of (k1^2, k3^2) within the bin.
#include "kernels/frank_fit.hpp"

// GCC 12 reports -Wmaybe-uninitialized inside its own avx512fintrin.h (_mm256_undefined_pd,
// GCC bug 105593) for Eigen's vectorised reductions in the QR below: a false positive.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Dense>
#pragma GCC diagnostic pop
#include <array>
#include <cmath>
#include <nlohmann/json.hpp>
#include <set>
#include <stdexcept>
#include <utility>

namespace hardrod {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

struct Point {
  double x, y;         // mean k1^2, k3^2 of the bin
  double vx, cxy, vy;  // (co)variances of k1^2, k3^2 within the bin
  double E;            // c / <|Q_m3|^2>, ratio bias removed
  long long count;
  double cv2;         // pooled squared coefficient of variation of |Q_m3|^2 (1 if Gaussian)
  double background;  // subtracted self term / c (0 without subtraction)
  // Relative error of the bin's E when E_model is the truth: that of the mean of |Q|^2,
  // sqrt(cv2 / count) (|Q|^2 / signal), with |Q|^2 / signal = 1 + background E_model.
  double rel(double E_model) const {
    return std::sqrt(cv2 / static_cast<double>(count)) * (1.0 + background * E_model);
  }
};

// E_m3 per bin of `data` (m = 1 for Q_13, 2 for Q_23). With `allowed`, only those bins
// (the replicas of an error estimate use the bins of the central fit, so that a bin does
// not drop in and out of the fit with the noise of its count).
// Bin errors use one coefficient of variation pooled over the bins rather than each bin's
// own: a bin's sample variance grows with its own outliers, so per-bin errors would give
// bins whose mean fluctuated up (E down) less weight and bias K up.
std::vector<Point> e_points(const FrankBlock &data, int m, double volume, const FrankFitOptions &o,
                            const std::set<FrankBinKey> *allowed) {
  std::vector<Point> points;
  if (data.samples <= 0) return points;
  const double c = 2.25 * (data.sum_S2 / static_cast<double>(data.samples)) * volume * o.kT;
  double cv2_sum = 0.0, dof = 0.0;
  std::vector<std::array<double, 2>> mean_self;  // per accepted bin
  for (const auto &[key, bin] : data.bins) {
    if (allowed ? !allowed->contains(key) || bin.count < 2
                : bin.count < std::max(2LL, o.min_bin_count))
      continue;
    const double n = static_cast<double>(bin.count);
    const double mean = (m == 1 ? bin.q13 : bin.q23) / n;
    const double meansq = (m == 1 ? bin.q13sq : bin.q23sq) / n;
    const double self = o.subtract_self_term ? (m == 1 ? bin.self13 : bin.self23) / n : 0.0;
    if (!(mean - self > 0.0) || !std::isfinite(mean)) continue;  // no signal left
    const double x = bin.k1sq / n, y = bin.k3sq / n;
    points.push_back({x, y, std::max(0.0, bin.k1sq_sq / n - x * x), bin.k1sq_k3sq / n - x * y,
                      std::max(0.0, bin.k3sq_sq / n - y * y), c / (mean - self), bin.count, 0.0,
                      self / c});
    mean_self.push_back({mean, self});
    cv2_sum += std::max(0.0, meansq - mean * mean) * (n / (n - 1.0)) / (mean * mean) * (n - 1.0);
    dof += n - 1.0;
  }
  const double cv2 = dof > 0.0 ? cv2_sum / dof : kNaN;
  for (std::size_t b = 0; b < points.size(); ++b) {
    Point &p = points[b];
    p.cv2 = cv2;
    // E[1/mean] = (1/mu)(1 + rel^2 + ...): remove the ratio bias to second order.
    const double rel = std::sqrt(cv2 / static_cast<double>(p.count)) * mean_self[b][0] /
                       (mean_self[b][0] - mean_self[b][1]);
    p.E *= 1.0 - rel * rel;
  }
  if (!(cv2 > 0.0)) points.clear();  // no spread at all: nothing to weight with
  return points;
}

// Monomials x^i y^j of a model; the first two are (1, 0) and (0, 1): K_m and K3.
std::vector<std::array<int, 2>> monomials(bool cubic) {
  std::vector<std::array<int, 2>> mono = {{1, 0}, {0, 1}};
  if (cubic)
    for (int i = 0; i <= 3; ++i)
      for (int j = 0; j <= 3; ++j)
        if (i + j >= 2) mono.push_back({i, j});  // (1,0), (0,1) are already first
  return mono;
}

struct ModelValues {
  double Km = kNaN, K3 = kNaN, chi2 = kNaN;
  int bins = 0;
  std::vector<std::array<double, 3>> terms;  // (i, j, a_ij) in D^2i+2j units: E = sum a x^i y^j
};

// Weighted least squares of E = sum_t a_t x^i y^j over points with x, y < max_k2, with
// iterative reweighting (header). Each iteration also undoes, with the previous fit, the
// averaging over a bin: <|Q|^2>_bin = c <1/E>_bin, so the bin's E is the harmonic mean of
// its members, E_mean (1 - var(E)/E_mean^2) to second order, var(E) = g^T C g with g the
// model's gradient and C the bin's (k1^2, k3^2) covariance. Columns are scaled by the
// largest x, y for conditioning.
ModelValues fit_model(const std::vector<Point> &all, bool cubic, double max_k2, int iterations) {
  std::vector<Point> pts;
  double xs = 0.0, ys = 0.0;
  for (const Point &p : all)
    if (p.x < max_k2 && p.y < max_k2) {
      pts.push_back(p);
      xs = std::max(xs, p.x), ys = std::max(ys, p.y);
    }
  const auto mono = monomials(cubic);
  const auto n = static_cast<Eigen::Index>(pts.size());
  const auto np = static_cast<Eigen::Index>(mono.size());
  ModelValues out;
  out.bins = static_cast<int>(n);
  if (n <= np || !(xs > 0.0) || !(ys > 0.0)) return out;
  Eigen::MatrixXd A(n, np), Ax(n, np), Ay(n, np);  // design and its x, y derivatives
  Eigen::VectorXd E(n), target(n), model(n), w(n), coef;
  for (Eigen::Index b = 0; b < n; ++b) {
    const Point &p = pts[static_cast<std::size_t>(b)];
    const double u = p.x / xs, v = p.y / ys;
    for (Eigen::Index t = 0; t < np; ++t) {
      const int i = mono[static_cast<std::size_t>(t)][0], j = mono[static_cast<std::size_t>(t)][1];
      A(b, t) = std::pow(u, i) * std::pow(v, j);
      Ax(b, t) = i == 0 ? 0.0 : i * std::pow(u, i - 1) * std::pow(v, j) / xs;
      Ay(b, t) = j == 0 ? 0.0 : j * std::pow(u, i) * std::pow(v, j - 1) / ys;
    }
    E(b) = p.E;
  }
  model = E;
  target = E;
  for (int it = 0; it < std::max(1, iterations); ++it) {
    for (Eigen::Index b = 0; b < n; ++b)
      w(b) = 1.0 / (model(b) * pts[static_cast<std::size_t>(b)].rel(model(b)));
    coef = (w.asDiagonal() * A).colPivHouseholderQr().solve(w.cwiseProduct(target));
    const Eigen::VectorXd fitted = A * coef, gx = Ax * coef, gy = Ay * coef;
    for (Eigen::Index b = 0; b < n; ++b) {
      const Point &p = pts[static_cast<std::size_t>(b)];
      const bool usable = fitted(b) > 0.0 && std::isfinite(fitted(b));
      model(b) = usable ? fitted(b) : E(b);
      const double spread =
          gx(b) * gx(b) * p.vx + 2.0 * gx(b) * gy(b) * p.cxy + gy(b) * gy(b) * p.vy;
      target(b) = usable ? E(b) * (1.0 + spread / (model(b) * model(b))) : E(b);
    }
  }
  const Eigen::VectorXd fitted = A * coef;
  double chi2 = 0.0;
  for (Eigen::Index b = 0; b < n; ++b) chi2 += std::pow((target(b) - fitted(b)) * w(b), 2);
  out.Km = coef(0) / xs;
  out.K3 = coef(1) / ys;
  for (Eigen::Index t = 0; t < np; ++t) {
    const int i = mono[static_cast<std::size_t>(t)][0], j = mono[static_cast<std::size_t>(t)][1];
    out.terms.push_back({static_cast<double>(i), static_cast<double>(j),
                         coef(t) / (std::pow(xs, i) * std::pow(ys, j))});
  }
  out.chi2 = chi2 / static_cast<double>(n - np);
  return out;
}

// The eight numbers one data set gives: plane {K1, K3_13, K2, K3_23}, then the cubic's.
using Values = std::array<double, 8>;

struct DataFit {
  Values values;
  std::array<ModelValues, 4> detail;  // plane 13, plane 23, cubic 13, cubic 23
};

DataFit fit_data(const FrankBlock &data, double volume, const FrankFitOptions &o,
                 const std::set<FrankBinKey> *allowed) {
  const std::vector<Point> p13 = e_points(data, 1, volume, o, allowed),
                           p23 = e_points(data, 2, volume, o, allowed);
  DataFit f;
  f.detail = {fit_model(p13, false, o.planar_max_k2, o.reweighting_iterations),
              fit_model(p23, false, o.planar_max_k2, o.reweighting_iterations),
              fit_model(p13, true, o.cubic_max_k2, o.reweighting_iterations),
              fit_model(p23, true, o.cubic_max_k2, o.reweighting_iterations)};
  for (std::size_t t = 0; t < 4; ++t) {
    f.values[2 * t] = f.detail[t].Km;
    f.values[2 * t + 1] = f.detail[t].K3;
  }
  return f;
}

// Error of each value from replicas: runs (sd / sqrt(n)) or jackknife ((n-1)/n sum dev^2).
double replica_error(const std::vector<double> &r, bool jackknife) {
  const double n = static_cast<double>(r.size());
  if (r.size() < 2) return kNaN;
  double mean = 0.0;
  for (double v : r) mean += v;
  mean /= n;
  double ss = 0.0;
  for (double v : r) ss += (v - mean) * (v - mean);
  return jackknife ? std::sqrt(ss * (n - 1.0) / n) : std::sqrt(ss / (n - 1.0) / n);
}

}  // namespace

FrankResult fit_frank(const std::vector<FrankAccumulator> &runs, const FrankFitOptions &options) {
  if (runs.empty()) throw std::invalid_argument("fit_frank: no runs given");
  FrankAccumulator merged = runs.front();
  for (std::size_t r = 1; r < runs.size(); ++r) merged += runs[r];
  const double volume = merged.box().volume();
  const FrankBlock total = merged.total();

  FrankResult result;
  result.samples = total.samples;
  result.runs = static_cast<int>(runs.size());
  result.mean_S2 = total.samples > 0 ? total.sum_S2 / static_cast<double>(total.samples) : kNaN;
  result.kT = options.kT;
  result.self_term_subtracted = options.subtract_self_term;
  const DataFit central = fit_data(total, volume, options, nullptr);
  std::set<FrankBinKey> allowed;  // bins of the central fit, for the replicas
  for (const auto &[key, bin] : total.bins)
    if (bin.count >= std::max(2LL, options.min_bin_count)) allowed.insert(key);

  std::vector<Values> replicas;
  const bool jackknife = runs.size() == 1;
  if (!jackknife) {
    for (const FrankAccumulator &run : runs)
      replicas.push_back(fit_data(run.total(), volume, options, &allowed).values);
    result.error_method = "spread over runs / sqrt(runs)";
  } else if (merged.blocks().size() >= 2) {
    for (const FrankBlock &block : merged.blocks()) {
      FrankBlock rest = total;
      rest -= block;
      replicas.push_back(fit_data(rest, volume, options, &allowed).values);
    }
    result.error_method = "jackknife over blocks";
  } else {
    result.error_method = "none";
  }
  result.replicas = static_cast<int>(replicas.size());

  Values errors;
  for (std::size_t v = 0; v < 8; ++v) {
    std::vector<double> r;
    r.reserve(replicas.size());
    for (const Values &rep : replicas) r.push_back(rep[v]);
    errors[v] = replica_error(r, jackknife);
  }
  auto fill = [&](FrankModelFit &fit, std::size_t offset, std::size_t detail) {
    fit.K1 = {central.values[offset], errors[offset]};
    fit.K3_13 = {central.values[offset + 1], errors[offset + 1]};
    fit.K2 = {central.values[offset + 2], errors[offset + 2]};
    fit.K3_23 = {central.values[offset + 3], errors[offset + 3]};
    fit.bins_13 = central.detail[detail].bins, fit.chi2_13 = central.detail[detail].chi2;
    fit.bins_23 = central.detail[detail + 1].bins, fit.chi2_23 = central.detail[detail + 1].chi2;
    fit.terms_13 = central.detail[detail].terms;
    fit.terms_23 = central.detail[detail + 1].terms;
    // Combined K3 with fixed inverse-variance weights, applied to every replica too, so its
    // error includes the correlation of the two estimates.
    double w13 = 0.5;
    const double v13 = fit.K3_13.error * fit.K3_13.error, v23 = fit.K3_23.error * fit.K3_23.error;
    if (v13 > 0.0 && v23 > 0.0 && std::isfinite(v13 + v23)) w13 = v23 / (v13 + v23);
    auto combine = [&](const Values &v) {
      return w13 * v[offset + 1] + (1.0 - w13) * v[offset + 3];
    };
    std::vector<double> r;
    r.reserve(replicas.size());
    for (const Values &rep : replicas) r.push_back(combine(rep));
    fit.K3 = {combine(central.values), replica_error(r, jackknife)};
  };
  fill(result.planar, 0, 0);
  fill(result.cubic, 4, 2);

  for (int m = 1; m <= 2; ++m)
    for (const Point &p : e_points(total, m, volume, options, nullptr))
      (m == 1 ? result.E13 : result.E23).push_back({p.x, p.y, p.E, p.E * p.rel(p.E), p.count});
  return result;
}

nlohmann::json to_json(const FrankResult &r) {
  auto num = [](double v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(); };
  auto est = [&](const FrankEstimate &e) {
    return nlohmann::json{{"value", num(e.value)}, {"error", num(e.error)}};
  };
  auto model = [&](const FrankModelFit &f) {
    return nlohmann::json{{"K1", est(f.K1)},
                          {"K2", est(f.K2)},
                          {"K3", est(f.K3)},
                          {"K3_from_E13", est(f.K3_13)},
                          {"K3_from_E23", est(f.K3_23)},
                          {"bins_E13", f.bins_13},
                          {"bins_E23", f.bins_23},
                          {"chi2_per_dof_E13", num(f.chi2_13)},
                          {"chi2_per_dof_E23", num(f.chi2_23)},
                          {"terms_E13", f.terms_13},
                          {"terms_E23", f.terms_23}};
  };
  auto table = [&](const std::vector<FrankBinE> &bins) {
    nlohmann::json t = nlohmann::json::array();
    for (const FrankBinE &b : bins) t.push_back({b.k1sq, b.k3sq, num(b.E), num(b.error), b.count});
    return t;
  };
  return {{"planar", model(r.planar)},
          {"cubic", model(r.cubic)},
          {"mean_S2", num(r.mean_S2)},
          {"kT", r.kT},
          {"self_term_subtracted", r.self_term_subtracted},
          {"samples", r.samples},
          {"runs", r.runs},
          {"replicas", r.replicas},
          {"error_method", r.error_method},
          {"bin_columns", {"k1sq", "k3sq", "E", "error", "count"}},
          {"E13", table(r.E13)},
          {"E23", table(r.E23)}};
}

}  // namespace hardrod
