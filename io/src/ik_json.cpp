#include "ctr/io/ik_json.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace ctr::io {
namespace {

nlohmann::json number(double v) {
  return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json vec(const Eigen::VectorXd& v) {
  nlohmann::json a = nlohmann::json::array();
  for (Eigen::Index i = 0; i < v.size(); ++i) a.push_back(number(v[i]));
  return a;
}

nlohmann::json answer(const IkReport::Row& r, bool with_direction) {
  const IkSummary& s = r.summary;
  nlohmann::json j;
  j["reached"] = s.reached();
  j["status"] = toString(s.status);
  j["alpha"] = vec(r.q.alpha);
  j["beta"] = vec(r.q.beta);
  j["tip_error"] = number(s.tip_error);
  j["closest"] = s.status == IkStatus::Failed ? nlohmann::json(nullptr) : vec(s.closest);
  if (with_direction) j["direction_error"] = number(s.direction_error);
  j["stable"] = s.stable;
  j["stability"] = number(s.stability);
  j["branch_dependent"] = s.branch_dependent;
  j["iterations"] = s.iterations;
  j["evaluations"] = s.evaluations;
  j["starts"] = s.starts;
  j["message"] = s.message;
  if (r.cost && r.cost->blind_q.size() == 0) {
    // Not computed (a path without the friction-blind comparison after its first target).
    j["friction"] = {{"blind_alpha", nullptr},    {"blind_beta", nullptr},      {"blind_reached", nullptr},
                     {"blind_tip", nullptr},      {"blind_tip_error", nullptr}, {"alpha_difference", nullptr},
                     {"beta_difference", nullptr}};
  } else if (r.cost) {
    const FrictionCost& c = *r.cost;
    nlohmann::json f;
    f["blind_alpha"] = vec(c.blind_q.alpha);
    f["blind_beta"] = vec(c.blind_q.beta);
    f["blind_reached"] = c.blind_reached;
    f["blind_tip"] = vec(c.blind_tip);
    f["blind_tip_error"] = number(c.blind_tip_error);
    f["alpha_difference"] = number(c.alpha_difference);
    f["beta_difference"] = number(c.beta_difference);
    j["friction"] = f;
  }
  if (r.joints && r.joints->size() == r.q.size()) {
    // The drives' compensation: where the commands put the tubes, and how far the commands are from those joints
    // (the commands of the description without actuation).
    const bool known = r.q.size() > 0;
    j["drives"] = {{"joint_alpha", vec(r.joints->alpha)},
                   {"joint_beta", vec(r.joints->beta)},
                   {"alpha_difference",
                    known ? number((r.q.alpha - r.joints->alpha).cwiseAbs().maxCoeff()) : nlohmann::json(nullptr)},
                   {"beta_difference",
                    known ? number((r.q.beta - r.joints->beta).cwiseAbs().maxCoeff()) : nlohmann::json(nullptr)}};
  }
  return j;
}

// RMS and largest of finite values; NaN (the blind step did not converge) makes the largest infinite (null).
double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}
double largest(const std::vector<double>& v) {
  double m = 0.0;
  for (double x : v) m = std::isfinite(x) ? std::max(m, x) : std::numeric_limits<double>::infinity();
  return m;
}

}  // namespace

std::string ikReportJson(const IkReport& rep, int indent) {
  nlohmann::json fr;
  if (rep.friction) {
    fr["boundary"] = rep.friction->boundary;
    fr["history"] = rep.friction->history;
    fr["approach"] = rep.friction->approach;
    fr["start_alpha"] = vec(rep.friction->start.alpha);
    fr["start_beta"] = vec(rep.friction->start.beta);
    fr["start_rows"] = rep.friction->start_rows;
  }
  nlohmann::json j;
  if (!rep.path) {
    if (rep.rows.size() != 1) throw std::invalid_argument("ikReportJson: one answer expected without a path");
    j = answer(rep.rows.front(), rep.with_direction);
    if (rep.friction) j["friction"].update(fr);
  } else {
    std::vector<double> errors, blind;
    int reached = 0;
    nlohmann::json rows = nlohmann::json::array();
    for (const IkReport::Row& r : rep.rows) {
      rows.push_back(answer(r, rep.with_direction));
      errors.push_back(r.summary.tip_error);
      if (r.cost) blind.push_back(r.cost->blind_tip_error);
      reached += r.summary.reached();
    }
    j["reached"] = reached == static_cast<int>(rep.rows.size());
    j["targets"] = rep.rows.size();
    j["reached_count"] = reached;
    j["tip_error_max"] = number(largest(errors));
    j["tip_error_rms"] = number(rms(errors));
    if (rep.friction) {
      fr["blind_tip_error_max"] = number(largest(blind));
      fr["blind_tip_error_rms"] = number(rms(blind));
      j["friction"] = fr;
    }
    j["rows"] = rows;
  }
  j["robot"] = rep.robot;
  return j.dump(indent);
}

}  // namespace ctr::io
