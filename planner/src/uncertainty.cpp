#include "ctr/planner/uncertainty.hpp"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include "ctr/io/file.hpp"
#include "ctr/io/input_error.hpp"
#include "ctr/model/configuration.hpp"

namespace ctr::planner {
namespace {

using Kind = RangeDimension::Kind;

bool isDrive(Kind k) {
  return k != Kind::BoundaryFriction && k != Kind::DistributedFriction;
}

bool isRotation(Kind k) {
  return k == Kind::RotationOffset || k == Kind::RotationPlay;
}

bool isPlay(Kind k) {
  return k == Kind::RotationPlay || k == Kind::TranslationPlay;
}

Drive& driveOf(Tube& t, Kind k) {
  return isRotation(k) ? t.rotation_drive : t.translation_drive;
}

void set(Robot& robot, const RangeDimension& d, double v) {
  if (d.kind == Kind::BoundaryFriction || d.kind == Kind::DistributedFriction) {
    FrictionCoefficients f = robot.friction();
    (d.kind == Kind::BoundaryFriction ? f.boundary : f.distributed) = v;
    robot = robot.withFriction(f);
    return;
  }
  Tube t = robot.tube(d.tube - 1);
  Drive& drive = driveOf(t, d.kind);
  (isPlay(d.kind) ? drive.play : drive.offset) = v;
  robot = robot.withTube(d.tube - 1, t);
}

}  // namespace

std::string RangeDimension::name() const {
  switch (kind) {
    case Kind::BoundaryFriction:
      return "friction.boundary";
    case Kind::DistributedFriction:
      return "friction.distributed";
    case Kind::RotationOffset:
      return "tube " + std::to_string(tube) + " rotation offset";
    case Kind::RotationPlay:
      return "tube " + std::to_string(tube) + " rotation play";
    case Kind::TranslationOffset:
      return "tube " + std::to_string(tube) + " translation offset";
    case Kind::TranslationPlay:
      return "tube " + std::to_string(tube) + " translation play";
  }
  return "?";
}

void checkRanges(const Robot& robot, const RobotRanges& ranges) {
  std::vector<double> lo, hi;
  for (std::size_t i = 0; i < ranges.size(); ++i) {
    const RangeDimension& d = ranges[i];
    const std::string name = "range of " + d.name();
    if (isDrive(d.kind) && (d.tube < 1 || d.tube > robot.size()))
      throw std::invalid_argument(name + ": the robot has tubes 1-" + std::to_string(robot.size()));
    if (!(std::isfinite(d.lo) && std::isfinite(d.hi)) || d.lo > d.hi)
      throw std::invalid_argument(name + ": needs finite lo <= hi");
    for (std::size_t j = 0; j < i; ++j)
      if (ranges[j].kind == d.kind && ranges[j].tube == d.tube) throw std::invalid_argument(name + ": given twice");
    lo.push_back(d.lo);
    hi.push_back(d.hi);
  }
  // The values: the robot description's own checks (Robot, withTube, withFriction) at both ends of every range.
  for (const std::vector<double>* end : {&lo, &hi}) {
    try {
      robotAt(robot, ranges, *end);
    } catch (const std::invalid_argument& e) {
      throw std::invalid_argument(std::string("a range's ") + (end == &lo ? "lower" : "upper") + " end: " + e.what());
    }
  }
}

Robot robotAt(const Robot& robot, const RobotRanges& ranges, const std::vector<double>& values) {
  if (values.size() != ranges.size()) throw std::invalid_argument("robotAt: one value per range");
  Robot r = robot;
  for (std::size_t i = 0; i < ranges.size(); ++i) set(r, ranges[i], values[i]);
  return r;
}

Configuration RobustCorner::joints(const Configuration& q) const {
  Configuration c = q;
  c.alpha += shift.alpha;
  c.beta += shift.beta;
  DriveState none;
  return jointsOf(drives, c, none);
}

std::string unwrappedCommandDependence(const Robot& robot) {
  for (int i = 0; i < robot.size(); ++i)
    if (robot.tube(i).rotation_drive.ratio_error != 0.0)
      return "tube " + std::to_string(i + 1) +
             "'s rotation drive has a ratio error (the joint depends on the unwrapped command)";
  return "";
}

std::vector<RobustCorner> robustCorners(const Robot& robot, const RobotRanges& ranges) {
  const std::string unwrapped = unwrappedCommandDependence(robot);
  if (!unwrapped.empty()) throw std::invalid_argument(unwrapped);
  const int n = robot.size();
  // Friction at its upper bounds; each drive's offset range and widest play.
  Robot upper = robot;
  for (const RangeDimension& d : ranges)
    if (!isDrive(d.kind) || isPlay(d.kind)) set(upper, d, d.hi);
  struct Axis {
    bool rotation;
    int tube;  // 0-based
    double offset_lo, offset_hi, half_play;
  };
  std::vector<Axis> axes;
  for (int i = 0; i < n; ++i)
    for (const bool rotation : {true, false}) {
      const Drive& d = rotation ? upper.tube(i).rotation_drive : upper.tube(i).translation_drive;
      Axis a{rotation, i, d.offset, d.offset, 0.5 * d.play};
      for (const RangeDimension& r : ranges)
        if (isDrive(r.kind) && !isPlay(r.kind) && r.tube == i + 1 && isRotation(r.kind) == rotation) {
          a.offset_lo = r.lo;
          a.offset_hi = r.hi;
        }
      if (a.half_play > 0.0 || a.offset_hi > a.offset_lo) axes.push_back(a);
    }
  // The memoryless robot: no plays.
  Robot base = upper;
  for (int i = 0; i < n; ++i) {
    Tube t = base.tube(i);
    t.rotation_drive.play = 0.0;
    t.translation_drive.play = 0.0;
    base = base.withTube(i, t);
  }
  std::vector<RobustCorner> corners;
  const std::size_t count = std::size_t{1} << axes.size();
  for (std::size_t c = 0; c < count; ++c) {
    Robot r = base;
    Configuration shift(Eigen::VectorXd::Zero(n), Eigen::VectorXd::Zero(n));
    for (std::size_t a = 0; a < axes.size(); ++a) {
      const Axis& x = axes[a];
      const bool high = (c >> a) & 1u;
      Tube t = r.tube(x.tube);
      (x.rotation ? t.rotation_drive : t.translation_drive).offset = high ? x.offset_hi : x.offset_lo;
      r = r.withTube(x.tube, t);
      (x.rotation ? shift.alpha : shift.beta)[x.tube] = high ? x.half_play : -x.half_play;
    }
    corners.push_back(RobustCorner{r, r.withoutActuation(), shift});
  }
  return corners;
}

std::vector<std::vector<double>> rangeReplayPoints(const RobotRanges& ranges, int samples, std::uint64_t seed) {
  std::vector<std::size_t> open;  // ranges with lo < hi
  for (std::size_t i = 0; i < ranges.size(); ++i)
    if (ranges[i].hi > ranges[i].lo) open.push_back(i);
  std::vector<std::vector<double>> points;
  std::vector<double> lo(ranges.size());
  for (std::size_t i = 0; i < ranges.size(); ++i) lo[i] = ranges[i].lo;
  for (std::size_t c = 0; c < (std::size_t{1} << open.size()); ++c) {
    std::vector<double> p = lo;
    for (std::size_t a = 0; a < open.size(); ++a)
      if ((c >> a) & 1u) p[open[a]] = ranges[open[a]].hi;
    points.push_back(std::move(p));
  }
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int s = 0; s < samples; ++s) {
    std::vector<double> p = lo;
    for (std::size_t i = 0; i < ranges.size(); ++i) p[i] = ranges[i].lo + u(gen) * (ranges[i].hi - ranges[i].lo);
    points.push_back(std::move(p));
  }
  return points;
}

RobotRanges rangesFromDiagnosis(const std::string& path, std::vector<std::string>* skipped) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(io::readFile(path));
  } catch (const nlohmann::json::exception& e) {
    throw io::InputError(path, 0, "", std::string("not a JSON file: ") + e.what());
  }
  if (!j.is_object() || !j.contains("final") || !j["final"].is_object() || !j.contains("findings"))
    throw io::InputError(path, 0, "final", "not a diagnosis (ctr diagnose --json): no final model and findings");
  const nlohmann::json effects = j["final"].value("effects", nlohmann::json::array());
  // Named: an accepted finding with `named` true of the same effect and tube.
  auto named = [&](const std::string& effect, int tube) {
    for (const auto& f : j["findings"])
      if (f.value("effect", "") == effect && f.value("accepted", false) && f.value("named", false) &&
          f.value("parameters", nlohmann::json::object()).value("tube", 0) == tube)
        return true;
    return false;
  };
  struct Known {
    const char* effect;
    Kind kind;
  };
  const Known known[] = {
      {"boundary_friction", Kind::BoundaryFriction},   {"distributed_friction", Kind::DistributedFriction},
      {"actuator_backlash", Kind::RotationPlay},       {"actuator_offset", Kind::RotationOffset},
      {"translation_backlash", Kind::TranslationPlay}, {"translation_offset", Kind::TranslationOffset}};
  RobotRanges out;
  for (const auto& e : effects) {
    const std::string effect = e.value("effect", "");
    const int tube = e.value("tube", 0);
    if (!named(effect, tube)) continue;
    const Known* k = nullptr;
    for (const Known& x : known)
      if (effect == x.effect) k = &x;
    const auto iv = e.find("interval95");
    if (!k || iv == e.end() || !iv->is_array() || iv->size() != 2 || !(*iv)[0].is_number() || !(*iv)[1].is_number()) {
      if (skipped) skipped->push_back(effect + (tube > 0 ? "[tube " + std::to_string(tube) + "]" : ""));
      continue;
    }
    RangeDimension d;
    d.kind = k->kind;
    d.tube = tube;
    d.lo = (*iv)[0].get<double>();
    d.hi = (*iv)[1].get<double>();
    if (!isDrive(d.kind) || isPlay(d.kind)) d.lo = std::max(0.0, d.lo);  // a 95 % interval reaching below zero
    out.push_back(d);
  }
  return out;
}

}  // namespace ctr::planner
