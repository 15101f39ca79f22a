// Diagnosis output: the JSON of docs/formats.md "Diagnosis", Markdown report, plot data.
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <sstream>

#include "ctr/diagnosis/diagnose.hpp"
#include "diagnosis_state.hpp"

namespace ctr::diagnosis {

namespace {
using nlohmann::json;

json num(double v) {
  return std::isfinite(v) ? json(v) : json(nullptr);
}

json mapJson(const std::map<std::string, double>& m) {
  json j = json::object();
  for (const auto& kv : m) j[kv.first] = num(kv.second);
  return j;
}

json scoreJson(const ModelScore& s) {
  json j;
  j["model"] = s.model;
  j["heldout_rmse"] = mapJson(s.heldout_rmse);
  j["fit_rmse"] = mapJson(s.fit_rmse);
  j["last_block_heldout_rmse"] = mapJson(s.last_block_rmse);
  j["heldout_score"] = num(s.heldout_score);
  j["bic"] = num(s.bic);
  return j;
}

json mismatchJson(const MismatchFinding& f) {
  return json{{"signature", f.signature},  {"variable", f.variable},        {"quantity", f.quantity},
              {"p_value", num(f.p_value)}, {"statistic", num(f.statistic)}, {"where", f.where}};
}

json matrixJson(const Eigen::MatrixXd& M) {
  json a = json::array();
  for (Eigen::Index r = 0; r < M.rows(); ++r) {
    json row = json::array();
    for (Eigen::Index c = 0; c < M.cols(); ++c) row.push_back(num(M(r, c)));
    a.push_back(row);
  }
  return a;
}

json vectorJson(const Eigen::VectorXd& v) {
  json a = json::array();
  for (Eigen::Index k = 0; k < v.size(); ++k) a.push_back(num(v[k]));
  return a;
}

json binsJson(const std::vector<BinSummary>& bins) {
  json a = json::array();
  for (const BinSummary& b : bins)
    a.push_back(json{{"variable", b.variable},
                     {"quantity", b.quantity},
                     {"lo", num(b.lo)},
                     {"hi", num(b.hi)},
                     {"direction", b.direction},
                     {"count", b.count},
                     {"mean", num(b.mean)},
                     {"rms", num(b.rms)}});
  return a;
}

// A parameter's value: a number, or an array for a vector parameter (force, direction).
json paramValueJson(const NamedParameter& p) {
  if (p.name == "tube") return json(static_cast<int>(p.value.front()));
  if (p.value.size() == 1) return num(p.value.front());
  json a = json::array();
  for (double v : p.value) a.push_back(num(v));
  return a;
}

// A parameter's 95 % interval: [lo, hi], or one [lo, hi] per component of a vector parameter.
json paramIntervalJson(const NamedParameter& p) {
  auto iv = [](const std::array<double, 2>& x) { return json::array({num(x[0]), num(x[1])}); };
  if (p.interval95.size() == 1) return iv(p.interval95.front());
  json a = json::array();
  for (const auto& x : p.interval95) a.push_back(iv(x));
  return a;
}

json parametersJson(const std::vector<NamedParameter>& ps) {
  json j = json::object();
  for (const NamedParameter& p : ps) j[p.name] = paramValueJson(p);
  return j;
}

json intervalsJson(const std::vector<NamedParameter>& ps) {
  json j = json::object();
  for (const NamedParameter& p : ps)
    if (!p.interval95.empty()) j[p.name] = paramIntervalJson(p);
  return j;
}

// An effect of a final model: {"effect": name, "tube": k, "<parameter>": value, "interval95": ...}.
json effectJson(const Effect& e, const EffectUncertainty* u) {
  const std::vector<NamedParameter> ps = namedParameters(e, u);
  json x{{"effect", toString(e.kind)}};
  for (const NamedParameter& p : ps) x[p.name] = paramValueJson(p);
  // One-parameter kinds: "interval95": [lo, hi] (as before); kinds with several parameters: one per parameter,
  // {"scale": [lo, hi], "direction": [[lo, hi], [lo, hi], [lo, hi]]} or {"force": [[lo, hi], x3]}.
  if (parameterCount(e.kind) == 1) {
    for (const NamedParameter& p : ps)
      if (p.name != "tube" && !p.interval95.empty()) x["interval95"] = paramIntervalJson(p);
  } else if (!intervalsJson(ps).empty()) {
    x["interval95"] = intervalsJson(ps);
  }
  return x;
}

json registrationJson(const Registration& g) {
  json reg;
  json R = json::array();
  for (int a = 0; a < 3; ++a) R.push_back(json::array({g.rotation(a, 0), g.rotation(a, 1), g.rotation(a, 2)}));
  reg["rotation"] = R;
  reg["translation"] = json::array({g.translation.x(), g.translation.y(), g.translation.z()});
  reg["tip_offset"] = g.tip_offset;
  return reg;
}

std::string f4(double v) {
  char b[64];
  std::snprintf(b, sizeof b, "%.4g", v);
  return b;
}
}  // namespace

namespace detail {

std::string paramText(const NamedParameter& p) {
  char b[64];
  std::string t = p.name + "=";
  if (p.value.size() > 1) t += "(";
  for (std::size_t i = 0; i < p.value.size(); ++i) {
    std::snprintf(b, sizeof b, "%.4g", p.value[i]);
    t += (i ? ", " : "") + std::string(b);
  }
  return t + (p.value.size() > 1 ? ")" : "");
}

std::string intervalText(const NamedParameter& p) {
  char b[128];
  std::string t;
  for (std::size_t i = 0; i < p.interval95.size(); ++i) {
    std::snprintf(b, sizeof b, "[%.4g, %.4g]", p.interval95[i][0], p.interval95[i][1]);
    t += (i ? " " : "") + std::string(b);
  }
  return t;
}

}  // namespace detail

using detail::intervalText;
using detail::paramText;

std::string reportToJson(const DiagnosisReport& r) {
  json j;
  j["verdict"] = r.verdict;
  j["baseline"] = scoreJson(r.baseline);
  json fin = scoreJson(r.final);
  json effects = json::array();
  for (const Effect& e : r.final_effects) {
    const auto u = r.final_uncertainty.find(e.label());
    effects.push_back(effectJson(e, u != r.final_uncertainty.end() ? &u->second : nullptr));
  }
  fin["effects"] = effects;
  j["final"] = fin;
  json mm = json::array();
  for (const auto& f : r.mismatch.findings) mm.push_back(mismatchJson(f));
  j["mismatch"] = mm;
  json tests = json::array();
  for (const auto& f : r.mismatch.tests) tests.push_back(mismatchJson(f));
  j["mismatch_tests"] = tests;
  json fs = json::array();
  for (const Finding& f : r.findings) {
    json x;
    x["effect"] = toString(f.effect.kind);
    x["accepted"] = f.accepted;
    x["round"] = f.round;
    x["parameters"] = parametersJson(f.parameters);
    x["interval95"] = intervalsJson(f.parameters);
    x["heldout_rmse"] = mapJson(f.heldout_rmse);
    x["heldout_p"] = num(f.heldout_p);
    x["delta_bic"] = num(f.delta_bic);
    x["model"] = [&] {
      std::string s = "nominal";
      for (const Effect& e : f.model) s += "+" + e.label();
      return s;
    }();
    if (f.accepted) {
      x["partial"] = f.partial;
      x["named"] = f.named;
      if (f.at_range_limit) x["at_range_limit"] = true;
    }
    if (!f.ambiguous_with.empty()) {
      json a = json::array();
      for (const Rival& rv : f.ambiguous_with) {
        json y{{"effect", toString(rv.effect.kind)}, {"parameters", parametersJson(namedParameters(rv.effect))},
               {"delta_bic", num(rv.delta_bic)},     {"heldout_rmse", mapJson(rv.heldout_rmse)},
               {"heldout_p", num(rv.heldout_p)},     {"why", rv.why}};
        a.push_back(y);
      }
      x["ambiguous_with"] = a;
    }
    if (std::isfinite(f.detection_limit)) x["detection_limit"] = f.detection_limit;
    x["explanation"] = f.explanation;
    fs.push_back(x);
  }
  j["findings"] = fs;
  json failed = json::array();
  for (const FailedRow& fr : r.failed_rows)
    failed.push_back(
        json{{"row", fr.row}, {"failure", toString(fr.failure)}, {"reason", fr.message}, {"model", fr.model}});
  j["failed_rows"] = failed;
  j["reliable"] = r.reliable;
  if (r.unexplained.present) {
    const Unexplained& u = r.unexplained;
    json un;
    un["fraction_explained"] = num(u.fraction_explained);
    un["heldout_rmse"] = mapJson(u.heldout_rmse);
    json nz = json::object();
    for (const auto& [q, e] : r.noise.by_quantity) nz[toString(q)] = num(e.sigma);
    un["noise"] = nz;
    json um = json::array();
    for (const auto& f : u.mismatch) um.push_back(mismatchJson(f));
    un["mismatch"] = um;
    un["heldout_ratio"] = num(u.heldout_ratio);
    un["heldout_p"] = num(u.heldout_p);
    un["where"] = u.where;
    if (!u.described.empty()) {
      json d = json::array();
      for (const GenericDescription& g : u.described)
        d.push_back(json{{"model", toString(g.model.kind)},
                         {"parameters", parametersJson(namedParameters(g.model))},
                         {"description", g.description},
                         {"delta_bic", num(g.delta_bic)},
                         {"heldout_rmse", mapJson(g.heldout_rmse)},
                         {"heldout_ratio", num(g.heldout_ratio)},
                         {"heldout_gain", num(g.heldout_gain)},
                         {"heldout_p", num(g.heldout_p)},
                         {"replaces", g.replaces}});
      un["described"] = d;
    }
    j["unexplained"] = un;
  }
  json branch = json::array();
  for (const BranchAmbiguousRow& b : r.branch_ambiguous_rows) {
    json a = json::array();
    for (double mm : b.alternatives_mm) a.push_back(num(mm));
    branch.push_back(json{{"row", b.row}, {"alternatives_mm", a}, {"excluded", b.excluded}});
  }
  j["branch_ambiguous_rows"] = branch;
  json outliers = json::array();
  for (const OutlierRow& o : r.outlier_rows)
    outliers.push_back(
        json{{"row", o.row}, {"quantities", o.quantities}, {"residual_over_noise", num(o.residual_over_noise)}});
  j["outlier_rows"] = outliers;
  j["branch_rule"] = r.branch;
  // The noise of every quantity: sigma (per component; the tangent's per direction normal to it), its source
  // (given, repeated, neighbours), its uncertainty and whether the recording separates it from model error.
  j["noise"] = json::object();
  for (const auto& [q, e] : r.noise.by_quantity) {
    json x{{"sigma", num(e.sigma)},
           {"source", e.source},
           {"dof", std::isfinite(e.dof) ? json(e.dof) : json("infinite")},
           {"interval95", json::array({num(e.interval95[0]), num(e.interval95[1])})},
           {"supported", e.supported},
           {"white", e.white},
           {"differences", e.pairs},
           {"note", e.note}};
    if (e.jitter > 0) {
      x["jitter"] = num(e.jitter);
      x["frames"] = e.frames;
    }
    if (e.serial_ratio != 0.0)
      x["serial_correlation"] = json{{"lag2_over_lag1", num(e.serial_ratio)}, {"p", num(e.serial_p)}};
    if (q == Quantity::TipTangent) x["per"] = "direction normal to the tangent";
    j["noise"][toString(q)] = x;
  }
  j["frame"] = toString(r.frame);
  if (r.frame == FrameMode::Unknown) j["registration"] = registrationJson(r.registration);
  j["replay_discretisation"] = {{"max_step", r.discretisation.max_step},
                                {"max_bending_per_step", r.discretisation.max_bending_per_step},
                                {"error_over_noise", r.discretisation.error_over_noise},
                                {"refined", r.discretisation.refined}};
  j["rows"] = r.rows;
  j["recording_rows"] = r.recording_rows;
  j["visits"] = r.visits;
  j["stride"] = r.stride;
  j["rounds"] = r.rounds;
  j["folds"] = r.folds;
  j["seconds"] = r.seconds;
  j["replays"] = r.evaluations;
  j["warnings"] = r.warnings;
  j["summary"] = r.summary;
  return j.dump(1) + "\n";
}

std::string reportToMarkdown(const DiagnosisReport& r, const io::Recording& full) {
  const io::Recording rec = diagnosedRows(full, r.stride);
  std::ostringstream o;
  o << "# Diagnosis\n\n";
  o << "Recording: " << r.rows << " rows, " << rec.tubes << " tubes, measured:";
  for (Quantity q : presentQuantities(rec)) o << " " << toString(q);
  o << (rec.hasTime() ? ", timed" : ", untimed")
    << "; frame: " << (r.frame == FrameMode::Unknown ? "unknown (registration estimated in every model)" : "base")
    << ". Held-out scheme: " << r.folds
    << " contiguous blocks in time (stateful models replayed over the whole sequence).\n\n";
  o << "**Verdict:** ";
  if (r.verdict.empty())
    o << (!r.noise.white() && r.unexplained.present
              ? "nothing established (the noise cannot be told from these data; give --noise)"
          : r.unexplained.present ? "not explained by any candidate (a mismatch remains that no effect in the library "
                                    "explains)"
          : r.noise.supported()   ? "nothing left out (the nominal model explains the data within the noise)"
                                  : "nothing named (the residuals are no larger than the differences between "
                                    "neighbouring rows; the recording cannot tell its noise from model error)");
  for (std::size_t k = 0; k < r.verdict.size(); ++k) o << (k ? ", " : "") << "`" << r.verdict[k] << "`";
  if (!r.verdict.empty() && r.unexplained.present) o << " (partial explanation)";
  if (!r.reliable) o << " — **unreliable** (too many rows could not be evaluated)";
  o << "\n\n" << r.summary << "\n\n";
  if (r.unexplained.present) {
    const Unexplained& u = r.unexplained;
    o << "## What is left unexplained\n\n";
    o << "The " << (r.final_effects.empty() ? "nominal model" : "final model (" + r.final.model + ")") << " explains "
      << f4(100 * u.fraction_explained) << " % of the baseline's excess held-out error; " << u.where
      << ". Held-out chi-square against the noise: " << f4(u.heldout_ratio)
      << " x the noise variance (p = " << f4(u.heldout_p) << ").\n\n";
    if (!u.mismatch.empty()) {
      o << "| signature | variable | quantity | p-value | where |\n|---|---|---|---|---|\n";
      std::size_t shown = 0;
      for (const auto& f : u.mismatch)
        if (++shown <= 12)
          o << "| " << f.signature << " | " << f.variable << " | " << f.quantity << " | " << f4(f.p_value) << " | "
            << f.where << " |\n";
      o << "\n";
    }
  }
  bool any_ambiguous = false;
  for (const Finding& f : r.findings) any_ambiguous = any_ambiguous || !f.ambiguous_with.empty();
  if (any_ambiguous) {
    o << "## Look-alikes this recording cannot tell apart\n\n| accepted | rival | rival delta BIC | p (accepted "
         "predicts held-out better) | evidence |\n|---|---|---|---|---|\n";
    for (const Finding& f : r.findings)
      for (const Rival& rv : f.ambiguous_with)
        o << "| " << f.effect.label() << " | " << rv.effect.label() << " | " << f4(rv.delta_bic) << " | "
          << f4(rv.heldout_p) << " | " << rv.why << " |\n";
    o << "\n";
  }
  if (!r.failed_rows.empty()) {
    o << "## Rows the model could not evaluate\n\nExcluded from every residual, fit, noise estimate and held-out "
         "score (never replaced by another row's output).\n\n| row | model | reason |\n|---|---|---|\n";
    std::size_t shown = 0;
    for (const FailedRow& fr : r.failed_rows) {
      if (++shown > 50) {
        o << "| ... | | " << r.failed_rows.size() - 50 << " more in the JSON |\n";
        break;
      }
      o << "| " << fr.row << " | " << fr.model << " | " << fr.message << " |\n";
    }
    o << "\n";
  }
  if (!r.outlier_rows.empty()) {
    o << "## Rows that look like tracker glitches\n\nTheir residuals under the final model are far beyond the noise "
         "and the residuals of their neighbours (docs/diagnosis.md, \"Tracker glitches\"); the diagnosis was run "
         "again without them.\n\n| row | quantities | residual / noise sigma |\n|---|---|---|\n";
    for (const OutlierRow& g : r.outlier_rows) {
      o << "| " << g.row << " | ";
      for (std::size_t k = 0; k < g.quantities.size(); ++k) o << (k ? ", " : "") << g.quantities[k];
      o << " | " << f4(g.residual_over_noise) << " |\n";
    }
    o << "\n";
  }
  if (!r.branch_ambiguous_rows.empty()) {
    o << "## Rows with other stable equilibria\n\nThe replay reaches each row by the branch rule `" << r.branch
      << "` (docs/diagnosis.md). At these rows the model has other stable equilibria the robot may have reached by "
         "a path the recording does not show; rows whose measurement lies nearer one of them are excluded.\n\n| row | "
         "alternatives (tip distance, mm) | excluded |\n|---|---|---|\n";
    std::size_t shown = 0;
    for (const BranchAmbiguousRow& b : r.branch_ambiguous_rows) {
      if (++shown > 50) {
        o << "| ... | " << r.branch_ambiguous_rows.size() - 50 << " more in the JSON | |\n";
        break;
      }
      o << "| " << b.row << " | ";
      for (double mm : b.alternatives_mm) o << f4(mm) << " ";
      o << "| " << (b.excluded ? "yes" : "no") << " |\n";
    }
    o << "\n";
  }
  o << "## Noise\n\n| quantity | sigma | source | 95 % interval | degrees of freedom | how "
       "|\n|---|---|---|---|---|---|\n";
  for (const auto& [q, e] : r.noise.by_quantity) {
    const double u = q == Quantity::TipPosition ? 1e3 : 180 / M_PI;
    const std::string unit = q == Quantity::TipPosition ? " mm" : " deg";
    o << "| " << toString(q) << (q == Quantity::TipTangent ? " (per normal direction)" : "") << " | " << f4(e.sigma * u)
      << unit << " | " << e.source << (e.supported ? "" : " (upper bound)") << " | [" << f4(e.interval95[0] * u) << ", "
      << f4(e.interval95[1] * u) << "]" << unit << " | " << (std::isfinite(e.dof) ? f4(e.dof) : std::string("given"))
      << " | " << e.note << (e.jitter > 0 ? "; frame jitter " + f4(e.jitter * u) + unit : std::string()) << " |\n";
  }
  o << "\n## Where the nominal model misses\n\n";
  if (r.mismatch.findings.empty()) {
    o << "No test found residuals beyond the noise" << (r.noise.supported() ? "" : " (an upper bound of it)")
      << ".\n\n";
  } else {
    o << "| signature | variable | quantity | p-value | where |\n|---|---|---|---|---|\n";
    for (const auto& f : r.mismatch.findings)
      o << "| " << f.signature << " | " << f.variable << " | " << f.quantity << " | " << f4(f.p_value) << " | "
        << f.where << " |\n";
    o << "\n";
  }
  o << "## Candidates\n\n| effect | accepted | parameters | 95 % interval | delta BIC | held-out p | why "
       "|\n|---|---|---|---|---|---|---|\n";
  for (const Finding& f : r.findings) {
    o << "| " << f.effect.label() << " | " << (f.accepted ? "**yes**" : "no") << " | ";
    for (const NamedParameter& p : f.parameters) o << paramText(p) << " ";
    o << " | ";
    for (const NamedParameter& p : f.parameters)
      if (!p.interval95.empty())
        o << (parameterCount(f.effect.kind) > 1 ? p.name + " " : std::string()) << intervalText(p) << " ";
    o << " | " << f4(f.delta_bic) << " | " << f4(f.heldout_p) << " | " << f.explanation << " |\n";
  }
  o << "\n## Held-out error before and after\n\n| quantity | nominal | " << r.final.model << " |\n|---|---|---|\n";
  for (const auto& kv : r.baseline.heldout_rmse) {
    const double after = r.final.heldout_rmse.count(kv.first) ? r.final.heldout_rmse.at(kv.first) : kv.second;
    const bool ang = kv.first == "twist";
    const double s = ang ? 180 / M_PI : kv.first == "tip_position" ? 1e3 : 1.0;
    const char* u = ang ? " deg" : kv.first == "tip_position" ? " mm" : "";
    o << "| " << kv.first << " | " << f4(kv.second * s) << u << " | " << f4(after * s) << u << " |\n";
  }
  o << "\n";
  if (!r.final_effects.empty()) {
    o << "## Fitted parameters (all rows)\n\n| effect | parameter | value | 95 % interval |\n|---|---|---|---|\n";
    for (const Effect& e : r.final_effects) {
      const auto u = r.final_uncertainty.find(e.label());
      for (const NamedParameter& p : namedParameters(e, u != r.final_uncertainty.end() ? &u->second : nullptr)) {
        if (p.name == "tube") continue;
        const std::string unit = p.name == "direction" ? "unit vector, base frame"
                                 : p.name == "scale"   ? "x 9.81 m/s^2"
                                 : p.name == "force"   ? "N, base frame"
                                                       : parameterUnit(e.kind);
        std::string value = paramText(p);
        value = value.substr(value.find('=') + 1);
        o << "| " << e.label() << " | " << p.name << " (" << unit << ") | " << value << " | " << intervalText(p)
          << " |\n";
      }
    }
    o << "\nIntervals: Gauss-Newton with a pre-whitened Newey-West (HAC) covariance over rows, robust to serially "
         "correlated model error (never narrower than the independent-residual interval).\n\n";
  }
  for (const auto& w : r.warnings) o << "- warning: " << w << "\n";
  const ReplayDiscretisation& d = r.discretisation;
  o << "\n"
    << r.evaluations << " replays of the sequence, " << f4(r.seconds)
    << " s. Integration steps of the replays: " << f4(1e3 * d.max_step) << " mm, " << f4(d.max_bending_per_step)
    << " rad of bending";
  const KinematicsOptions library;
  if (d.refined)
    o << " (the library's default steps: the longer ones differed by " << f4(d.error_over_noise)
      << " x the noise on the nominal replay).\n";
  else if (d.max_step <= library.max_step && d.max_bending_per_step <= library.max_bending_per_step)
    o << " (the library's default steps or finer).\n";
  else
    o << "; their error on the nominal replay against the library's default steps: " << f4(d.error_over_noise)
      << " x the noise.\n";
  return o.str();
}

std::string plotDataJson(const DiagnosisReport& r, const io::Recording& full) {
  const io::Recording rec = diagnosedRows(full, r.stride);
  json j;
  j["rows"] = r.rows;
  j["final_model"] = r.final.model;
  if (rec.hasTime()) j["time"] = vectorJson(rec.time);
  json vars = json::array();
  for (const ConfigVariable& v : r.plot.variables)
    vars.push_back(json{
        {"name", v.name}, {"angle", v.angle}, {"value", vectorJson(v.value)}, {"direction", vectorJson(v.direction)}});
  j["variables"] = vars;
  json meas, nom, fit;
  if (rec.hasTwist()) {
    meas["twist"] = matrixJson(rec.twist);
    nom["twist"] = matrixJson(r.plot.nominal.twist);
    fit["twist"] = matrixJson(r.plot.fitted.twist);
  }
  if (rec.hasTipPosition()) {
    meas["tip_position"] = matrixJson(rec.tip_position);
    nom["tip_position"] = matrixJson(r.plot.nominal.tip_position);
    fit["tip_position"] = matrixJson(r.plot.fitted.tip_position);
  }
  if (rec.hasTipTangent()) {
    meas["tip_tangent"] = matrixJson(rec.tip_tangent);
    nom["tip_tangent"] = matrixJson(r.plot.nominal.tip_tangent);
    fit["tip_tangent"] = matrixJson(r.plot.fitted.tip_tangent);
  }
  j["measured"] = meas;
  j["nominal"] = nom;
  j["fitted"] = fit;
  j["moment"] = json{{"nominal", vectorJson(r.plot.nominal.moment)}, {"fitted", vectorJson(r.plot.fitted.moment)}};
  j["residual_bins"] = json{{"nominal", binsJson(r.mismatch.bins)}, {"fitted", binsJson(r.plot.final_mismatch.bins)}};
  return j.dump() + "\n";
}

std::string reportToJson(const MultiDiagnosisReport& r) {
  json j;
  json recs = json::array();
  for (std::size_t i = 0; i < r.recordings.size(); ++i) {
    json x{{"file", r.names[i]}, {"diagnosis", json::parse(reportToJson(r.recordings[i]))}};
    if (i < r.fits.size()) {
      const RecordingFit& f = r.fits[i];
      json joint;
      json effects = json::array();
      for (const Effect& e : f.effects) effects.push_back(effectJson(e, nullptr));
      joint["effects"] = effects;
      joint["fit_rmse"] = mapJson(f.fit_rmse);
      joint["own_fit_rmse"] = mapJson(f.own_fit_rmse);
      if (r.frame == FrameMode::Unknown) joint["registration"] = registrationJson(f.registration);
      x["joint_fit"] = joint;
    }
    recs.push_back(x);
  }
  j["recordings"] = recs;
  j["shared_verdict"] = r.verdict;
  json effects = json::array();
  for (const JointEffect& e : r.effects) {
    json x{{"effect", toString(e.effect.kind)}, {"agreement", toString(e.agreement)}, {"explanation", e.explanation}};
    if (isPerTube(e.effect.kind)) x["tube"] = e.effect.tube;
    if (e.agreement == Agreement::Shared) {
      x["parameters"] = parametersJson(e.parameters);
      x["interval95"] = intervalsJson(e.parameters);
    }
    json per = json::array();
    json named = json::array();
    for (const RecordingValue& v : e.per_recording) {
      per.push_back(json{{"file", r.names[static_cast<std::size_t>(v.recording)]},
                         {"parameters", parametersJson(v.parameters)},
                         {"interval95", intervalsJson(v.parameters)},
                         {"named", v.named},
                         {"supports", v.supports},
                         {"confounded", v.confounded}});
      if (v.named) named.push_back(r.names[static_cast<std::size_t>(v.recording)]);
    }
    x["per_recording"] = per;
    x["named_in"] = named;
    if (e.dof > 0) x["consistency"] = json{{"chi2", num(e.chi2)}, {"dof", e.dof}, {"p", num(e.p)}};
    effects.push_back(x);
  }
  j["effects"] = effects;
  j["frame"] = toString(r.frame);
  j["alpha"] = r.alpha;
  j["seconds"] = r.seconds;
  j["warnings"] = r.warnings;
  j["summary"] = r.summary;
  return j.dump(1) + "\n";
}

}  // namespace ctr::diagnosis
