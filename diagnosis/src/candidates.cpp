// The candidate slots of a recording, and decimation of long recordings.
#include <algorithm>

#include "ctr/diagnosis/diagnose.hpp"
#include "ctr/diagnosis/noise.hpp"

namespace ctr::diagnosis {

namespace {
bool hasKind(const std::vector<EffectKind>& ks, EffectKind k) {
  return ks.empty() || std::find(ks.begin(), ks.end(), k) != ks.end();
}
}  // namespace

std::vector<Effect> candidateSlots(const Robot& nominal, const io::Recording& rec, const DiagnoseOptions& o) {
  std::vector<Effect> s;
  const int n = nominal.size();
  auto add = [&](EffectKind k, int tube) {
    if (!hasKind(o.candidates, k)) return;
    s.push_back(nominalEffect(nominal, k, tube));
  };
  // Does tube i (0-based) rotate (absolute) or translate in the recording?
  auto varies = [&](Eigen::VectorXd Configuration::*joint, int i) {
    double lo = 1e300, hi = -1e300;
    for (const auto& q : rec.commands) {
      lo = std::min(lo, (q.*joint)[i]);
      hi = std::max(hi, (q.*joint)[i]);
    }
    return hi - lo > 1e-6;
  };
  auto rotates = [&](int i) { return varies(&Configuration::alpha, i); };
  auto translates = [&](int i) { return varies(&Configuration::beta, i); };
  if (n >= 2) {
    add(EffectKind::BoundaryFriction, 0);
    add(EffectKind::DistributedFriction, 0);
    add(EffectKind::TorsionalStiffness, 0);
  }
  for (int i = 1; i <= n; ++i)
    if (nominal.tube(i - 1).curved_length > 0 && nominal.tube(i - 1).curvature != 0) add(EffectKind::Precurvature, i);
  for (int i = 2; i <= n; ++i) add(EffectKind::BendingStiffness, i);
  for (int i = 1; i <= n; ++i)
    if (rotates(i - 1)) add(EffectKind::ActuatorBacklash, i);
  // Offsets: in an unknown frame a rotation of the whole robot is absorbed by the registration, so an offset of tube 1
  // is one of all the other tubes by the opposite angle -- a hypothesis of its own only with three tubes or more
  // (with two it is tube 2's offset).
  for (int i = (o.frame == FrameMode::Base || n >= 3 ? 1 : 2); i <= n; ++i) add(EffectKind::ActuatorOffset, i);
  bool any_translation = false;
  for (int i = 1; i <= n; ++i) {
    if (!translates(i - 1)) continue;
    any_translation = true;
    add(EffectKind::TranslationBacklash, i);
  }
  // A zero error of one stage changes how far that tube extends relative to the others (a common shift of all
  // tubes moves the tip along z: absorbed by the registration in an unknown frame, observable in the base frame).
  if (any_translation)
    for (int i = 1; i <= n; ++i) add(EffectKind::TranslationOffset, i);
  // External loads (screened at first order before any loaded fit; diagnose()). Gravity needs a weight: the
  // description's linear densities, or nitinol's density with the diameters.
  if (gravityUnavailable(nominal).empty()) add(EffectKind::Gravity, 0);
  add(EffectKind::TipLoad, 0);
  if (rec.hasTime() && rec.rows() > 2 && rec.time[rec.rows() - 1] > rec.time[0]) add(EffectKind::SensorLatency, 0);
  return s;
}

io::Recording decimateRecording(const io::Recording& in, int k) {
  io::Recording out;
  out.tubes = in.tubes;
  const int rows = in.rows();
  std::vector<int> keep;
  for (int r = 0; r < rows; r += k) keep.push_back(r);
  auto take = [&](const Eigen::MatrixXd& M) {
    if (M.cols() == 0) return Eigen::MatrixXd(0, 0);
    Eigen::MatrixXd o(static_cast<Eigen::Index>(keep.size()), M.cols());
    for (std::size_t j = 0; j < keep.size(); ++j) o.row(static_cast<Eigen::Index>(j)) = M.row(keep[j]);
    return o;
  };
  for (int r : keep) out.commands.push_back(in.commands[static_cast<std::size_t>(r)]);
  out.twist = take(in.twist);
  out.tip_position = take(in.tip_position);
  out.tip_tangent = take(in.tip_tangent);
  if (in.hasTime()) out.time = take(in.time);
  return out;
}

io::Recording diagnosedRows(const io::Recording& rec, int stride) {
  const io::Recording visits = collapseFrames(rec).recording;
  return stride > 1 ? decimateRecording(visits, stride) : visits;
}

}  // namespace ctr::diagnosis
