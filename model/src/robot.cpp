#include "ctr/model/robot.hpp"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <utility>

namespace ctr {
namespace {

constexpr double kPi = 3.14159265358979323846;

std::string where(const Tube& t, int index) {
  std::ostringstream os;
  os << "tube '" << t.name << "' (" << index + 1 << ")";
  return os.str();
}

}  // namespace

std::string validateTube(const Tube& t, int index) {
  auto bad = [&](const char* key, const std::string& what) {
    return where(t, index) + ": key '" + key + "': " + what;
  };
  auto finite = [](double v) { return std::isfinite(v); };
  if (!finite(t.straight_length) || t.straight_length < 0.0)
    return bad("straight_length", "must be a finite length >= 0 m");
  if (!finite(t.curved_length) || t.curved_length < 0.0)
    return bad("curved_length", "must be a finite length >= 0 m");
  if (t.length() <= 0.0) return bad("curved_length", "tube has zero total length");
  if (!finite(t.curvature)) return bad("curvature", "must be finite");
  if (!finite(t.bending_stiffness) || t.bending_stiffness <= 0.0)
    return bad("bending_stiffness", "must be > 0 N m^2");
  if (!finite(t.torsional_stiffness) || t.torsional_stiffness <= 0.0)
    return bad("torsional_stiffness", "must be > 0 N m^2");
  if (t.poisson_ratio && (!finite(*t.poisson_ratio) || *t.poisson_ratio <= -1.0))
    return bad("poisson_ratio", "must be finite and > -1");
  if (!finite(t.outer_diameter) || t.outer_diameter < 0.0)
    return bad("outer_diameter", "must be >= 0 m");
  if (!finite(t.inner_diameter) || t.inner_diameter < 0.0)
    return bad("inner_diameter", "must be >= 0 m");
  if (t.outer_diameter > 0.0 && t.inner_diameter >= t.outer_diameter)
    return bad("inner_diameter", "must be smaller than outer_diameter");
  if (!finite(t.linear_density) || t.linear_density < 0.0) return bad("linear_density", "must be finite and >= 0 kg/m");
  if (t.rotation_limits) {
    auto [lo, hi] = *t.rotation_limits;
    if (!finite(lo) || !finite(hi) || lo > hi) return bad("rotation_limits", "must be finite [min, max] with min <= max");
  }
  if (t.translation_limits) {
    auto [lo, hi] = *t.translation_limits;
    if (!finite(lo) || !finite(hi) || lo > hi)
      return bad("translation_limits", "must be finite [min, max] with min <= max");
    if (hi > 0.0) return bad("translation_limits", "beta must be <= 0 (tubes leave the actuation unit at s = 0)");
  }
  // The drives (actuation.hpp): keys as in the robot description's `actuation:` block.
  for (const bool rotation : {true, false}) {
    const Drive& d = rotation ? t.rotation_drive : t.translation_drive;
    const std::string axis = rotation ? "actuation.rotation." : "actuation.translation.";
    auto badDrive = [&](const std::string& key, const std::string& what) {
      return where(t, index) + ": key '" + axis + key + "': " + what;
    };
    for (const auto& [key, v] : {std::pair<const char*, double>{"offset", d.offset},
                                 {"play", d.play},
                                 {"ratio_error", d.ratio_error},
                                 {"ratio_reference", d.ratio_reference},
                                 {"stage_reference", d.stage_reference},
                                 {"stage_scale", d.stage_scale}})
      if (!finite(v)) return badDrive(key, "must be finite");
    for (double p : d.periodic)
      if (!finite(p)) return badDrive("periodic", "must be finite");
    for (double c : d.stage)
      if (!finite(c)) return badDrive("stage_error", "must be finite");
    if (d.play < 0.0) return badDrive("play", "must be >= 0 (the full width of the dead band)");
    if (rotation && d.play >= 2 * kPi) return badDrive("play", "must be less than a turn (2 pi rad)");
    if (!rotation && d.play >= t.length()) return badDrive("play", "must be shorter than the tube");
    if (rotation && std::abs(d.offset) > kPi)
      return badDrive("offset", "must be within half a turn (|offset| <= pi rad)");
    if (!rotation && std::abs(d.offset) >= t.length()) return badDrive("offset", "must be shorter than the tube");
    if (std::abs(d.ratio_error) >= 1.0) return badDrive("ratio_error", "must be within (-1, 1) (a fraction)");
    if (!(d.stage_scale > 0.0)) return badDrive("stage_scale", "must be > 0");
    if (!rotation && (d.periodic[0] != 0 || d.periodic[1] != 0 || d.periodic[2] != 0 || d.periodic[3] != 0))
      return badDrive("periodic", "is an error of rotation drives");
    if (rotation && (d.stage[0] != 0 || d.stage[1] != 0 || d.stage[2] != 0))
      return badDrive("stage_error", "is an error of translation stages");
  }
  return {};
}

Robot::Robot(std::string name, std::vector<Tube> tubes, FrictionCoefficients friction, Loads loads)
    : name_(std::move(name)), tubes_(std::move(tubes)), friction_(friction), loads_(loads) {
  if (tubes_.empty()) throw std::invalid_argument("key 'tubes': a robot needs at least one tube");
  for (int i = 0; i < size(); ++i) {
    const std::string err = validateTube(tubes_[static_cast<std::size_t>(i)], i);
    if (!err.empty()) throw std::invalid_argument(err);
  }
  // Nesting: tube i+1 must fit inside tube i where diameters are known.
  for (int i = 0; i + 1 < size(); ++i) {
    const Tube& o = tubes_[static_cast<std::size_t>(i)];
    const Tube& in = tubes_[static_cast<std::size_t>(i + 1)];
    if (o.inner_diameter > 0.0 && in.outer_diameter > 0.0 && in.outer_diameter > o.inner_diameter) {
      std::ostringstream os;
      os << where(in, i + 1) << ": key 'outer_diameter': " << in.outer_diameter
         << " m does not fit inside " << where(o, i) << " (inner_diameter " << o.inner_diameter
         << " m); tubes are listed outermost first";
      throw std::invalid_argument(os.str());
    }
    if (o.outer_diameter > 0.0 && in.outer_diameter > 0.0 && in.outer_diameter >= o.outer_diameter) {
      std::ostringstream os;
      os << where(in, i + 1) << ": key 'outer_diameter': " << in.outer_diameter << " m is not smaller than "
         << where(o, i) << "'s outer diameter " << o.outer_diameter << " m; tubes are listed outermost first";
      throw std::invalid_argument(os.str());
    }
  }
  if (!std::isfinite(friction_.boundary) || friction_.boundary < 0.0)
    throw std::invalid_argument("friction: key 'boundary': must be finite and >= 0");
  if (!std::isfinite(friction_.distributed) || friction_.distributed < 0.0)
    throw std::invalid_argument("friction: key 'distributed': must be finite and >= 0");
  if (!loads_.gravity.allFinite()) throw std::invalid_argument("loads: key 'gravity': must be finite");
  if (!loads_.tip_force.allFinite()) throw std::invalid_argument("loads: key 'tip_force': must be finite");
  if (!loads_.tip_moment.allFinite()) throw std::invalid_argument("loads: key 'tip_moment': must be finite");
}

bool Robot::hasWeight() const {
  for (const Tube& t : tubes_)
    if (t.linear_density > 0.0) return true;
  return false;
}

Robot Robot::withFriction(FrictionCoefficients f) const { return Robot(name_, tubes_, f, loads_); }

Robot Robot::withLoads(const Loads& loads) const { return Robot(name_, tubes_, friction_, loads); }

Robot Robot::withoutActuation() const {
  std::vector<Tube> tubes = tubes_;
  for (Tube& t : tubes) {
    t.rotation_drive = Drive{};
    t.translation_drive = Drive{};
  }
  return Robot(name_, std::move(tubes), friction_, loads_);
}

Robot Robot::withTube(int i, const Tube& t) const {
  std::vector<Tube> tubes = tubes_;
  tubes.at(static_cast<std::size_t>(i)) = t;
  return Robot(name_, std::move(tubes), friction_, loads_);
}

}  // namespace ctr
