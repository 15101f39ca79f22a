// Nonlinear least squares of effect parameters (Ceres) and held-out cross-validation.
#include "ctr/diagnosis/fit.hpp"

#include <ceres/ceres.h>

#include "ctr/diagnosis/statistics.hpp"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <limits>

#include "parallel.hpp"

namespace ctr::diagnosis {

int coordinateCount(const std::vector<Effect>& effects) {
  int k = 0;
  for (const Effect& e : effects) k += parameterCount(e.kind);
  return k;
}

ParameterRange parameterRange(const Robot& nominal, const io::Recording& rec, EffectKind kind, int tube,
                              int coordinate) {
  ParameterRange r;
  switch (kind) {
    case EffectKind::BoundaryFriction:
      r = {0.0, 1.0, {0.03, 0.08, 0.15, 0.3, 0.6}};
      break;
    case EffectKind::DistributedFriction:
      r = {0.0, 1.0, {0.1, 0.5}};
      break;
    case EffectKind::TorsionalStiffness:
      r = {-0.5, 3.0, {0.0, 0.15, 0.3, 0.45, 0.6, 0.8, 1.1, 1.6, 2.3}};
      break;
    case EffectKind::Precurvature: {
      const double k0 = nominal.tube(tube - 1).curvature;
      if (k0 > 0)
        r = {0.5 * k0, 1.6 * k0, {0.7 * k0, 0.85 * k0, 1.15 * k0, 1.3 * k0}};
      else
        r = {0.0, 15.0, {2.0, 5.0, 10.0}};
      break;
    }
    case EffectKind::BendingStiffness: {
      const double e0 = nominal.tube(tube - 1).bending_stiffness;
      r = {0.33 * e0, 3.0 * e0, {0.5 * e0, 0.7 * e0, 1.4 * e0, 2.0 * e0}};
      break;
    }
    case EffectKind::ActuatorBacklash:
      r = {0.0, 0.6, {0.03, 0.08, 0.15, 0.25, 0.4}};
      break;
    case EffectKind::ActuatorOffset:
      r = {-0.6, 0.6, {-0.4, -0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3, 0.4}};
      break;
    case EffectKind::TranslationBacklash:  // m; linear stages: play of up to 1 cm
      r = {0.0, 0.01, {0.0005, 0.001, 0.002, 0.004, 0.007}};
      break;
    case EffectKind::TranslationOffset:  // m; zero errors of up to 1 cm
      r = {-0.01, 0.01, {-0.006, -0.003, -0.0015, -0.0005, 0.0005, 0.0015, 0.003, 0.006}};
      break;
    case EffectKind::SensorLatency: {
      double dt = 0.1;
      if (rec.time.size() > 1) {
        std::vector<double> d;
        for (Eigen::Index k = 1; k < rec.time.size(); ++k)
          if (rec.time[k] > rec.time[k - 1]) d.push_back(rec.time[k] - rec.time[k - 1]);
        if (!d.empty()) {
          std::nth_element(d.begin(), d.begin() + static_cast<long>(d.size() / 2), d.end());
          dt = d[d.size() / 2];
        }
      }
      r = {0.0, 20.0 * dt, {0.5 * dt, dt, 2 * dt, 4 * dt, 8 * dt, 14 * dt}};
      break;
    }
    case EffectKind::Gravity: {
      // Each component of scale * direction, up to 3 g around the nominal (a weight up to 3x the assumed one).
      const double c = nominalEffect(nominal, kind, tube).vec[coordinate];
      r = {c - 3.0, c + 3.0, {c - 1.0, c - 0.3, c + 0.3, c + 1.0}};
      break;
    }
    case EffectKind::TipLoad: {
      // Each force component up to the force that deflects a cantilever as stiff as all tubes together and as long
      // as the robot by 30 % of its length (F L^3 / 3 EI = 0.3 L), around the nominal force.
      double ei = 0.0, len = 0.0;
      for (const Tube& t : nominal.tubes()) {
        ei += t.bending_stiffness;
        len = std::max(len, t.length());
      }
      const double fmax = len > 0 ? 0.9 * ei / (len * len) : 1.0;
      const double c = nominal.loads().tip_force[coordinate];
      r = {c - fmax, c + fmax, {c - 0.3 * fmax, c - 0.1 * fmax, c + 0.1 * fmax, c + 0.3 * fmax}};
      break;
    }
    // Generic models, started at zero (no grid): a ratio error up to 25 %, harmonics up to 20 deg; stage errors up
    // to 5 mm per term; a tracker drift up to 10 mm per term.
    case EffectKind::DriveRatio:
      r = {-0.25, 0.25, {}};
      break;
    case EffectKind::DrivePeriodic:
      r = {-0.35, 0.35, {}};
      break;
    case EffectKind::StageError:
      r = {-0.005, 0.005, {}};
      break;
    case EffectKind::TrackerDrift:
      r = {-0.01, 0.01, {}};
      break;
  }
  return r;
}

namespace {

constexpr double kFailedRowPenalty = 10.0;

struct Layout {
  std::vector<int> rows;  // rows used
  std::vector<Quantity> quantities;
  int components = 0;  // per row
};

std::vector<char> intersect(const std::vector<char>& use, const std::vector<char>& rows) {
  std::vector<char> u = use;
  for (std::size_t k = 0; k < u.size() && !rows.empty(); ++k) u[k] = u[k] && k < rows.size() && rows[k];
  return u;
}

Layout makeLayout(const io::Recording& rec, const std::vector<char>& use) {
  Layout L;
  for (int k = 0; k < rec.rows(); ++k)
    if (k < static_cast<int>(use.size()) && use[static_cast<std::size_t>(k)]) L.rows.push_back(k);
  L.quantities = presentQuantities(rec);
  for (Quantity q : L.quantities) L.components += q == Quantity::Twist ? static_cast<int>(rec.twist.cols()) : 3;
  return L;
}

/// Evaluates the weighted residual vector for parameter vector x (scaled to [0, 1] per effect).
class Model {
 public:
  Model(const Robot& nominal, const io::Recording& rec, std::vector<Effect> effects, const std::vector<char>& use,
        const FitOptions& o, Workspace& ws)
      : nominal_(nominal),
        rec_(rec),
        effects_(std::move(effects)),
        use_(intersect(use, o.rows)),
        o_(o),
        ws_(ws),
        layout_(makeLayout(rec, use_)) {
    for (int j = std::max(0, o.first_free); j < static_cast<int>(effects_.size()); ++j) {
      const Effect& e = effects_[static_cast<std::size_t>(j)];
      for (int c = 0; c < parameterCount(e.kind); ++c) {
        free_.push_back(j);
        coord_.push_back(c);
        ranges_.push_back(parameterRange(nominal, rec, e.kind, e.tube, c));
      }
    }
  }
  /// Free parameters: the coordinates of the free effects (parameterCount each).
  int parameters() const { return static_cast<int>(free_.size()); }
  /// Index into the effect list of free parameter j.
  int effectIndex(int j) const { return free_[static_cast<std::size_t>(j)]; }
  /// Coordinate of its effect that free parameter j is.
  int coordinateIndex(int j) const { return coord_[static_cast<std::size_t>(j)]; }
  /// Start value of free parameter j.
  double startValue(int j) const {
    return effects_[static_cast<std::size_t>(effectIndex(j))].coordinate(coordinateIndex(j));
  }
  int residuals() const { return static_cast<int>(layout_.rows.size()) * layout_.components; }
  int componentsPerRow() const { return layout_.components; }
  const std::vector<int>& rows() const { return layout_.rows; }
  bool forwardDifferences() const { return o_.forward_differences; }
  double toX(int j, double v) const {
    const auto& r = ranges_[static_cast<std::size_t>(j)];
    return std::clamp((v - r.lo) / (r.hi - r.lo), 0.0, 1.0);
  }
  double toValue(int j, double x) const {
    const auto& r = ranges_[static_cast<std::size_t>(j)];
    return r.lo + x * (r.hi - r.lo);
  }
  double span(int j) const { return ranges_[static_cast<std::size_t>(j)].hi - ranges_[static_cast<std::size_t>(j)].lo; }
  const ParameterRange& range(int j) const { return ranges_[static_cast<std::size_t>(j)]; }
  std::vector<Effect> effectsAt(const double* x) const {
    std::vector<Effect> e = effects_;
    for (int j = 0; j < parameters(); ++j)
      e[static_cast<std::size_t>(effectIndex(j))].setCoordinate(coordinateIndex(j), toValue(j, x[j]));
    return e;
  }
  /// Full evaluation (prediction, registration, residuals), with the caller's workspace.
  FitResult evaluate(const std::vector<Effect>& e) { return evaluate(e, ws_); }
  FitResult evaluate(const std::vector<Effect>& e, Workspace& w) {
    ++evaluations;
    FitResult f;
    f.effects = e;
    f.prediction = predict(nominal_, rec_.commands, rec_.time, e, w, o_.predict);
    f.registration = mapToSensor(rec_, f.prediction, o_.frame, use_, o_.noise);
    f.residuals = computeResiduals(rec_, f.prediction);
    excludeRows(f.residuals, o_.rows);
    return f;
  }
  /// Evaluations of several parameter points, on FitOptions::threads threads (in order of `xs`).
  std::vector<FitResult> evaluateAll(const std::vector<std::vector<double>>& xs) {
    std::vector<FitResult> out(xs.size());
    detail::parallelFor(static_cast<int>(xs.size()), o_.threads, ws_, [&](int i, Workspace& w) {
      out[static_cast<std::size_t>(i)] = evaluate(effectsAt(xs[static_cast<std::size_t>(i)].data()), w);
    });
    return out;
  }
  /// The evaluation at x: from the last few evaluations of the optimiser when x is one of them (the optimiser's
  /// final point was always evaluated), else a new replay.
  FitResult evaluateAt(const std::vector<double>& x) {
    for (const auto& [cx, cf] : recent_)
      if (cx == x) return cf;
    return evaluate(effectsAt(x.data()));
  }
  void remember(const std::vector<double>& x, const FitResult& f) {
    for (const auto& r : recent_)
      if (r.first == x) return;
    if (recent_.size() >= 3) recent_.erase(recent_.begin());
    recent_.emplace_back(x, f);
  }
  /// Noise-normalised residuals of the fit rows. A fit row the model could not evaluate at these parameter values
  /// costs a fixed penalty per component (kFailedRowPenalty noise units), so that no optimiser can lower its cost
  /// by making rows fail; an unmeasured component contributes 0.
  void weighted(const FitResult& f, double* out) const {
    int i = 0;
    for (int k : layout_.rows) {
      const bool failed = k < f.prediction.rows() && !f.prediction.ok[static_cast<std::size_t>(k)];
      for (Quantity q : layout_.quantities) {
        const Eigen::MatrixXd& R = f.residuals.of(q);
        const Eigen::MatrixXd& M = measured(rec_, q);
        const double s = o_.noise.of(q) > 0 ? o_.noise.of(q) : 1.0;
        for (Eigen::Index c = 0; c < R.cols(); ++c) {
          const double v = R(k, c);
          out[i++] = std::isfinite(v) ? v / s : (failed && std::isfinite(M(k, c)) ? kFailedRowPenalty : 0.0);
        }
      }
    }
  }
  double cost(const FitResult& f) const {
    Eigen::VectorXd v(residuals());
    weighted(f, v.data());
    return 0.5 * v.squaredNorm();
  }
  Eigen::VectorXd residualAt(const double* x) {
    Eigen::VectorXd v(residuals());
    weighted(evaluate(effectsAt(x)), v.data());
    return v;
  }
  /// As residualAt, keeping the evaluation for evaluateAt (and taking it from there when x was evaluated last: the
  /// optimiser evaluates the cost at a trial point, then its Jacobian there when the step is accepted).
  Eigen::VectorXd residualAtRemembered(const double* x) {
    std::vector<double> xv(x, x + parameters());
    FitResult f = evaluateAt(xv);
    Eigen::VectorXd v(residuals());
    weighted(f, v.data());
    remember(xv, f);
    return v;
  }
  int finiteCount(const Residuals& r) const {
    int c = 0;
    for (int k : layout_.rows)
      for (Quantity q : layout_.quantities)
        for (Eigen::Index j = 0; j < r.of(q).cols(); ++j) c += std::isfinite(r.of(q)(k, j)) ? 1 : 0;
    return c;
  }
  /// Central-difference Jacobian in x units (one-sided at the bounds); with `forward` (and r0 given) a one-sided
  /// difference away from the nearer bound (one replay per parameter instead of two).
  /// The difference points are replayed concurrently (FitOptions::threads).
  Eigen::MatrixXd jacobian(const double* x, const Eigen::VectorXd* r0, bool forward = false) {
    const int k = parameters();
    Eigen::MatrixXd J(residuals(), k);
    std::vector<double> lo(static_cast<std::size_t>(k)), hi(static_cast<std::size_t>(k));
    std::vector<std::vector<double>> points;                          // distinct points to replay
    std::vector<std::array<int, 2>> at(static_cast<std::size_t>(k));  // index into points (-1 = r0) of a, b
    for (int j = 0; j < k; ++j) {
      const double h = o_.difference_step;
      const double xj = x[j];
      double a = std::min(1.0, xj + h), b = std::max(0.0, xj - h);
      if (forward && r0) {
        if (xj + h <= 1.0)
          b = xj;
        else
          a = xj;
      }
      hi[static_cast<std::size_t>(j)] = a;
      lo[static_cast<std::size_t>(j)] = b;
      for (int side = 0; side < 2; ++side) {
        const double v = side == 0 ? a : b;
        if (r0 && v == xj) {
          at[static_cast<std::size_t>(j)][static_cast<std::size_t>(side)] = -1;
          continue;
        }
        std::vector<double> xp(x, x + k);
        xp[static_cast<std::size_t>(j)] = v;
        at[static_cast<std::size_t>(j)][static_cast<std::size_t>(side)] = static_cast<int>(points.size());
        points.push_back(std::move(xp));
      }
    }
    const std::vector<FitResult> fr = evaluateAll(points);
    std::vector<Eigen::VectorXd> r(fr.size(), Eigen::VectorXd(residuals()));
    for (std::size_t i = 0; i < fr.size(); ++i) weighted(fr[i], r[i].data());
    for (int j = 0; j < k; ++j) {
      const auto& ab = at[static_cast<std::size_t>(j)];
      const Eigen::VectorXd& ra = ab[0] < 0 ? *r0 : r[static_cast<std::size_t>(ab[0])];
      const Eigen::VectorXd& rb = ab[1] < 0 ? *r0 : r[static_cast<std::size_t>(ab[1])];
      J.col(j) = (ra - rb) / std::max(1e-12, hi[static_cast<std::size_t>(j)] - lo[static_cast<std::size_t>(j)]);
    }
    return J;
  }
  std::atomic<int> evaluations{0};

 private:
  const Robot& nominal_;
  const io::Recording& rec_;
  std::vector<Effect> effects_;
  std::vector<char> use_;
  const FitOptions& o_;
  Workspace& ws_;
  Layout layout_;
  std::vector<ParameterRange> ranges_;
  std::vector<int> free_, coord_;
  std::vector<std::pair<std::vector<double>, FitResult>> recent_;
};

class ReplayCost : public ceres::CostFunction {
 public:
  explicit ReplayCost(Model& m) : m_(m) {
    set_num_residuals(m.residuals());
    mutable_parameter_block_sizes()->push_back(m.parameters());
  }
  bool Evaluate(double const* const* p, double* residuals, double** jacobians) const override {
    const int k = m_.parameters();
    std::vector<double> x(p[0], p[0] + k);
    Eigen::VectorXd r0 = m_.residualAtRemembered(x.data());
    if (!r0.allFinite()) return false;
    Eigen::Map<Eigen::VectorXd>(residuals, num_residuals()) = r0;
    if (jacobians && jacobians[0]) {
      const Eigen::MatrixXd J = m_.jacobian(x.data(), &r0, m_.forwardDifferences());
      Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jacobians[0], num_residuals(),
                                                                                         k) = J;
    }
    return true;
  }

 private:
  Model& m_;
};

/// Jacobian (central differences) at x, kept in f for the one-step cross-validation, and the 95 % intervals.
void addLinearisation(Model& m, const std::vector<double>& x, FitResult& f) {
  const int k = m.parameters();
  Eigen::VectorXd r0(m.residuals());
  m.weighted(f, r0.data());
  const Eigen::MatrixXd J = m.jacobian(x.data(), nullptr);
  const int dof = std::max(1, m.finiteCount(f.residuals) - k);
  const double s2 = 2.0 * f.cost / dof;
  const Eigen::MatrixXd H = J.transpose() * J;
  const Eigen::MatrixXd C = H.completeOrthogonalDecomposition().pseudoInverse() * s2;
  // Residuals of consecutive rows are serially correlated (model error varies smoothly along a path): the
  // interval uses the pre-whitened Newey-West (HAC) covariance over rows, never narrower than the classical one.
  const stats::HacCovariance hac = stats::hacCovariance(J, r0, m.componentsPerRow());
  f.jacobian = J;
  f.weighted_residuals = r0;
  f.jacobian_rows = m.rows();
  f.components = m.componentsPerRow();
  f.x = x;
  f.interval_serial_correlation = hac.rho;
  f.uncertainty.assign(f.effects.size(), EffectUncertainty{});
  {  // All coordinates together (FitResult::covariance): the per-effect blocks below are its diagonal blocks.
    bool all_ok = true;
    for (int j = 0; j < k; ++j) all_ok = all_ok && hac.covariance(j, j) > 0;
    Eigen::VectorXd d(k);
    for (int j = 0; j < k; ++j)
      d[j] = m.span(j) * (all_ok ? std::sqrt(std::max(1.0, C(j, j) / hac.covariance(j, j))) : 1.0);
    f.covariance = d.asDiagonal() * (all_ok ? hac.covariance : C) * d.asDiagonal();
  }
  // Per effect: the block of its coordinates, the HAC covariance scaled so that no variance is below the classical
  // one (its correlations kept), in coordinate units.
  for (int j0 = 0; j0 < k;) {
    const int e = m.effectIndex(j0);
    int j1 = j0;
    while (j1 < k && m.effectIndex(j1) == e) ++j1;
    const int nb = j1 - j0;
    const Eigen::MatrixXd Hc = hac.covariance.block(j0, j0, nb, nb), Cc = C.block(j0, j0, nb, nb);
    bool hac_ok = true;
    for (int a = 0; a < nb; ++a) hac_ok = hac_ok && Hc(a, a) > 0;
    Eigen::VectorXd d(nb);
    for (int a = 0; a < nb; ++a) d[a] = m.span(j0 + a) * (hac_ok ? std::sqrt(std::max(1.0, Cc(a, a) / Hc(a, a))) : 1.0);
    EffectUncertainty& u = f.uncertainty[static_cast<std::size_t>(e)];
    u.covariance = d.asDiagonal() * (hac_ok ? Hc : Cc) * d.asDiagonal();
    for (int a = 0; a < nb; ++a) {
      const int j = j0 + a;
      const double sd = std::sqrt(std::max(0.0, u.covariance(a, a)));
      const double v = f.effects[static_cast<std::size_t>(e)].coordinate(m.coordinateIndex(j));
      const double half = H(j, j) > 0 ? 1.96 * sd : std::numeric_limits<double>::infinity();
      u.interval95.push_back({std::max(m.range(j).lo, v - half), std::min(m.range(j).hi, v + half)});
    }
    j0 = j1;
  }
}

}  // namespace

FitResult evaluateModel(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& effects,
                        const std::vector<char>& use, const FitOptions& options, Workspace& ws) {
  Model m(nominal, rec, effects, use, options, ws);
  FitResult f = m.evaluate(effects);
  f.cost = m.cost(f);
  f.evaluations = m.evaluations.load();
  return f;
}

FitResult fitEffects(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& start,
                     const std::vector<char>& use, const FitOptions& o, Workspace& ws, int grid_from) {
  Model m(nominal, rec, start, use, o, ws);
  const int k = m.parameters();
  if (k == 0) return evaluateModel(nominal, rec, start, use, o, ws);
  std::vector<double> x(static_cast<std::size_t>(k));
  for (int j = 0; j < k; ++j) x[static_cast<std::size_t>(j)] = m.toX(j, m.startValue(j));
  // Coarse grid scan of the new effects (one at a time, others held), keeping the start value if best.
  if (o.grid_search) {
    for (int j = 0; j < k; ++j) {
      if (m.effectIndex(j) < grid_from || m.range(j).grid.empty()) continue;
      std::vector<std::vector<double>> pts(1, x);  // the start, then the grid (replayed concurrently)
      for (double v : m.range(j).grid) {
        pts.push_back(x);
        pts.back()[static_cast<std::size_t>(j)] = m.toX(j, v);
      }
      const std::vector<FitResult> fr = m.evaluateAll(pts);
      std::size_t bi = 0;
      double best = m.cost(fr[0]);
      for (std::size_t i = 1; i < fr.size(); ++i) {
        const double c = m.cost(fr[i]);
        if (c < best) {
          best = c;
          bi = i;
        }
      }
      x = pts[bi];
    }
  }
  // Gate: the Gauss-Newton model at the grid's best point predicts the largest cost drop the optimiser can reach;
  // when even that is worth less than gate_bic in BIC, the candidate cannot pass and the iterations are skipped.
  if (o.gate_bic > 0) {
    const Eigen::VectorXd r0 = m.residualAt(x.data());
    const Eigen::MatrixXd J = m.jacobian(x.data(), &r0, true);
    const Eigen::MatrixXd H = J.transpose() * J;
    Eigen::VectorXd dx = -H.completeOrthogonalDecomposition().solve(J.transpose() * r0);
    for (int j = 0; j < k; ++j)
      dx[j] = std::clamp(x[static_cast<std::size_t>(j)] + (std::isfinite(dx[j]) ? dx[j] : 0.0), 0.0, 1.0) -
              x[static_cast<std::size_t>(j)];
    const double c0 = r0.squaredNorm(), c1 = (r0 + J * dx).squaredNorm();
    const int n = std::max(1, m.residuals());
    if (c0 > 0 && n * std::log(c0 / std::max(c1, 1e-300 * c0)) < o.gate_bic) {
      FitResult f = m.evaluate(m.effectsAt(x.data()));
      f.cost = m.cost(f);
      f.converged = true;
      f.message = "gated: the linearised optimum cannot lower BIC enough";
      f.evaluations = m.evaluations.load();
      return f;
    }
  }
  ceres::Problem::Options po;
  po.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  problem.AddResidualBlock(new ReplayCost(m), nullptr, x.data());
  for (int j = 0; j < k; ++j) {
    problem.SetParameterLowerBound(x.data(), j, 0.0);
    problem.SetParameterUpperBound(x.data(), j, 1.0);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = o.max_iterations;
  so.function_tolerance = o.function_tolerance;
  so.parameter_tolerance = 1e-4;
  so.gradient_tolerance = 1e-8;
  // No projected line search at the bounds: it evaluates the Jacobian (k replays) at every trial step (Ceres
  // issue 187); a step that leaves the box is projected onto it and judged by the trust region as any other.
  so.max_num_line_search_step_size_iterations = 0;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  FitResult f = m.evaluateAt(x);
  f.cost = m.cost(f);
  f.converged = summary.IsSolutionUsable();
  f.message = summary.BriefReport();
  if (o.intervals) addLinearisation(m, x, f);
  f.evaluations = m.evaluations.load();
  return f;
}

FitResult linearizeModel(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& effects,
                         const std::vector<char>& use, const FitOptions& options, Workspace& ws) {
  Model m(nominal, rec, effects, use, options, ws);
  std::vector<double> x(static_cast<std::size_t>(m.parameters()));
  for (int j = 0; j < m.parameters(); ++j) x[static_cast<std::size_t>(j)] = m.toX(j, m.startValue(j));
  FitResult f = m.evaluate(m.effectsAt(x.data()));
  f.cost = m.cost(f);
  if (m.parameters() > 0) addLinearisation(m, x, f);
  f.evaluations = m.evaluations.load();
  return f;
}

std::vector<DetectionLimit> detectionLimits(const Robot& nominal, const io::Recording& rec,
                                            const std::vector<Effect>& model, const std::vector<Effect>& candidates,
                                            const std::vector<char>& use, const FitOptions& options,
                                            double bic_threshold, Workspace& ws) {
  const double inf = std::numeric_limits<double>::infinity();
  std::vector<DetectionLimit> limit(candidates.size());
  Model m(nominal, rec, model, use, options, ws);
  const int k = m.parameters(), n = m.residuals(), C = m.componentsPerRow();
  if (n == 0) return limit;
  std::vector<double> x(static_cast<std::size_t>(k));
  for (int j = 0; j < k; ++j) x[static_cast<std::size_t>(j)] = m.toX(j, m.startValue(j));
  const Eigen::VectorXd r0 = m.residualAt(x.data());
  const Eigen::MatrixXd Jm = k > 0 ? m.jacobian(x.data(), nullptr) : Eigen::MatrixXd(n, 0);
  // Each candidate's column: a one-sided difference into its range from its value (one replay each).
  std::vector<Eigen::VectorXd> col(candidates.size());
  std::vector<double> span(candidates.size(), 0.0);
  detail::parallelFor(static_cast<int>(candidates.size()), options.threads, ws, [&](int i, Workspace& w) {
    const Effect& c = candidates[static_cast<std::size_t>(i)];
    if (parameterCount(c.kind) != 1) throw std::invalid_argument("detectionLimits: a candidate with one coordinate");
    const ParameterRange r = parameterRange(nominal, rec, c.kind, c.tube);
    const double v0 = c.coordinate(0), h = options.difference_step * (r.hi - r.lo);
    const double v1 = v0 + h <= r.hi ? v0 + h : v0 - h;
    std::vector<Effect> e = model;
    e.push_back(c);
    e.back().setCoordinate(0, v1);
    const FitResult f = m.evaluate(e, w);
    Eigen::VectorXd r1(n);
    m.weighted(f, r1.data());
    span[static_cast<std::size_t>(i)] = r.hi - r.lo;
    col[static_cast<std::size_t>(i)] = (r1 - r0) / ((v1 - v0) / (r.hi - r.lo));  // per unit of the range
  });
  // Components per row of each quantity and their independent count (the BIC's n); the model's residual sum of
  // squares per quantity (E_q) and the BIC drop a candidate must reach (the same for every candidate).
  std::vector<std::pair<int, double>> blocks;  // (components, independent components) per quantity, in row order
  for (Quantity q : presentQuantities(rec)) {
    const int cols = q == Quantity::Twist ? static_cast<int>(rec.twist.cols()) : 3;
    blocks.emplace_back(cols, rowDof(q, cols));
  }
  const int rows = n / std::max(1, C);
  const int dof = std::max(1, n - k - 1);
  std::vector<double> E(blocks.size(), 0.0), nq(blocks.size(), 0.0);
  for (int row = 0; row < rows; ++row) {
    Eigen::Index at = static_cast<Eigen::Index>(row) * C;
    for (std::size_t b = 0; b < blocks.size(); at += blocks[b].first, ++b) {
      E[b] += r0.segment(at, blocks[b].first).squaredNorm();
      nq[b] += blocks[b].second;
    }
  }
  double total = 0.0;
  for (double v : nq) total += v;
  const double target = bic_threshold + std::log(std::max(1.0, total));
  Eigen::CompleteOrthogonalDecomposition<Eigen::MatrixXd> model_cod;  // of the model's columns, for every candidate
  if (k > 0) model_cod.compute(Jm);
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    if (!col[i].allFinite() || col[i].squaredNorm() <= 0.0) continue;  // no output depends on it
    limit[i].confounded = true;                                        // until a finite limit is found
    // The part of its prediction change the model's effects cannot take up (their refit): none left, to 1 % (the
    // one-sided difference of the column against the central ones of the model leaves ~0.2 % of a duplicate), is a
    // candidate this recording cannot tell from them at any size.
    Eigen::VectorXd g = col[i];
    if (k > 0) g -= Jm * model_cod.solve(col[i]);
    if (g.squaredNorm() <= 1e-4 * col[i].squaredNorm()) continue;
    Eigen::MatrixXd J(n, k + 1);
    J << Jm, col[i];
    // (a) The 95 % interval half-width of the candidate's coordinate at its value.
    const Eigen::MatrixXd H = J.transpose() * J;
    const Eigen::MatrixXd Hinv = H.completeOrthogonalDecomposition().pseudoInverse();
    const double classical = Hinv(k, k) * r0.squaredNorm() / dof;
    const stats::HacCovariance hac = stats::hacCovariance(J, r0, C);
    const double var = std::max(classical, hac.covariance(k, k));
    if (!(Hinv(k, k) > 0) || !std::isfinite(var)) continue;
    const double interval = 1.96 * std::sqrt(var) * span[i];
    // (b) The size whose prediction change, with the model's effects refitted (g), lowers BIC by the threshold:
    // sum_q n_q ln(1 + t^2 G_q / E_q) = threshold + ln N.
    std::vector<double> G(blocks.size(), 0.0);
    for (int row = 0; row < rows; ++row) {
      Eigen::Index at = static_cast<Eigen::Index>(row) * C;
      for (std::size_t b = 0; b < blocks.size(); at += blocks[b].first, ++b)
        G[b] += g.segment(at, blocks[b].first).squaredNorm();
    }
    auto gain = [&](double t) {
      double s = 0.0;
      for (std::size_t b = 0; b < blocks.size(); ++b)
        if (E[b] > 0) s += nq[b] * std::log1p(t * t * G[b] / E[b]);
      return s;
    };
    double hi = 1.0;
    while (gain(hi) < target && hi < 1e6) hi *= 2;
    double bic_limit = inf;
    if (gain(hi) >= target) {
      double lo = 0.0;
      for (int it = 0; it < 60; ++it) (gain(0.5 * (lo + hi)) < target ? lo : hi) = 0.5 * (lo + hi);
      bic_limit = hi * span[i];
    }
    limit[i].value = std::max(interval, bic_limit);
    limit[i].confounded = !std::isfinite(limit[i].value);
  }
  return limit;
}

std::vector<int> foldOfRows(int rows, int folds) {
  std::vector<int> f(static_cast<std::size_t>(rows));
  folds = std::max(1, std::min(folds, rows));
  for (int k = 0; k < rows; ++k) f[static_cast<std::size_t>(k)] = std::min(folds - 1, k * folds / std::max(1, rows));
  return f;
}

CrossValidation crossValidate(const Robot& nominal, const io::Recording& rec, const std::vector<Effect>& start,
                              int folds, const FitOptions& options, Workspace& ws, int max_iterations, int threads,
                              const FitResult* full) {
  CrossValidation cv;
  const int rows = rec.rows();
  const std::vector<int> fold = foldOfRows(rows, folds);
  const int nf = rows ? fold.back() + 1 : 0;
  FitOptions o = options;
  o.grid_search = false;
  o.intervals = false;
  o.max_iterations = max_iterations;
  for (Quantity q : presentQuantities(rec)) {
    const Eigen::MatrixXd& M = measured(rec, q);
    cv.heldout.of(q) = Eigen::MatrixXd::Constant(rows, M.cols(), std::numeric_limits<double>::quiet_NaN());
  }
  std::vector<FitResult> fits(static_cast<std::size_t>(nf));
  const int ncoord = coordinateCount(start);
  const bool one_step =
      full && !start.empty() && full->jacobian.cols() == ncoord && full->x.size() == static_cast<std::size_t>(ncoord) &&
      full->components > 0 &&
      full->jacobian.rows() == static_cast<Eigen::Index>(full->jacobian_rows.size()) * full->components;
  auto fitFold = [&](int f, Workspace& w) {
    std::vector<char> train(static_cast<std::size_t>(rows));
    for (int k = 0; k < rows; ++k) train[static_cast<std::size_t>(k)] = fold[static_cast<std::size_t>(k)] != f;
    if (start.empty()) {
      fits[static_cast<std::size_t>(f)] = evaluateModel(nominal, rec, start, train, o, w);
    } else if (one_step) {
      // One Gauss-Newton step from the full-data optimum using the training rows' part of its linearisation.
      const int C = full->components, k = ncoord;
      Eigen::MatrixXd H = Eigen::MatrixXd::Zero(k, k);
      Eigen::VectorXd g = Eigen::VectorXd::Zero(k);
      for (std::size_t i = 0; i < full->jacobian_rows.size(); ++i) {
        if (fold[static_cast<std::size_t>(full->jacobian_rows[i])] == f) continue;
        const auto Ji = full->jacobian.middleRows(static_cast<Eigen::Index>(i) * C, C);
        H.noalias() += Ji.transpose() * Ji;
        g.noalias() += Ji.transpose() * full->weighted_residuals.segment(static_cast<Eigen::Index>(i) * C, C);
      }
      H.diagonal().array() += 1e-9 * std::max(1e-300, H.diagonal().maxCoeff());
      const Eigen::VectorXd dx = -H.ldlt().solve(g);
      std::vector<Effect> e = start;
      int j = 0;
      for (Effect& ef : e)
        for (int c = 0; c < parameterCount(ef.kind); ++c, ++j) {
          const ParameterRange pr = parameterRange(nominal, rec, ef.kind, ef.tube, c);
          const double xj = std::clamp(full->x[static_cast<std::size_t>(j)] + (dx.allFinite() ? dx[j] : 0.0), 0.0, 1.0);
          ef.setCoordinate(c, pr.lo + xj * (pr.hi - pr.lo));
        }
      fits[static_cast<std::size_t>(f)] = evaluateModel(nominal, rec, e, train, o, w);
    } else {
      fits[static_cast<std::size_t>(f)] = fitEffects(nominal, rec, start, train, o, w);
    }
  };
  detail::parallelFor(nf, threads, ws, fitFold);  // folds are independent fits
  for (int f = 0; f < nf; ++f) {
    const FitResult& r = fits[static_cast<std::size_t>(f)];
    cv.evaluations += r.evaluations;
    cv.fold_effects.push_back(r.effects);
    for (Quantity q : presentQuantities(rec))
      for (int k = 0; k < rows; ++k)
        if (fold[static_cast<std::size_t>(k)] == f) cv.heldout.of(q).row(k) = r.residuals.of(q).row(k);
  }
  const std::vector<char> all(static_cast<std::size_t>(rows), 1);
  cv.rmse = rmse(rec, cv.heldout, all);
  cv.row_score = rowScores(rec, cv.heldout, options.noise);
  cv.score = finiteMean(cv.row_score);
  return cv;
}

}  // namespace ctr::diagnosis
