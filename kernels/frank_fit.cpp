// Frank constants from binned <|Qk_m3|^2> (see the header). A white background B (molecular
// disorder) adds to <|Q|^2>: 1/E_obs = 1/E + b, b = B/c, c = (9/4) S^2 V kT. Per bin, E is
// corrected to second order for the bias of 1/<|Q|^2> and for the spread of (k1^2, k3^2)
// within the bin.
#include "kernels/frank_fit.hpp"

// GCC 12 reports -Wmaybe-uninitialized inside its own avx512fintrin.h (_mm256_undefined_pd,
// GCC bug 105593) for Eigen's vectorised reductions in the QR below: a false positive.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#include <Eigen/Dense>
#pragma GCC diagnostic pop
#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <set>
#include <stdexcept>
#include <utility>

namespace hardrod {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double mean_of(const FrankBin &bin, int m) {
  return (m == 1 ? bin.q13 : bin.q23) / double(bin.count);
}
double self_of(const FrankBin &bin, int m) {
  return (m == 1 ? bin.self13 : bin.self23) / double(bin.count);
}

// ---- the bins' variances -------------------------------------------------------------------

// Replicas for the bin variances: the runs, or consecutive stretches of a single run.
std::vector<FrankBlock> replica_data(const std::vector<FrankAccumulator> &runs, int groups) {
  std::vector<FrankBlock> out;
  if (runs.size() >= 2) {
    for (const FrankAccumulator &r : runs) out.push_back(r.total());
    return out;
  }
  const auto &blocks = runs.front().blocks();
  const std::size_t g = std::min(blocks.size(), static_cast<std::size_t>(std::max(groups, 1)));
  if (g < 2) return out;
  out.resize(g);
  for (std::size_t b = 0; b < blocks.size(); ++b) out[b * g / blocks.size()] += blocks[b];
  return out;
}

// phi_b = n_b var(mean) / mean^2 of one bin from the replicas' means: {phi_hat, dof}, dof 0
// where fewer than two replicas hold it.
std::pair<double, double> bin_inflation(const FrankBlock &total,
                                        const std::vector<FrankBlock> &replicas, int m,
                                        const FrankBinKey &key) {
  const double ybar = mean_of(total.bins.at(key), m);
  double ss = 0.0, used = 0.0;
  for (const FrankBlock &r : replicas) {
    const auto it = r.bins.find(key);
    if (it == r.bins.end() || it->second.count < 1) continue;
    const double d = mean_of(it->second, m) - ybar;
    ss += double(it->second.count) * d * d;
    used += 1.0;
  }
  if (used < 2.0 || !(ybar > 0.0)) return {kNaN, 0.0};
  return {ss / ((used - 1.0) * ybar * ybar), used - 1.0};
}

using BinInflations = std::map<FrankBinKey, std::pair<double, double>>;

// bin_inflation of every bin of `keys`, for one component.
BinInflations bin_inflations(const FrankBlock &total, const std::vector<FrankBlock> &replicas,
                             int m, const std::set<FrankBinKey> &keys) {
  BinInflations out;
  for (const FrankBinKey &key : keys) out[key] = bin_inflation(total, replicas, m, key);
  return out;
}

// The bins' phi_hat (bin_inflations) fitted by phi = g0 + g1 u with u = <|Q|^2> / c = 1 / E_obs
// (weighted least squares, weights (replicas - 1) / phi_model^2, the variance of a sample
// variance; g0, g1 >= 0).
FrankVarianceModel variance_model(const FrankBlock &total, const BinInflations &inflations, int m,
                                  double c, const std::set<FrankBinKey> &bins) {
  std::vector<std::array<double, 3>> data;  // u, phi_hat, dof
  for (const FrankBinKey &key : bins) {
    const auto [phi, dof] = inflations.at(key);
    if (dof > 0.0) data.push_back({mean_of(total.bins.at(key), m) / c, phi, dof});
  }
  FrankVarianceModel model;
  model.bins = static_cast<int>(data.size());
  if (data.size() < 3) return model;
  double g0 = 0.0, g1 = 0.0;
  for (const auto &d : data) g0 += d[1];
  g0 /= double(data.size());
  for (int it = 0; it < 6; ++it) {
    double s = 0, su = 0, suu = 0, sp = 0, sup = 0;
    for (const auto &[u, phi, dof] : data) {
      const double w = dof / std::pow(std::max(g0 + g1 * u, 1e-12), 2);
      s += w, su += w * u, suu += w * u * u, sp += w * phi, sup += w * u * phi;
    }
    const double det = s * suu - su * su;
    double a = det > 0.0 ? (sp * suu - su * sup) / det : sp / s;
    double b = det > 0.0 ? (s * sup - su * sp) / det : 0.0;
    if (b < 0.0) a = sp / s, b = 0.0;
    if (a < 0.0) a = 0.0, b = sup / suu;
    g0 = a, g1 = b;
  }
  model.g0 = g0, model.g1 = g1;
  return model;
}

// Without replicas: the samples taken as independent, phi = the pooled squared coefficient of
// variation of |Q|^2 within the bins (1 for Gaussian modes).
FrankVarianceModel independent_samples_model(const FrankBlock &total, int m,
                                             const std::set<FrankBinKey> &bins) {
  double sum = 0.0, dof = 0.0;
  for (const FrankBinKey &key : bins) {
    const FrankBin &bin = total.bins.at(key);
    const double n = double(bin.count), mean = mean_of(bin, m);
    const double meansq = (m == 1 ? bin.q13sq : bin.q23sq) / n;
    if (n < 2.0 || !(mean > 0.0)) continue;
    sum += std::max(0.0, meansq - mean * mean) * n / (mean * mean);
    dof += n - 1.0;
  }
  FrankVarianceModel model;
  model.bins = static_cast<int>(bins.size());
  if (dof > 0.0) model.g0 = sum / dof, model.g1 = 0.0;
  return model;
}

// ---- points --------------------------------------------------------------------------------

struct Point {
  double x, y;         // mean k1^2, k3^2 of the bin
  double vx, cxy, vy;  // (co)variances of k1^2, k3^2 within the bin
  double E;            // c / (<|Q|^2> - self), ratio bias removed
  double n;            // k vectors x samples
  double u;            // <|Q|^2> / c, for the variance model
  double background;   // subtracted self term / c (0 without subtraction)
  FrankBinKey key;
  // Relative error of E when the truth is E_model: that of <|Q|^2>, sqrt(phi / n), amplified
  // by <|Q|^2> / (<|Q|^2> - self) = 1 + background E_model.
  double rel(const FrankVarianceModel &v, double E_model) const {
    return std::sqrt((v.g0 + v.g1 * u) / n) * (1.0 + background * E_model);
  }
};

// E_m3 per bin of `data` for the bins in `keys` (those present with >= 2 k vectors).
std::vector<Point> e_points(const FrankBlock &data, int m, double c, const FrankFitOptions &o,
                            const FrankVarianceModel &v, const std::set<FrankBinKey> &keys) {
  std::vector<Point> points;
  for (const FrankBinKey &key : keys) {
    const auto it = data.bins.find(key);
    if (it == data.bins.end() || it->second.count < 2) continue;
    const FrankBin &bin = it->second;
    const double n = double(bin.count), mean = mean_of(bin, m);
    const double self = o.subtract_self_term ? self_of(bin, m) : 0.0;
    if (!(mean - self > 0.0) || !std::isfinite(mean)) continue;
    const double x = bin.k1sq / n, y = bin.k3sq / n;
    Point p{x,
            y,
            std::max(0.0, bin.k1sq_sq / n - x * x),
            bin.k1sq_k3sq / n - x * y,
            std::max(0.0, bin.k3sq_sq / n - y * y),
            c / (mean - self),
            n,
            mean / c,
            self / c,
            key};
    // E[1/mean] = (1/mu)(1 + rel^2 + ...). A bin with rel > 1/2 (fewer than four effective
    // samples) has a skewed, heavy-tailed ratio that no second-order correction repairs: left out.
    const double rel = p.rel(v, p.E);
    if (!(rel <= o.max_bin_relative_error)) continue;
    p.E /= 1.0 + rel * rel;
    points.push_back(p);
  }
  return points;
}

// The central bins: enough k vectors, and with the self term subtracted, a self term below
// half the signal.
std::set<FrankBinKey> central_bins(const FrankBlock &total, const FrankFitOptions &o) {
  std::set<FrankBinKey> keys;
  for (const auto &[key, bin] : total.bins) {
    if (bin.count < std::max(2LL, o.min_bin_count)) continue;
    if (o.subtract_self_term &&
        !(self_of(bin, 1) < 0.5 * mean_of(bin, 1) && self_of(bin, 2) < 0.5 * mean_of(bin, 2)))
      continue;
    keys.insert(key);
  }
  return keys;
}

// ---- the models ----------------------------------------------------------------------------

enum class Model { kPlanar, kCubic, kBackground };

struct Range {
  double max_x, max_y;
  bool open;  // x < max (planar) or x <= max (cubic)
  bool contains(const Point &p) const {
    return open ? p.x < max_x && p.y < max_y : p.x <= max_x && p.y <= max_y;
  }
};

Range range_of(Model model, const FrankFitOptions &o) {
  return model == Model::kPlanar ? Range{o.planar_max_k2, o.planar_max_k2, true}
                                 : Range{o.cubic_max_k1sq, o.cubic_max_k3sq, false};
}

// Monomials x^i y^j of P; the first two are (1, 0) and (0, 1): K_m and K3. The plane; the
// cubic sum_{1 <= i+j; i, j <= 3}; the background model's quadratic (the Frank terms and the
// next order in k^2, which the saturation 1/b at large k cannot mimic).
std::vector<std::array<int, 2>> monomials(Model model) {
  std::vector<std::array<int, 2>> mono = {{1, 0}, {0, 1}};
  const int most = model == Model::kCubic ? 3 : model == Model::kBackground ? 2 : 1;
  for (int i = 0; i <= most; ++i)
    for (int j = 0; j <= most; ++j)
      if (i + j >= 2 && (model == Model::kCubic || i + j <= most)) mono.push_back({i, j});
  return mono;
}

struct ModelValues {
  FrankEstimate Km, K3, b;
  double chi2 = kNaN;  // per degree of freedom
  int bins = 0, dof = 0;
  std::vector<std::array<double, 3>> terms;  // (i, j, a_ij): P = sum a x^i y^j
};

// The fitted function: P = sum_t p_t x^i y^j over `mono`, E = P / (1 + b P) (b = 0: none).
struct Evaluator {
  const std::vector<std::array<int, 2>> &mono;
  double xs, ys;  // column scales
  bool with_b;
  // E and its gradient in the parameters (p..., then b), and dE/dx, dE/dy.
  double operator()(const Point &pt, const Eigen::VectorXd &p, Eigen::VectorXd *grad, double *dx,
                    double *dy) const {
    const double u = pt.x / xs, v = pt.y / ys;
    double P = 0.0, Px = 0.0, Py = 0.0;
    const auto np = static_cast<Eigen::Index>(mono.size());
    for (Eigen::Index t = 0; t < np; ++t) {
      const int i = mono[size_t(t)][0], j = mono[size_t(t)][1];
      const double f = std::pow(u, i) * std::pow(v, j);
      if (grad) (*grad)(t) = f;
      P += p(t) * f;
      if (i > 0) Px += p(t) * i * std::pow(u, i - 1) * std::pow(v, j) / xs;
      if (j > 0) Py += p(t) * j * std::pow(u, i) * std::pow(v, j - 1) / ys;
    }
    const double b = with_b ? p(np) : 0.0, d = 1.0 / (1.0 + b * P), d2 = d * d;
    if (grad) {
      grad->head(np) *= d2;
      if (with_b) (*grad)(np) = -P * P * d2;
    }
    *dx = Px * d2, *dy = Py * d2;
    return P * d;
  }
};

// The weighted least-squares problem of one fit: chi^2 = sum_b ((target_b - E(pt_b)) /
// sigma_b)^2 over the points, with its Jacobian and residuals when asked.
struct LeastSquares {
  const std::vector<Point> &pts;
  const Evaluator &eval;
  Eigen::Index np;  // parameters
  Eigen::VectorXd sigma, target;

  double chi2(const Eigen::VectorXd &q, Eigen::MatrixXd *J, Eigen::VectorXd *r) const {
    double sum = 0.0, dx, dy;
    Eigen::VectorXd g(np);
    for (Eigen::Index b = 0; b < sigma.size(); ++b) {
      const double res = (target(b) - eval(pts[size_t(b)], q, &g, &dx, &dy)) / sigma(b);
      sum += res * res;
      if (J) J->row(b) = g.transpose() / sigma(b), (*r)(b) = res;
    }
    return sum;
  }

  // Gauss-Newton with damping (Levenberg-Marquardt) from p: exact in one step for the
  // polynomials (E linear in p). Leaves J and r at the final p; returns its chi^2.
  double solve(Eigen::VectorXd &p, bool with_b, Eigen::MatrixXd &J, Eigen::VectorXd &r) const {
    double lambda = with_b ? 1e-3 : 0.0;
    double c = chi2(p, &J, &r);
    for (int it = 0; it < (with_b ? 60 : 1); ++it) {
      Eigen::MatrixXd A = J.transpose() * J;
      A.diagonal() *= 1.0 + lambda;
      const Eigen::VectorXd step = A.ldlt().solve(J.transpose() * r);
      Eigen::VectorXd trial = p + step;
      if (with_b) trial(np - 1) = std::max(0.0, trial(np - 1));  // a background adds to <|Q|^2>
      const double c2 = chi2(trial, nullptr, nullptr);
      if (c2 <= c || !with_b) {
        const bool converged = c - c2 < 1e-10 * (1.0 + c);
        p = trial, lambda *= 0.3;
        c = chi2(p, &J, &r);
        if (converged) break;
      } else {
        lambda = std::max(lambda * 10.0, 1e-6);
      }
    }
    return c;
  }

  // New weights 1 / (E_model rel(E_model))^2 and targets from the fit p: each bin's E
  // corrected for the spread of the model over the bin.
  void reweight(const Eigen::VectorXd &p, const FrankVarianceModel &v) {
    for (Eigen::Index b = 0; b < sigma.size(); ++b) {
      const Point &pt = pts[size_t(b)];
      double dx, dy;
      const double m = eval(pt, p, nullptr, &dx, &dy);
      const bool usable = m > 0.0 && std::isfinite(m);
      const double E = usable ? m : pt.E;
      sigma(b) = E * pt.rel(v, E);
      const double spread = dx * dx * pt.vx + 2.0 * dx * dy * pt.cxy + dy * dy * pt.vy;
      target(b) = usable ? pt.E * (1.0 + spread / (m * m)) : pt.E;
    }
  }
};

// Weighted least squares of E over the points in `range` with the Gauss-Newton /
// Levenberg-Marquardt iteration (a single linear solve per reweighting for the polynomial
// models). Weights 1 / (E_model rel(E_model))^2 from the previous iterate; the target is each
// bin's E corrected for the spread of the model over the bin (<1/E> over a bin of finite width:
// E_mean (1 - var(E) / E^2), var(E) = g^T C g).
ModelValues fit_model(const std::vector<Point> &all, Model model, const FrankFitOptions &o,
                      const FrankVarianceModel &v) {
  const Range range = range_of(model, o);
  std::vector<Point> pts;
  double xs = 0.0, ys = 0.0;
  for (const Point &p : all)
    if (range.contains(p)) pts.push_back(p), xs = std::max(xs, p.x), ys = std::max(ys, p.y);
  const auto mono = monomials(model);
  const bool with_b = model == Model::kBackground;
  const auto np = static_cast<Eigen::Index>(mono.size()) + (with_b ? 1 : 0);
  const auto n = static_cast<Eigen::Index>(pts.size());
  ModelValues out;
  out.bins = static_cast<int>(n);
  out.dof = static_cast<int>(n - np);
  if (n <= np || !(xs > 0.0) || !(ys > 0.0) || !std::isfinite(v.g0)) return out;
  const Evaluator eval{mono, xs, ys, with_b};

  Eigen::VectorXd p = Eigen::VectorXd::Zero(np);
  if (with_b) {  // start from the plane (b = 0), where the gradient in b is not zero
    const ModelValues plane = fit_model(pts, Model::kPlanar, o, v);
    if (!std::isfinite(plane.Km.value) || !std::isfinite(plane.K3.value)) return out;
    p(0) = plane.Km.value * xs, p(1) = plane.K3.value * ys;
  }
  LeastSquares ls{pts, eval, np, Eigen::VectorXd(n), Eigen::VectorXd(n)};
  for (Eigen::Index b = 0; b < n; ++b) {
    const Point &pt = pts[size_t(b)];
    ls.target(b) = pt.E;
    ls.sigma(b) = pt.E * pt.rel(v, pt.E);
  }
  Eigen::MatrixXd J(n, np);
  Eigen::VectorXd r(n);
  double chi2 = 0.0;
  for (int reweight = 0; reweight < std::max(1, o.reweighting_iterations); ++reweight) {
    ls.solve(p, with_b, J, r);
    ls.reweight(p, v);
    chi2 = ls.chi2(p, &J, &r);
  }
  const Eigen::MatrixXd cov = (J.transpose() * J).inverse();
  out.chi2 = chi2 / double(out.dof);
  const double inflate = std::sqrt(std::max(1.0, out.chi2));
  auto estimate = [&](Eigen::Index t, double scale) {
    return FrankEstimate{p(t) / scale, std::sqrt(std::max(0.0, cov(t, t))) / scale * inflate, kNaN};
  };
  out.Km = estimate(0, xs);
  out.K3 = estimate(1, ys);
  if (with_b) out.b = estimate(np - 1, 1.0);
  for (size_t t = 0; t < mono.size(); ++t)
    out.terms.push_back(
        {double(mono[t][0]), double(mono[t][1]),
         p(Eigen::Index(t)) / (std::pow(xs, mono[t][0]) * std::pow(ys, mono[t][1]))});
  return out;
}

// ---- one data set, all fits ----------------------------------------------------------------

constexpr std::array<Model, 3> kModels = {Model::kPlanar, Model::kCubic, Model::kBackground};

// Fits of E_13 ([0][model]) and E_23 ([1][model]).
using AllFits = std::array<std::array<ModelValues, 3>, 2>;

AllFits fit_all(const FrankBlock &data, double volume, const FrankFitOptions &o,
                const std::array<FrankVarianceModel, 2> &v, const std::set<FrankBinKey> &keys) {
  AllFits fits;
  if (data.samples <= 0) return fits;
  const double c = 2.25 * (data.sum_S2 / double(data.samples)) * volume * o.kT;
  for (int m = 1; m <= 2; ++m) {
    const std::vector<Point> pts = e_points(data, m, c, o, v[size_t(m - 1)], keys);
    for (size_t k = 0; k < kModels.size(); ++k)
      fits[size_t(m - 1)][k] = fit_model(pts, kModels[k], o, v[size_t(m - 1)]);
  }
  return fits;
}

// sd / sqrt(n) of independent replicas' estimates, without those more than five robust
// standard deviations (1.4826 median absolute deviations) from the median: one replica's fit
// that ran away should not decide the spread of the others.
double spread_error(const std::vector<double> &r) {
  std::vector<double> finite;
  for (double x : r)
    if (std::isfinite(x)) finite.push_back(x);
  if (finite.size() < 2) return kNaN;
  auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    const size_t h = v.size() / 2;
    return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
  };
  const double mid = median(finite);
  std::vector<double> dev;
  for (double x : finite) dev.push_back(std::fabs(x - mid));
  const double mad = median(dev);
  std::vector<double> ok;
  for (double x : finite)
    if (finite.size() < 3 || !(mad > 0.0) || std::fabs(x - mid) <= 5.0 * 1.4826 * mad)
      ok.push_back(x);
  if (ok.size() < 2) return kNaN;
  double mean = 0.0, ss = 0.0;
  for (double x : ok) mean += x;
  mean /= double(ok.size());
  for (double x : ok) ss += (x - mean) * (x - mean);
  return std::sqrt(ss / double(ok.size() - 1) / double(ok.size()));
}

// Determined: positive, with a finite error smaller than the value itself.
bool physical(const FrankEstimate &e) {
  return std::isfinite(e.value) && e.value > 0.0 && std::isfinite(e.error) && e.error > 0.0 &&
         e.error < e.value;
}

// The model's entry of FrankResult from the central fits and the replicas'.
FrankModelFit assemble(const AllFits &central, const std::vector<AllFits> &replicas, size_t k) {
  FrankModelFit f;
  const ModelValues &a = central[0][k], &b = central[1][k];
  auto with_spread = [&](FrankEstimate e, int m, bool k3) {
    std::vector<double> r;
    for (const AllFits &rep : replicas) {
      const FrankEstimate &x = k3 ? rep[size_t(m)][k].K3 : rep[size_t(m)][k].Km;
      r.push_back(physical(x) ? x.value : kNaN);
    }
    e.spread = spread_error(r);
    return e;
  };
  f.K1 = with_spread(a.Km, 0, false), f.K3_13 = with_spread(a.K3, 0, true);
  f.K2 = with_spread(b.Km, 1, false), f.K3_23 = with_spread(b.K3, 1, true);
  f.bins_13 = a.bins, f.bins_23 = b.bins, f.dof_13 = a.dof, f.dof_23 = b.dof;
  f.chi2_13 = a.chi2, f.chi2_23 = b.chi2;
  f.background_13 = a.b, f.background_23 = b.b;
  f.terms_13 = a.terms, f.terms_23 = b.terms;
  // K3: the two estimates are independent (Q_13 and Q_23 modes are): inverse-variance mean,
  // or the one that is determined.
  if (physical(f.K3_13) != physical(f.K3_23)) {
    f.K3 = physical(f.K3_13) ? f.K3_13 : f.K3_23;
  } else if (physical(f.K3_13) && physical(f.K3_23)) {
    const double w13 = 1.0 / (f.K3_13.error * f.K3_13.error),
                 w23 = 1.0 / (f.K3_23.error * f.K3_23.error);
    f.K3.value = (w13 * f.K3_13.value + w23 * f.K3_23.value) / (w13 + w23);
    f.K3.error = 1.0 / std::sqrt(w13 + w23);
    std::vector<double> r;
    for (const AllFits &rep : replicas)
      r.push_back(physical(rep[0][k].K3) && physical(rep[1][k].K3)
                      ? (w13 * rep[0][k].K3.value + w23 * rep[1][k].K3.value) / (w13 + w23)
                      : kNaN);
    f.K3.spread = spread_error(r);
  }
  for (FrankEstimate *e : {&f.K1, &f.K2, &f.K3, &f.K3_13, &f.K3_23}) {
    if (!physical(*e)) {
      *e = FrankEstimate{};  // never a negative K or a zero error
      continue;
    }
    e->fit_error = e->error;
    if (replicas.size() >= 3 && std::isfinite(e->spread)) e->error = std::max(e->error, e->spread);
  }
  return f;
}

}  // namespace

double FrankModelFit::chi2_dof() const {
  double chi2 = 0.0;
  int dof = 0;
  if (dof_13 > 0 && std::isfinite(chi2_13)) chi2 += chi2_13 * dof_13, dof += dof_13;
  if (dof_23 > 0 && std::isfinite(chi2_23)) chi2 += chi2_23 * dof_23, dof += dof_23;
  return dof > 0 ? chi2 / dof : kNaN;
}

FrankResult fit_frank(const std::vector<FrankAccumulator> &runs, const FrankFitOptions &options) {
  if (runs.empty()) throw std::invalid_argument("fit_frank: no runs given");
  FrankAccumulator merged = runs.front();
  for (size_t r = 1; r < runs.size(); ++r) merged += runs[r];
  const double volume = merged.box().volume();
  const FrankBlock total = merged.total();

  FrankResult result;
  result.samples = total.samples;
  result.runs = static_cast<int>(runs.size());
  result.options = options;
  result.error_method = "none";
  if (total.samples <= 0) return result;
  result.mean_S2 = total.sum_S2 / double(total.samples);
  const double c = 2.25 * result.mean_S2 * volume * options.kT;

  const std::set<FrankBinKey> keys = central_bins(total, options);
  std::set<FrankBinKey> fitted;  // the variance model is fitted on the bins some fit uses
  for (const FrankBinKey &key : keys) {
    const FrankBin &bin = total.bins.at(key);
    const Point p{
        bin.k1sq / double(bin.count), bin.k3sq / double(bin.count), 0, 0, 0, 0, 0, 0, 0, key};
    if (range_of(Model::kCubic, options).contains(p) ||
        range_of(Model::kPlanar, options).contains(p))
      fitted.insert(key);
  }
  const std::vector<FrankBlock> replicas = replica_data(runs, options.replica_groups);
  result.replicas = static_cast<int>(replicas.size());
  std::array<FrankVarianceModel, 2> v;
  std::array<BinInflations, 2> inflations;
  for (int m = 1; m <= 2; ++m) {
    if (replicas.size() >= 2) inflations[size_t(m - 1)] = bin_inflations(total, replicas, m, keys);
    v[size_t(m - 1)] = replicas.size() >= 2
                           ? variance_model(total, inflations[size_t(m - 1)], m, c, fitted)
                           : independent_samples_model(total, m, fitted);
  }
  if (replicas.size() >= 2)
    result.error_method = runs.size() >= 2
                              ? "bin variances from the spread over runs"
                              : "bin variances from the spread over stretches of the run";
  else
    result.error_method =
        "samples taken as independent (one run, too few blocks): errors too small";
  result.variance_13 = v[0], result.variance_23 = v[1];

  const AllFits central = fit_all(total, volume, options, v, keys);
  std::vector<AllFits> replica_fits;
  for (const FrankBlock &r : replicas) replica_fits.push_back(fit_all(r, volume, options, v, keys));
  result.planar = assemble(central, replica_fits, 0);
  result.cubic = assemble(central, replica_fits, 1);
  result.background = assemble(central, replica_fits, 2);

  for (int m = 1; m <= 2; ++m)
    for (const Point &p : e_points(total, m, c, options, v[size_t(m - 1)], keys))
      (m == 1 ? result.E13 : result.E23)
          .push_back({p.x, p.y, p.E, p.E * p.rel(v[size_t(m - 1)], p.E), (long long)p.n,
                      replicas.size() >= 2 ? inflations[size_t(m - 1)].at(p.key).first : kNaN});
  return result;
}

namespace {

// n var(mean) / var of n consecutive samples of |Q|^2 whose amplitude lives tau samples (their
// |Q|^2 then correlate as rho = exp(-2 / tau) per sample): coth(1 / tau) for n -> infinity,
// n for tau -> infinity.
double finite_run_inflation(double tau, double n) {
  const double rho = std::exp(-2.0 / tau);
  return (1.0 + rho) / (1.0 - rho) -
         2.0 * rho * (1.0 - std::pow(rho, n)) / (n * (1.0 - rho) * (1.0 - rho));
}

// Its inverse in tau by bisection on log tau; infinity where phi is at or beyond 95 % of the
// saturation n (the mode outlives the replicas: only a lower bound is known).
double lifetime_from_inflation(double phi, double n) {
  if (!(phi > 1.0)) return 0.0;
  if (phi >= 0.95 * n) return std::numeric_limits<double>::infinity();
  double lo = std::log(1e-3), hi = std::log(1e3 * n);
  for (int it = 0; it < 100; ++it) {
    const double mid = 0.5 * (lo + hi);
    (finite_run_inflation(std::exp(mid), n) < phi ? lo : hi) = mid;
  }
  return std::exp(0.5 * (lo + hi));
}

}  // namespace

// The slow end: among the well-populated bins (at least the median count; a wandering
// director leaves sparse, noisy bins below the lowest real mode), the smallest E, and a
// lifetime pooled over the bins up to twice that E as tau_b E_b = const (a mode relaxes at a
// rate ~ K k^2), weighted by count: one bin's phi from six replicas is uncertain by ~60 %.
// Each bin's tau from its phi over replicas of finite length (finite_run_inflation).
FrankSlowestMode slowest_mode(const FrankResult &r) {
  FrankSlowestMode out;
  std::vector<const FrankBinE *> bins;
  std::vector<long long> counts;
  for (const auto *list : {&r.E13, &r.E23})
    for (const FrankBinE &b : *list) bins.push_back(&b), counts.push_back(b.count);
  if (bins.empty()) return out;
  std::nth_element(counts.begin(), counts.begin() + counts.size() / 2, counts.end());
  const long long median = counts[counts.size() / 2];
  for (std::size_t i = 0; i < bins.size(); ++i)
    if (bins[i]->count >= median && bins[i]->E > 0.0 && !(bins[i]->E >= out.E))
      out.E = bins[i]->E, out.k1sq = bins[i]->k1sq, out.k3sq = bins[i]->k3sq,
      out.component = i < r.E13.size() ? 1 : 2;
  out.replica_samples = r.replicas > 0 ? double(r.samples) / r.replicas : kNaN;
  double weight = 0.0, sum = 0.0;
  for (const FrankBinE *b : bins) {
    if (b->count < median || !(b->E <= 2.0 * out.E) || !std::isfinite(b->phi)) continue;
    const double tau = lifetime_from_inflation(b->phi, out.replica_samples);
    sum += double(b->count) * tau * b->E, weight += double(b->count);
  }
  if (weight > 0.0) {
    out.lifetime_samples = sum / weight / out.E;
    out.outlives_replicas = std::isinf(out.lifetime_samples);
    if (out.outlives_replicas) out.lifetime_samples = out.replica_samples;
  }
  return out;
}

}  // namespace hardrod
