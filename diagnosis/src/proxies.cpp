// Proxies: with a structured remainder, an accepted effect may be a stand-in absorbing part of physics it does not
// model. Constancy (a real effect has one value for the whole recording) and confounding (a generic smooth
// correction of the remainder does what the effect does) decide whether it is named.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <memory>

#include <Eigen/QR>

#include "diagnosis_state.hpp"
#include "parallel.hpp"

namespace ctr::diagnosis::detail {

namespace {

/// Name of fitted coordinate c of an effect, for messages ("mu", "force x", "gravity x" = scale * direction x).
std::string coordinateLabel(const Effect& e, int c) {
  if (parameterCount(e.kind) == 1) return parameterName(e.kind);
  if (isGeneric(e.kind)) return "coefficient " + std::to_string(c);
  const char* axis[] = {"x", "y", "z"};
  return std::string(e.kind == EffectKind::Gravity ? "scale*direction " : "force ") + axis[c];
}

/// The variable along which the remainder is largest: the first located finding of the final residuals (then of
/// the baseline's) that names a configuration variable; nullptr for time (drift) or when none is named.
std::unique_ptr<ConfigVariable> remainderVariableOf(const State& s) {
  const std::vector<ConfigVariable> vars = configVariables(s.rec);
  const std::array<const std::vector<MismatchFinding>*, 2> lists{&s.final_mismatch.findings, &s.rep.mismatch.findings};
  for (const std::vector<MismatchFinding>* findings : lists)
    for (const MismatchFinding& f : *findings) {
      if (f.variable == "time") return nullptr;
      for (const ConfigVariable& v : vars)
        if (v.name == f.variable) return std::make_unique<ConfigVariable>(v);
    }
  return vars.empty() ? nullptr : std::make_unique<ConfigVariable>(vars.front());
}

void checkConstancy(State& s) {
  const Robot& nominal = s.nominal;
  const io::Recording& rec = s.rec;
  const DiagnoseOptions& o = s.o;
  DiagnosisReport& rep = s.rep;
  const FitOptions& fo = s.fo;
  Workspace& ws = s.ws;
  Candidate& cur = s.cur;
  const std::vector<char>& evaluable = s.evaluable;
  const int rows = rec.rows();
  auto remainderVariable = [&]() { return remainderVariableOf(s); };
  // 3b. With a structured remainder, an accepted effect may be a proxy absorbing part of physics it does not model.
  // A real effect has one value for the whole recording; a proxy's fitted value follows whatever part of the
  // mismatch the rows it is fitted on hold. Two parameter-constancy checks: the held-out folds (contiguous blocks in
  // time) and a split of the rows in two halves by the configuration variable where the remainder is largest (each
  // half refitted with its own intervals). An effect whose values disagree beyond their uncertainty (z > 3) and by
  // more than a quarter of its size is not named; it stays in the fit as a partial explanation, so the named effects
  // are judged in the model that predicts best (dropping it would move their values to absorb what it took up).
  if (!rep.unexplained.present || cur.fit.effects.empty()) return;
  {
    const std::unique_ptr<ConfigVariable> split = remainderVariable();
    std::array<std::vector<char>, 2> half;
    std::string split_name = "time";
    {
      std::vector<std::pair<double, int>> order_rows;
      for (int k = 0; k < rows; ++k)
        if (evaluable[static_cast<std::size_t>(k)])
          order_rows.push_back({split ? split->value[k] : static_cast<double>(k), k});
      std::stable_sort(order_rows.begin(), order_rows.end(),
                       [](const auto& a, const auto& b) { return a.first < b.first; });
      half[0].assign(static_cast<std::size_t>(rows), 0);
      half[1].assign(static_cast<std::size_t>(rows), 0);
      for (std::size_t i = 0; i < order_rows.size(); ++i)
        half[2 * i < order_rows.size() ? 0 : 1][static_cast<std::size_t>(order_rows[i].second)] = 1;
      if (split) split_name = split->name;
    }
    std::array<FitResult, 2> halves;
    FitOptions ho = fo;
    ho.intervals = true;
    ho.grid_search = false;
    ho.max_iterations = 4;  // warm start from the full-data values
    parallelFor(2, o.threads, ws, [&](int h, Workspace& tws) {
      halves[static_cast<std::size_t>(h)] = fitEffects(nominal, rec, cur.fit.effects, half[static_cast<std::size_t>(h)],
                                                       ho, tws, coordinateCount(cur.fit.effects));
    });
    s.count(halves[0].evaluations + halves[1].evaluations);
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j) {
      const Effect& e = cur.fit.effects[j];
      if (isGeneric(e.kind)) continue;  // a description of the remainder, never named
      const Effect e0 = nominalEffect(nominal, e.kind, e.tube);
      const int nc = parameterCount(e.kind);
      // The effect's size: its distance from the nominal over all its coordinates.
      double size = 0.0;
      for (int c = 0; c < nc; ++c) size = std::hypot(size, e.coordinate(c) - e0.coordinate(c));
      bool time_unstable = false, split_unstable = false;
      std::string why_time, why_split;
      for (int c = 0; c < nc; ++c) {
        const std::string cname = coordinateLabel(e, c);
        // Time folds.
        double lo = e.coordinate(c), hi = e.coordinate(c);
        for (const auto& fe : cur.cv.fold_effects)
          if (j < fe.size()) {
            lo = std::min(lo, fe[j].coordinate(c));
            hi = std::max(hi, fe[j].coordinate(c));
          }
        auto widthOf = [&](const FitResult& f) {
          if (j >= f.uncertainty.size() || static_cast<int>(f.uncertainty[j].interval95.size()) <= c)
            return std::numeric_limits<double>::infinity();
          const auto& iv = f.uncertainty[j].interval95[static_cast<std::size_t>(c)];
          return std::isfinite(iv[1] - iv[0]) ? iv[1] - iv[0] : std::numeric_limits<double>::infinity();
        };
        const double w0 = widthOf(cur.fit);
        const double width = std::isfinite(w0) ? w0 : 0.0;
        const bool tu = cur.cv.fold_effects.size() >= 2 && hi - lo > std::max(width, 0.25 * size);
        // Configuration halves.
        const double va = halves[0].effects[j].coordinate(c), vb = halves[1].effects[j].coordinate(c);
        const double z =
            std::abs(va - vb) / std::max(1e-300, std::hypot(widthOf(halves[0]) / 3.92, widthOf(halves[1]) / 3.92));
        const bool su = z > 3.0 && std::abs(va - vb) > 0.25 * size;
        s.say(DiagnoseProgress::Stage::Remainder,
              "constancy: " + e.label() + " " + cname +
                  fmt(" = %.4g; time folds %.4g .. %.4g; halves by ", e.coordinate(c), lo, hi) + split_name +
                  fmt(" %.4g vs %.4g (z = %.1f)", va, vb, z));
        if (tu && !time_unstable)
          why_time = "its fitted " + cname +
                     fmt(" changes between held-out blocks in time (%.4g to %.4g, against a 95 %% interval of width "
                         "%.3g): it absorbs part of a mismatch it does not model, so it is a partial explanation, "
                         "not named",
                         lo, hi, width);
        if (su && !split_unstable)
          why_split = "its fitted " + cname + " depends on which rows it is fitted on (" + fmt("%.4g", va) + " with " +
                      split_name + " below its median, " +
                      fmt("%.4g above, z = %.1f): it absorbs part of a mismatch it does not ", vb, z) +
                      "model, so it is a partial explanation, not named";
        time_unstable = time_unstable || tu;
        split_unstable = split_unstable || su;
      }
      if (time_unstable || split_unstable) {
        const std::string lab = e.label();
        s.confounded.insert(lab);
        s.removed_partial[lab] = time_unstable ? why_time : why_split;
        s.say(DiagnoseProgress::Stage::Remainder,
              "constancy: " + lab + " is not constant over the recording; kept in the fit, not named");
      }
    }
  }
}

void checkConfounding(State& s) {
  const io::Recording& rec = s.rec;
  const DiagnoseOptions& o = s.o;
  DiagnosisReport& rep = s.rep;
  Candidate& cur = s.cur;
  const std::vector<char>& evaluable = s.evaluable;
  const int rows = rec.rows();
  auto remainderVariable = [&]() { return remainderVariableOf(s); };
  // 3c. Confounding with the remainder: an effect is named only if it explains something that a generic smooth
  // correction of every measured component along the remainder's variable (Fourier series up to 3 harmonics for
  // an angle, a cubic for a translation or time) does not. Both models -- with and without the effect -- get the
  // correction (profiled out by linear least squares), so its own parameters cancel; an effect whose BIC gain then
  // falls below the threshold could be part of the unexplained physics and is reported as a partial explanation,
  // not named in the verdict.
  if (!rep.unexplained.present || cur.fit.effects.empty()) return;
  {
    const std::unique_ptr<ConfigVariable> v = remainderVariable();
    Eigen::VectorXd x(rows);
    bool angle = v && v->angle;
    for (int k = 0; k < rows; ++k) x[k] = v ? v->value[k] : (rec.hasTime() ? rec.time[k] : k);
    const double xlo = x.minCoeff(), xhi = x.maxCoeff();
    const int nb = angle ? 7 : 4;
    auto basis = [&](int k, int b) {
      if (angle) return b == 0 ? 1.0 : (b % 2 ? std::cos((b + 1) / 2 * x[k]) : std::sin(b / 2 * x[k]));
      const double t = xhi > xlo ? 2 * (x[k] - xlo) / (xhi - xlo) - 1 : 0.0;
      return std::pow(t, b);
    };
    auto projectedBic = [&](const Residuals& r, const std::vector<char>& m, int k) {
      double b = 0;
      int total = 0;
      for (Quantity q : presentQuantities(rec)) {
        const Eigen::MatrixXd& R = r.of(q);
        double rss = 0;
        int n = 0;
        for (Eigen::Index c = 0; c < R.cols(); ++c) {
          std::vector<int> idx;
          for (int kk = 0; kk < rows; ++kk)
            if (m[static_cast<std::size_t>(kk)] && std::isfinite(R(kk, c))) idx.push_back(kk);
          if (static_cast<int>(idx.size()) <= nb) continue;
          Eigen::MatrixXd B(static_cast<Eigen::Index>(idx.size()), nb);
          Eigen::VectorXd y(static_cast<Eigen::Index>(idx.size()));
          for (std::size_t i = 0; i < idx.size(); ++i) {
            for (int bb = 0; bb < nb; ++bb) B(static_cast<Eigen::Index>(i), bb) = basis(idx[i], bb);
            y[static_cast<Eigen::Index>(i)] = R(idx[i], c);
          }
          const Eigen::VectorXd coef = B.colPivHouseholderQr().solve(y);
          rss += (y - B * coef).squaredNorm();
          n += static_cast<int>(idx.size());
        }
        if (n == 0) continue;
        b += n * std::log(std::max(1e-300, rss / n));
        total += n;
      }
      return b + k * std::log(std::max(1, total));
    };
    if (s.without.size() != cur.fit.effects.size()) refitEachWithout(s);
    const std::string vname = v ? v->name : "time";
    for (std::size_t j = 0; j < cur.fit.effects.size(); ++j) {
      if (isGeneric(cur.fit.effects[j].kind)) continue;              // a description of the remainder, never named
      if (s.confounded.count(cur.fit.effects[j].label())) continue;  // not constant: already not named
      const FitResult& f = s.without[j];
      const std::vector<char> m = commonRows(cur.fit.residuals, f.residuals, evaluable);
      const int k = coordinateCount(cur.fit.effects), kw = coordinateCount(f.effects);
      const double plain = bic(rec, f.residuals, m, kw) - bic(rec, cur.fit.residuals, m, k);
      const double d = projectedBic(f.residuals, m, kw) - projectedBic(cur.fit.residuals, m, k);
      const std::string lab = cur.fit.effects[j].label();
      s.say(DiagnoseProgress::Stage::Remainder, "confounding: " + lab +
                                                    fmt(" BIC gain %.1f; with a smooth correction along ", plain) +
                                                    vname + fmt(" %.1f", d));
      if (d < o.bic_threshold) {
        s.confounded.insert(lab);
        s.removed_partial[lab] =
            std::string("a smooth correction of the outputs along ") + vname +
            fmt(" -- a stand-in for the unexplained remainder -- does what it does (its BIC gain drops from %.1f to "
                "%.1f): it may be part of physics the library does not have, so it is a partial explanation, not named",
                plain, d);
      }
    }
  }
}

}  // namespace

void checkProxies(State& s) {
  checkConstancy(s);
  checkConfounding(s);
}

}  // namespace ctr::diagnosis::detail
