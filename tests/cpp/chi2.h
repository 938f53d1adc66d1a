// Chi-square goodness-of-fit tests for sampling routines, in the style of
// Mitsuba 3's ChiSquareTest (mitsuba/python/chi2.py):
//
//  1. the domain (the sphere of directions, parameterised by (phi, cos theta),
//     or a rectangle of the plane) is cut into a grid of bins; on the sphere the
//     grid is uniform in phi and cos theta, so every bin has the same solid
//     angle and d(omega) = d(cos theta) d(phi) needs no Jacobian;
//  2. N samples are drawn and histogrammed; samples the sampler rejects and,
//     for mixed BSDFs, delta samples go into one extra "other" bin;
//  3. the expected count of a bin is N times the integral of the pdf over it,
//     computed by 2D h-adaptive Gauss-Legendre quadrature (each cell is
//     compared with the sum of its four children, and refined until they
//     agree); the other bin expects N (1 - integral of the pdf over the whole
//     domain);
//  4. bins expecting fewer than 5 samples are pooled (sorted by expected count,
//     merged until each pooled cell expects >= 5), the Pearson statistic is
//     formed over the remaining cells with (cells - 1) degrees of freedom, and
//     its p-value is the regularised upper incomplete gamma function
//     Q(dof / 2, stat / 2);
//  5. as in Mitsuba, more than 1e-5 N samples in bins where the pdf integrates
//     to (practically) zero is a rejection by itself;
//  6. the null hypothesis "the samples follow the pdf" is rejected when the
//     p-value is below the Sidak-corrected significance 1 - (1 - alpha)^(1/n)
//     for n tests in a file, so that with alpha = 0.01 a correct
//     implementation fails *some* test of that file with probability 0.01.
//
// Header-only; everything is in namespace chi2.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "caustica/base/math.h"

namespace chi2 {

inline constexpr double kPi = 3.14159265358979323846;

// ---------------------------------------------------------------------------
// Regularised incomplete gamma functions (Numerical Recipes, 3rd ed., Sec. 6.2):
// the series for x < a + 1, the Lentz continued fraction otherwise.

inline double gamma_p_series(double a, double x) {
  double ap = a, sum = 1.0 / a, del = sum;
  for (int n = 0; n < 100000; ++n) {
    ap += 1.0;
    del *= x / ap;
    sum += del;
    if (std::fabs(del) < std::fabs(sum) * 1e-16) break;
  }
  return sum * std::exp(-x + a * std::log(x) - std::lgamma(a));
}

inline double gamma_q_continued_fraction(double a, double x) {
  const double tiny = 1e-300;
  double b = x + 1.0 - a, c = 1.0 / tiny, d = 1.0 / b, h = d;
  for (int i = 1; i < 100000; ++i) {
    double an = -i * (i - a);
    b += 2.0;
    d = an * d + b;
    if (std::fabs(d) < tiny) d = tiny;
    c = b + an / c;
    if (std::fabs(c) < tiny) c = tiny;
    d = 1.0 / d;
    double del = d * c;
    h *= del;
    if (std::fabs(del - 1.0) < 1e-16) break;
  }
  return std::exp(-x + a * std::log(x) - std::lgamma(a)) * h;
}

// Q(a, x) = Gamma(a, x) / Gamma(a), the upper tail; Q(k/2, s/2) is the
// probability that a chi-square variable with k degrees of freedom exceeds s.
inline double gamma_q(double a, double x) {
  if (!(a > 0.0) || !(x >= 0.0)) return std::numeric_limits<double>::quiet_NaN();
  if (x == 0.0) return 1.0;
  if (x < a + 1.0) return 1.0 - gamma_p_series(a, x);
  return gamma_q_continued_fraction(a, x);
}

inline double chi2_survival(double stat, int dof) { return gamma_q(0.5 * dof, 0.5 * stat); }

// Per-test significance such that n independent tests at this level reject a
// true null hypothesis somewhere with probability alpha (Sidak).
inline double sidak_alpha(double alpha, int n_tests) {
  return 1.0 - std::pow(1.0 - alpha, 1.0 / double(n_tests));
}

// ---------------------------------------------------------------------------
// 2D h-adaptive Gauss-Legendre quadrature over a grid of bins. The nodes are
// inside the cells, so a step of the pdf along a bin edge (the horizon
// cos theta = 0 is one) is integrated exactly; each cell's estimate is
// compared with the sum of its four children's, and the cell is refined until
// they agree or the maximum depth is reached.

struct QuadOptions {
  int min_depth = 2;         // every bin is split at least into 4^min_depth cells
  int max_depth = 7;         // ... and at most into 4^max_depth
  double abs_tol = 1e-9;     // absolute error aimed at over the whole domain
  double rel_tol = 1e-6;     // relative error aimed at per cell (single-precision pdfs)
};

struct Grid {
  double x0, x1, y0, y1;  // domain
  int nx, ny;             // bins
  double bx(int i) const { return x0 + (x1 - x0) * i / nx; }
  double by(int j) const { return y0 + (y1 - y0) * j / ny; }
  double area() const { return (x1 - x0) * (y1 - y0); }
  // Bin of a point, or -1 when outside.
  int bin(double x, double y) const {
    if (!(x >= x0 && x <= x1 && y >= y0 && y <= y1)) return -1;
    int i = std::min(nx - 1, int((x - x0) / (x1 - x0) * nx));
    int j = std::min(ny - 1, int((y - y0) / (y1 - y0) * ny));
    return j * nx + i;
  }
};

struct Integration {
  std::vector<double> mass;  // integral of the pdf over each bin
  double total = 0.0;        // over the whole grid
  double error = 0.0;        // estimated absolute quadrature error of `total` (sum over cells)
  long evaluations = 0;
  long non_finite = 0;       // pdf evaluations that were NaN or infinite (a bug)
};

namespace detail {

template <class F>
struct Integrator {
  F& f;
  QuadOptions q;
  double tol_density;  // absolute tolerance per unit area
  Integration* out;

  double eval(double x, double y) {
    ++out->evaluations;
    double v = f(x, y);
    if (!std::isfinite(v)) {
      ++out->non_finite;
      return 0.0;
    }
    return v;
  }
  // 4-point Gauss-Legendre rule in each dimension (exact for degree 7).
  double gauss(double x0, double x1, double y0, double y1) {
    static constexpr double n[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                                    0.8611363115940526};
    static constexpr double w[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                                    0.3478548451374538};
    double xm = 0.5 * (x0 + x1), xh = 0.5 * (x1 - x0), ym = 0.5 * (y0 + y1), yh = 0.5 * (y1 - y0);
    double s = 0.0;
    for (int j = 0; j < 4; ++j) {
      double row = 0.0;
      for (int i = 0; i < 4; ++i) row += w[i] * eval(xm + xh * n[i], ym + yh * n[j]);
      s += w[j] * row;
    }
    return s * xh * yh;
  }
  void adapt(double x0, double x1, double y0, double y1, double whole, int depth, double& sum,
             double& err) {
    double xm = 0.5 * (x0 + x1), ym = 0.5 * (y0 + y1);
    double c0 = gauss(x0, xm, y0, ym), c1 = gauss(xm, x1, y0, ym);
    double c2 = gauss(x0, xm, ym, y1), c3 = gauss(xm, x1, ym, y1);
    double s = c0 + c1 + c2 + c3, diff = s - whole;
    double tol = std::max(tol_density * (x1 - x0) * (y1 - y0), q.rel_tol * std::fabs(s));
    if (depth + 1 >= q.min_depth && std::fabs(diff) <= tol) {
      // For a smooth integrand halving the cell shrinks the error 2^8-fold,
      // so the children's error is about |diff| / 255.
      sum += s;
      err += std::fabs(diff) / 255.0;
      return;
    }
    if (depth + 1 >= q.max_depth) {
      // Not converged (a discontinuity inside the cell): count the whole
      // difference as the error.
      sum += s;
      err += std::fabs(diff);
      return;
    }
    adapt(x0, xm, y0, ym, c0, depth + 1, sum, err);
    adapt(xm, x1, y0, ym, c1, depth + 1, sum, err);
    adapt(x0, xm, ym, y1, c2, depth + 1, sum, err);
    adapt(xm, x1, ym, y1, c3, depth + 1, sum, err);
  }
};

}  // namespace detail

// Integrates density(x, y) (with respect to dx dy) over every bin of the grid.
template <class F>
Integration integrate(const Grid& g, F&& density, const QuadOptions& q = {}) {
  Integration r;
  r.mass.assign(size_t(g.nx) * g.ny, 0.0);
  detail::Integrator<std::remove_reference_t<F>> in{density, q, q.abs_tol / g.area(), &r};
  for (int j = 0; j < g.ny; ++j)
    for (int i = 0; i < g.nx; ++i) {
      double x0 = g.bx(i), x1 = g.bx(i + 1), y0 = g.by(j), y1 = g.by(j + 1);
      double sum = 0.0, err = 0.0;
      in.adapt(x0, x1, y0, y1, in.gauss(x0, x1, y0, y1), 0, sum, err);
      r.mass[size_t(j) * g.nx + i] = sum;
      r.total += sum;
      r.error += err;
    }
  return r;
}

// The sphere of directions as a (phi, cos theta) rectangle: phi in [-pi, pi]
// (atan2's range), cos theta in [-1, 1]; nx = 2 res, ny = res bins.
inline Grid sphere_grid(int res) { return Grid{-kPi, kPi, -1.0, 1.0, 2 * res, res}; }
inline caustica::Vec3f sphere_dir(double phi, double z) {
  double r = std::sqrt(std::max(0.0, 1.0 - z * z));
  return caustica::Vec3f(float(r * std::cos(phi)), float(r * std::sin(phi)), float(z));
}

// ---------------------------------------------------------------------------
// The test.

struct Options {
  long samples = 1000000;
  double alpha = 0.01;     // family-wise significance
  int n_tests = 1;         // tests in the file, for the Sidak correction
  double min_expected = 5.0;
  QuadOptions quad{};
  int report_bins = 10;    // worst bins printed on failure
};

struct Result {
  double stat = 0.0;
  int dof = 0;
  double p_value = 0.0;
  double alpha = 0.0;      // Sidak-corrected per-test significance
  bool passed = false;
  double pdf_integral = 0.0, quad_error = 0.0;
  long other_observed = 0;      // delta or rejected samples
  double other_expected = 0.0;  // N (1 - pdf_integral)
  long bad_samples = 0;         // not finite, not unit length, or outside the domain
  long zero_pdf_samples = 0;    // samples in bins expecting < 1e-6 samples (pdf ~ 0 there)
  long non_finite_pdf = 0;
  double zero_pdf_allowed = 0.0;  // 1e-5 N
  std::string report;           // a summary, and the worst bins on failure
};

// Pearson's test of observed against expected counts; the last entry may be
// the "other" bin. names(i) describes bin i for the report.
template <class Names>
void pearson(const std::vector<double>& observed, const std::vector<double>& expected, double min_expected,
             double alpha, int report_bins, Names&& names, Result& r) {
  const size_t n = observed.size();
  std::vector<size_t> order(n);
  for (size_t i = 0; i < n; ++i) order[i] = i;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return expected[a] < expected[b]; });
  double stat = 0.0, pool_o = 0.0, pool_e = 0.0;
  int cells = 0, pooled_bins = 0;
  std::vector<std::pair<double, size_t>> contrib;  // (contribution, bin) of unpooled bins
  for (size_t k = 0; k < n; ++k) {
    size_t i = order[k];
    if (expected[i] < min_expected || (pool_e > 0.0 && pool_e < min_expected)) {
      pool_o += observed[i];
      pool_e += expected[i];
      ++pooled_bins;
      if (pool_e >= min_expected) {
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e;
        ++cells;
        pool_o = pool_e = 0.0;
      }
      continue;
    }
    double c = (observed[i] - expected[i]) * (observed[i] - expected[i]) / expected[i];
    stat += c;
    ++cells;
    contrib.push_back({c, i});
  }
  double leftover_contrib = 0.0;
  if (pool_e > 0.0 || pool_o > 0.0) {
    // A remainder expecting < 5: merge it into the smallest unpooled cell, or,
    // when there is none, keep it as a cell (a sample where nothing is
    // expected makes the statistic infinite: a certain rejection).
    if (!contrib.empty()) {
      size_t i = contrib.front().second;
      stat -= contrib.front().first;
      double o = observed[i] + pool_o, e = expected[i] + pool_e;
      contrib.front().first = (o - e) * (o - e) / e;
      stat += contrib.front().first;
    } else {
      leftover_contrib = pool_e > 0.0 ? (pool_o - pool_e) * (pool_o - pool_e) / pool_e
                                      : std::numeric_limits<double>::infinity();
      stat += leftover_contrib;
      ++cells;
    }
  }
  r.stat = stat;
  r.dof = cells - 1;
  r.alpha = alpha;
  r.p_value = r.dof > 0 ? chi2_survival(stat, r.dof) : (stat == 0.0 ? 1.0 : 0.0);
  r.passed = r.p_value >= alpha && r.bad_samples == 0 && r.non_finite_pdf == 0 &&
             r.zero_pdf_samples <= r.zero_pdf_allowed;

  char buf[512];
  std::snprintf(buf, sizeof buf,
                "chi2 = %.2f, dof = %d, p = %.3g (reject below %.3g); %d bins pooled; pdf integral = %.8f "
                "(quadrature error ~%.1e); other bin: observed %ld, expected %.1f; bad samples %ld; "
                "samples where the pdf is 0: %ld; non-finite pdf values %ld\n",
                r.stat, r.dof, r.p_value, alpha, pooled_bins, r.pdf_integral, r.quad_error, r.other_observed,
                r.other_expected, r.bad_samples, r.zero_pdf_samples, r.non_finite_pdf);
  r.report = buf;
  if (!r.passed) {
    std::sort(contrib.begin(), contrib.end(), [](auto& a, auto& b) { return a.first > b.first; });
    r.report += "worst bins:\n";
    for (int k = 0; k < report_bins && k < int(contrib.size()); ++k) {
      size_t i = contrib[k].second;
      std::snprintf(buf, sizeof buf, "  %s: observed %.0f, expected %.1f, (O-E)^2/E = %.2f\n", names(i).c_str(),
                    observed[i], expected[i], contrib[k].first);
      r.report += buf;
    }
    if (pool_o > 0.0 || pool_e > 0.0) {
      std::snprintf(buf, sizeof buf, "  pooled remainder: observed %.0f, expected %.2f\n", pool_o, pool_e);
      r.report += buf;
    }
  }
}

// A sample of a 2D domain: sample() -> Sample2, called opt.samples times;
// density(x, y) is with respect to dx dy.
struct Sample2 {
  bool ok = false;   // false: rejected, counts in the "other" bin
  double x = 0, y = 0;
  bool delta = false;  // a discrete (delta) sample: counts in the "other" bin
};

namespace detail {
// integrate() -> Integration gives the bins' masses.
template <class Sampler, class Integrate, class ToGrid>
Result run(const Grid& g, Sampler&& sample, Integrate&& integrate_bins, ToGrid&& to_grid, const Options& opt,
           const char* xname, const char* yname) {
  Result r;
  const size_t nb = size_t(g.nx) * g.ny;
  std::vector<double> observed(nb + 1, 0.0), expected(nb + 1, 0.0);
  for (long s = 0; s < opt.samples; ++s) {
    Sample2 p;
    bool valid = to_grid(sample(), p);
    if (!valid) {
      ++r.bad_samples;
      continue;
    }
    if (!p.ok || p.delta) {
      ++observed[nb];
      continue;
    }
    int b = g.bin(p.x, p.y);
    if (b < 0) {
      ++r.bad_samples;
      continue;
    }
    ++observed[size_t(b)];
  }
  r.other_observed = long(observed[nb]);
  Integration in = integrate_bins();
  r.pdf_integral = in.total;
  r.quad_error = in.error;
  r.non_finite_pdf = in.non_finite;
  for (size_t i = 0; i < nb; ++i) expected[i] = double(opt.samples) * in.mass[i];
  r.other_expected = std::max(0.0, double(opt.samples) * (1.0 - in.total));
  expected[nb] = r.other_expected;
  for (size_t i = 0; i <= nb; ++i)
    if (expected[i] < 1e-6) r.zero_pdf_samples += long(observed[i]);
  r.zero_pdf_allowed = 1e-5 * double(opt.samples);
  auto names = [&](size_t i) -> std::string {
    if (i == nb) return "other (delta / rejected)";
    char buf[160];
    int bi = int(i % size_t(g.nx)), bj = int(i / size_t(g.nx));
    std::snprintf(buf, sizeof buf, "%s [%.4f, %.4f] x %s [%.4f, %.4f]", xname, g.bx(bi), g.bx(bi + 1), yname,
                  g.by(bj), g.by(bj + 1));
    return buf;
  };
  pearson(observed, expected, opt.min_expected, sidak_alpha(opt.alpha, opt.n_tests), opt.report_bins, names, r);
  if (std::getenv("CHI2_VERBOSE")) std::fprintf(stderr, "[chi2] %s", r.report.c_str());  // debugging aid
  return r;
}
}  // namespace detail

// Points in a rectangle: sample() -> Sample2 (x, y in the grid's domain).
template <class Sampler, class Density>
Result test_2d(const Grid& g, Sampler&& sample, Density&& density, const Options& opt) {
  auto to_grid = [](const Sample2& s, Sample2& p) {
    p = s;
    return !s.ok || s.delta || (std::isfinite(s.x) && std::isfinite(s.y));
  };
  return detail::run(g, sample, [&] { return integrate(g, density, opt.quad); }, to_grid, opt, "x", "y");
}

// The same with exact expected bin masses (probabilities) given.
template <class Sampler>
Result test_2d_masses(const Grid& g, Sampler&& sample, const std::vector<double>& mass, const Options& opt) {
  auto to_grid = [](const Sample2& s, Sample2& p) {
    p = s;
    return !s.ok || s.delta || (std::isfinite(s.x) && std::isfinite(s.y));
  };
  auto given = [&] {
    Integration in;
    in.mass = mass;
    for (double m : mass) in.total += m;
    return in;
  };
  return detail::run(g, sample, given, to_grid, opt, "x", "y");
}

// Directions: sample() -> SampleDir; density(Vec3f) per unit solid angle.
struct SampleDir {
  bool ok = false;
  caustica::Vec3f w{0.f};
  bool delta = false;
};

template <class Sampler, class Density>
Result test_sphere(int res, Sampler&& sample, Density&& density, const Options& opt) {
  Grid g = sphere_grid(res);
  auto to_grid = [](const SampleDir& s, Sample2& p) {
    p.ok = s.ok;
    p.delta = s.delta;
    if (!s.ok || s.delta) return true;
    double x = s.w.x, y = s.w.y, z = s.w.z;
    double len = std::sqrt(x * x + y * y + z * z);
    if (!std::isfinite(len) || std::fabs(len - 1.0) > 1e-3) return false;  // not a unit vector
    p.x = std::atan2(y, x);
    p.y = std::clamp(z / len, -1.0, 1.0);
    return true;
  };
  auto dens = [&](double phi, double z) { return double(density(sphere_dir(phi, z))); };
  return detail::run(g, sample, [&] { return integrate(g, dens, opt.quad); }, to_grid, opt, "phi", "cos theta");
}

}  // namespace chi2
