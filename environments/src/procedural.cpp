#include "ctr/environments/procedural.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace ctr::environments {

// ---------------------------------------------------------------------------------------------------------------
// Primitives.

double Primitive::g(const Eigen::Vector3d& p) const {
  double v = 0.0;
  switch (kind) {
    case Kind::Ellipsoid: {
      const Eigen::Vector3d q = rotation.transpose() * (p - centre);
      v = (q.cwiseQuotient(radii).norm() - 1.0) * radii.minCoeff();
      break;
    }
    case Kind::Capsule: {
      const Eigen::Vector3d ab = b - a;
      const double L2 = ab.squaredNorm();
      const double t = L2 > 0.0 ? std::clamp((p - a).dot(ab) / L2, 0.0, 1.0) : 0.0;
      v = (p - (a + t * ab)).norm() - radius;
      break;
    }
    case Kind::Cylinder: {
      const Eigen::Vector3d ab = b - a;
      const double L = ab.norm();
      const Eigen::Vector3d u = L > 0 ? Eigen::Vector3d(ab / L) : Eigen::Vector3d::UnitZ();
      const Eigen::Vector3d m = 0.5 * (a + b);
      const double ax = (p - m).dot(u);
      const double rad = (p - m - ax * u).norm();
      const double dr = rad - radius, da = std::abs(ax) - 0.5 * L;
      const double out = Eigen::Vector2d(std::max(dr, 0.0), std::max(da, 0.0)).norm();
      v = out + std::min(std::max(dr, da), 0.0);
      break;
    }
    case Kind::Box: {  // rounded by `radius` (0: sharp)
      const Eigen::Vector3d q = (rotation.transpose() * (p - centre)).cwiseAbs() - (radii.array() - radius).matrix();
      v = q.cwiseMax(0.0).norm() + std::min(q.maxCoeff(), 0.0) - radius;
      break;
    }
    case Kind::Torus: {
      const Eigen::Vector3d q = rotation.transpose() * (p - centre);
      v = Eigen::Vector2d(q.head<2>().norm() - major_radius, q.z()).norm() - radius;
      break;
    }
  }
  for (const auto& h : holes) v = std::max(v, -h.g(p));
  return v;
}

Aabb Primitive::bounds() const {
  switch (kind) {
    case Kind::Ellipsoid: {
      const Eigen::Vector3d e = rotation.cwiseAbs() * radii;
      return Aabb(centre - e, centre + e);
    }
    case Kind::Capsule:
    case Kind::Cylinder: {
      Aabb box;
      box.extend(a);
      box.extend(b);
      return box.inflated(radius);
    }
    case Kind::Box: {
      const Eigen::Vector3d e = rotation.cwiseAbs() * radii;
      return Aabb(centre - e, centre + e);
    }
    case Kind::Torus: {
      const Eigen::Vector3d e =
          rotation.cwiseAbs() * Eigen::Vector3d(major_radius + radius, major_radius + radius, radius);
      return Aabb(centre - e, centre + e);
    }
  }
  return {};
}

Aabb ProceduralAnatomy::extent(double wall) const {
  Aabb box;
  for (const auto& p : lumen) box.extend(p.bounds());
  return box.inflated(wall);
}

namespace {

// SplitMix64: a fully specified generator, so anatomies are identical on every platform.
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : s_(seed * 0x2545F4914F6CDD1Dull + 0x9E3779B97F4A7C15ull) {}
  std::uint64_t next() {
    std::uint64_t z = (s_ += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
  }
  double uniform() { return static_cast<double>(next() >> 11) * (1.0 / 9007199254740992.0); }
  double range(double lo, double hi) { return lo + (hi - lo) * uniform(); }
  /// 1 + a * U(-1, 1)
  double jitter(double a) { return 1.0 + a * (2.0 * uniform() - 1.0); }

 private:
  std::uint64_t s_;
};

Eigen::Matrix3d frameFromZ(const Eigen::Vector3d& z0, const Eigen::Vector3d& xhint = Eigen::Vector3d::UnitX()) {
  const Eigen::Vector3d z = z0.normalized();
  Eigen::Vector3d x = xhint - xhint.dot(z) * z;
  if (x.norm() < 1e-6) {
    int axis = 0;
    z.cwiseAbs().minCoeff(&axis);
    Eigen::Vector3d e = Eigen::Vector3d::Zero();
    e[axis] = 1;
    x = e - e.dot(z) * z;
  }
  x.normalize();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

Primitive ellipsoid(std::string name, const Eigen::Vector3d& c, const Eigen::Vector3d& r,
                    const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity()) {
  Primitive p;
  p.kind = Primitive::Kind::Ellipsoid;
  p.name = std::move(name);
  p.centre = c;
  p.radii = r;
  p.rotation = R;
  return p;
}
Primitive capsule(std::string name, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r) {
  Primitive p;
  p.kind = Primitive::Kind::Capsule;
  p.name = std::move(name);
  p.a = a;
  p.b = b;
  p.radius = r;
  return p;
}
Primitive cylinder(std::string name, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r) {
  Primitive p = capsule(std::move(name), a, b, r);
  p.kind = Primitive::Kind::Cylinder;
  return p;
}
Primitive box(std::string name, const Eigen::Vector3d& c, const Eigen::Vector3d& half,
              const Eigen::Matrix3d& R = Eigen::Matrix3d::Identity()) {
  Primitive p;
  p.kind = Primitive::Kind::Box;
  p.name = std::move(name);
  p.centre = c;
  p.radii = half;
  p.rotation = R;
  return p;
}
Primitive torus(std::string name, const Eigen::Vector3d& c, const Eigen::Vector3d& axis, double R, double r) {
  Primitive p;
  p.kind = Primitive::Kind::Torus;
  p.name = std::move(name);
  p.centre = c;
  p.rotation = frameFromZ(axis);
  p.major_radius = R;
  p.radius = r;
  return p;
}

double param(const ProceduralSpec& spec, const std::string& key) {
  const auto defs = proceduralParameters(spec.type);
  auto it = spec.params.find(key);
  return it != spec.params.end() ? it->second : defs.at(key).first;
}

NamedTarget target(std::string name, const Eigen::Vector3d& p) {
  return NamedTarget{std::move(name), p, "procedural"};
}

// ---------------------------------------------------------------------------------------------------------------
// Intracardiac: right atrium entered from the inferior vena cava, left atrium behind the interatrial septum
// (with a foramen), right ventricle behind the tricuspid valve (annulus, three leaflets, chordae).

ProceduralAnatomy intracardiac(const ProceduralSpec& spec) {
  Rng rng(spec.seed);
  const double s = 1e-3 * spec.scale;  // mm -> m
  auto V = [&](double x, double y, double z) { return Eigen::Vector3d(x * s, y * s, z * s); };
  ProceduralAnatomy a;
  a.type = "intracardiac";
  a.seed = spec.seed;
  // Right atrium.
  const Eigen::Vector3d ra_r(24 * rng.jitter(0.08), 20 * rng.jitter(0.08), 28 * rng.jitter(0.08));
  a.lumen.push_back(ellipsoid("right_atrium", V(0, 0, 0), ra_r * s));
  // Left atrium, overlapping the right atrium by 12 mm along x.
  const Eigen::Vector3d la_r(20 * rng.jitter(0.08), 18 * rng.jitter(0.08), 22 * rng.jitter(0.08));
  const Eigen::Vector3d la_c(ra_r.x() + la_r.x() - 12.0, rng.range(2, 6), rng.range(4, 8));
  a.lumen.push_back(ellipsoid("left_atrium", la_c * s, la_r * s));
  // Vena cavae.
  const double ivc_r = 11 * rng.jitter(0.08);
  a.lumen.push_back(capsule("inferior_vena_cava", V(0, 0, -ra_r.z() - 45), V(0, 0, -ra_r.z() + 8), ivc_r * s));
  const double svc_r = 10 * rng.jitter(0.08);
  a.lumen.push_back(capsule("superior_vena_cava", V(0, -2, ra_r.z() - 8), V(0, -4, ra_r.z() + 28), svc_r * s));
  // Pulmonary veins into the left atrium.
  for (int k = 0; k < 2; ++k) {
    const double y = la_c.y() + (k == 0 ? -8.0 : 8.0) + rng.range(-1.5, 1.5);
    const Eigen::Vector3d p0(la_c.x() + la_r.x() - 6, y, la_c.z() + 4);
    a.lumen.push_back(capsule("pulmonary_vein_" + std::to_string(k + 1), p0 * s,
                              (p0 + Eigen::Vector3d(24, 0, rng.range(-3, 3))) * s, 6 * rng.jitter(0.1) * s));
  }
  // Right ventricle, overlapping the right atrium by 10 mm along -y.
  const Eigen::Vector3d rv_r(24 * rng.jitter(0.08), 16 * rng.jitter(0.08), 26 * rng.jitter(0.08));
  const Eigen::Vector3d rv_c(-4 + rng.range(-2, 2), -ra_r.y() - rv_r.y() + 10.0, -12 + rng.range(-2, 2));
  a.lumen.push_back(ellipsoid("right_ventricle", rv_c * s, rv_r * s));

  // Interatrial septum with the foramen ovale.
  const double xs = ra_r.x() - 6.0;
  const Eigen::Vector3d fo(xs, rng.range(-2, 6), rng.range(-2, 8));
  const double fo_r = 4.0 * rng.jitter(0.12);
  Primitive septum = box("interatrial_septum", V(xs, 0, 0), V(1.5, 80, 80));
  septum.holes.push_back(
      cylinder("foramen_ovale", (fo - Eigen::Vector3d(5, 0, 0)) * s, (fo + Eigen::Vector3d(5, 0, 0)) * s, fo_r * s));
  a.obstacles.push_back(septum);

  // Tricuspid valve: a wall between atrium and ventricle with the orifice, the annulus, leaflets and chordae.
  const double yv = -ra_r.y() + 5.0;
  const Eigen::Vector3d vc(-2 + rng.range(-1.5, 1.5), yv, -6 + rng.range(-1.5, 1.5));
  const double orifice = 10.0 * rng.jitter(0.08);
  Primitive wall = box("atrioventricular_wall", V(0, yv, 0), V(80, 1.5, 80));
  wall.holes.push_back(cylinder("tricuspid_orifice", (vc + Eigen::Vector3d(0, 5, 0)) * s,
                                (vc - Eigen::Vector3d(0, 5, 0)) * s, orifice * s));
  a.obstacles.push_back(wall);
  a.obstacles.push_back(torus("tricuspid_annulus", vc * s, Eigen::Vector3d::UnitY(), orifice * s, 2.0 * s));
  const double phase = rng.range(-10, 10) * M_PI / 180.0;
  for (int k = 0; k < 3; ++k) {
    const double phi = M_PI / 2 + phase + k * 2.0 * M_PI / 3.0 + rng.range(-8, 8) * M_PI / 180.0;
    const Eigen::Vector3d radial(std::cos(phi), 0, std::sin(phi));
    const double tilt = rng.range(30, 45) * M_PI / 180.0;
    // Leaflet plane: from the annulus inwards and down into the ventricle (-y).
    const Eigen::Vector3d inward = (-std::cos(tilt) * radial - std::sin(tilt) * Eigen::Vector3d::UnitY()).normalized();
    const Eigen::Vector3d tangent = Eigen::Vector3d::UnitY().cross(radial).normalized();
    Eigen::Matrix3d R;
    R.col(0) = inward;
    R.col(1) = tangent;
    R.col(2) = inward.cross(tangent);
    const double len = 4.5 * rng.jitter(0.1);
    const Eigen::Vector3d root = vc + radial * (orifice - 1.0);
    const Eigen::Vector3d centre = root + inward * len;
    a.obstacles.push_back(ellipsoid("leaflet_" + std::to_string(k + 1), centre * s,
                                    Eigen::Vector3d(len, 5.0 * rng.jitter(0.1), 0.6) * s, R));
    // Chorda from the leaflet's free edge to a papillary point in the ventricle.
    const Eigen::Vector3d tip = root + inward * (2 * len - 0.5);
    const Eigen::Vector3d papillary =
        vc + radial * rng.range(4, 8) + Eigen::Vector3d(0, -rng.range(16, 20), 0) + Eigen::Vector3d(0, 0, -2);
    a.obstacles.push_back(capsule("chorda_" + std::to_string(k + 1), tip * s, papillary * s, 0.7 * s));
  }

  // Start in the inferior vena cava, pointing up into the right atrium.
  a.start = NamedPose{"ivc", Eigen::Isometry3d::Identity(), "procedural"};
  a.start.pose.translation() = V(0, 0, -ra_r.z() - 35);
  a.targets.push_back(target("foramen", fo * s));
  a.targets.push_back(target("septum", V(xs - 1.5 - 3.0, std::clamp(fo.y() + 7.0, -6.0, 9.0), fo.z() - 9.0)));
  a.targets.push_back(target("tricuspid", vc * s));
  a.targets.push_back(target("appendage", V(-13, -5, 13)));
  std::ostringstream d;
  d << "intracardiac (seed " << spec.seed << "): right atrium " << 2 * ra_r.x() << " x " << 2 * ra_r.y() << " x "
    << 2 * ra_r.z() << " mm, septum at x = " << xs << " mm with a " << 2 * fo_r << " mm foramen, tricuspid orifice "
    << 2 * orifice << " mm with 3 leaflets and chordae";
  a.description = d.str();
  return a;
}

// ---------------------------------------------------------------------------------------------------------------
// Airway: trachea and a bifurcating lumen tree (Murray-like radius ratios, random branching angles and planes).

void airwayBranch(ProceduralAnatomy& a, Rng& rng, const Eigen::Vector3d& p0, const Eigen::Vector3d& d,
                  const Eigen::Vector3d& perp, double r, int gen, int generations, double length_ratio, double s,
                  int& leaf) {
  const double L = (gen == 0 ? 70.0 : length_ratio * r * rng.jitter(0.2)) * s;
  const Eigen::Vector3d p1 = p0 + d * L;
  a.lumen.push_back(capsule("branch_g" + std::to_string(gen), p0, p1, r * s));
  if (gen == 0) a.targets.push_back(target("carina", p1));
  if (gen == generations) {
    ++leaf;
    std::ostringstream name;
    name << "leaf_" << (leaf < 10 ? "0" : "") << leaf;
    a.targets.push_back(target(name.str(), p1 - d * std::min(2.0 * s, 0.25 * L)));
    return;
  }
  // Branching plane: rotate the previous plane about d by ~90 degrees.
  const double rot = (90.0 + rng.range(-20, 20)) * M_PI / 180.0;
  const Eigen::Vector3d e = (Eigen::AngleAxisd(rot, d) * perp).normalized();
  const double ta = rng.range(22, 38) * M_PI / 180.0, tb = rng.range(32, 50) * M_PI / 180.0;
  const double ra = r * 0.82 * rng.jitter(0.05), rb = r * 0.74 * rng.jitter(0.05);
  const Eigen::Vector3d da = (std::cos(ta) * d + std::sin(ta) * e).normalized();
  const Eigen::Vector3d db = (std::cos(tb) * d - std::sin(tb) * e).normalized();
  airwayBranch(a, rng, p1, da, e, ra, gen + 1, generations, length_ratio, s, leaf);
  airwayBranch(a, rng, p1, db, e, rb, gen + 1, generations, length_ratio, s, leaf);
}

ProceduralAnatomy airway(const ProceduralSpec& spec) {
  Rng rng(spec.seed);
  const double s = 1e-3 * spec.scale;
  ProceduralAnatomy a;
  a.type = "airway";
  a.seed = spec.seed;
  const int generations = static_cast<int>(std::lround(param(spec, "generations")));
  const double r0 = param(spec, "trachea_radius") * 1e3 * rng.jitter(0.05);
  const double length_ratio = param(spec, "length_ratio");
  int leaf = 0;
  // Trachea from z = +70 mm down to the carina at the origin.
  airwayBranch(a, rng, Eigen::Vector3d(0, 0, 70) * s, -Eigen::Vector3d::UnitZ(), Eigen::Vector3d::UnitX(), r0, 0,
               generations, length_ratio, s, leaf);
  a.start = NamedPose{"trachea", Eigen::Isometry3d::Identity(), "procedural"};
  a.start.pose.linear() = frameFromZ(-Eigen::Vector3d::UnitZ());
  a.start.pose.translation() = Eigen::Vector3d(0, 0, 62) * s;
  std::ostringstream d;
  d << "airway (seed " << spec.seed << "): trachea radius " << r0 << " mm, " << generations << " generations, " << leaf
    << " terminal branches";
  a.description = d.str();
  return a;
}

// ---------------------------------------------------------------------------------------------------------------
// Transnasal skull-base passage: a narrow slit-shaped nasal passage with turbinates and a septal spur, the sphenoid
// ostium, and the sphenoid sinus with the sella and the carotid prominences. z: posterior, y: superior, x: lateral.

ProceduralAnatomy sinus(const ProceduralSpec& spec) {
  Rng rng(spec.seed);
  const double s = 1e-3 * spec.scale;
  auto V = [&](double x, double y, double z) { return Eigen::Vector3d(x * s, y * s, z * s); };
  ProceduralAnatomy a;
  a.type = "sinus";
  a.seed = spec.seed;
  const double w = param(spec, "passage_width") * 1e3;  // mm
  const double bow = 4.0 * rng.jitter(0.3);
  auto centre = [&](double z) { return Eigen::Vector3d(0, bow * std::sin(M_PI * z / 140.0), z); };
  // Nostril vestibule.
  a.lumen.push_back(capsule("vestibule", V(0, 0, -15), V(0, 0, 3), 5.0 * s));
  // Slit: rounded slabs (w wide, 16 mm tall) along the bowed centreline, 10 mm segments overlapping at the joints.
  const double half_h = 8.0;
  for (int k = 0; k < 7; ++k) {
    const Eigen::Vector3d p0 = centre(10.0 * k), p1 = centre(10.0 * (k + 1));
    Primitive slab = box("nasal_passage", 0.5 * (p0 + p1) * s,
                         Eigen::Vector3d(0.5 * w, half_h, 0.5 * (p1 - p0).norm() + 0.5 * w) * s,
                         frameFromZ(p1 - p0, Eigen::Vector3d::UnitX()));
    slab.radius = 0.5 * w * s;
    a.lumen.push_back(slab);
  }
  // Turbinates protruding from the lateral wall (+x), a septal spur from the medial wall (-x).
  const double tz[3] = {18, 34, 50}, ty[3] = {-5, 0, 5};
  for (int k = 0; k < 3; ++k) {
    const double protrusion = rng.range(0.8, 1.5);
    const double rx = 2.5;
    const Eigen::Vector3d c = centre(tz[k] + rng.range(-2, 2)) + Eigen::Vector3d(w / 2 + rx - protrusion, ty[k], 0);
    a.obstacles.push_back(ellipsoid("turbinate_" + std::to_string(k + 1), c * s, Eigen::Vector3d(rx, 2.5, 9) * s));
  }
  {
    const double protrusion = rng.range(0.6, 1.2);
    const Eigen::Vector3d c = centre(33 + rng.range(-1, 1)) + Eigen::Vector3d(-(w / 2 + 2.0 - protrusion), -6, 0);
    a.obstacles.push_back(ellipsoid("septal_spur", c * s, Eigen::Vector3d(2.0, 2.0, 4.0) * s));
  }
  // Sphenoid ostium and sinus.
  const Eigen::Vector3d end = centre(70);
  const Eigen::Vector3d ostium = end + Eigen::Vector3d(0, 3, 10);
  a.lumen.push_back(capsule("sphenoid_ostium", end * s, ostium * s, 3.0 * rng.jitter(0.1) * s));
  const Eigen::Vector3d sc = end + Eigen::Vector3d(0, 5, 22);
  const Eigen::Vector3d sr(12 * rng.jitter(0.1), 10 * rng.jitter(0.1), 11 * rng.jitter(0.1));
  a.lumen.push_back(ellipsoid("sphenoid_sinus", sc * s, sr * s));
  // Sella turcica bulging from the posterior-superior wall; carotid prominences on the lateral walls.
  const Eigen::Vector3d sella = sc + Eigen::Vector3d(0, 0.55 * sr.y(), 0.75 * sr.z());
  a.obstacles.push_back(ellipsoid("sella", sella * s, Eigen::Vector3d(7, 5, 5) * s));
  for (int k = 0; k < 2; ++k) {
    const double x = (k == 0 ? -1 : 1) * 0.85 * sr.x();
    a.obstacles.push_back(capsule(k == 0 ? "carotid_right" : "carotid_left",
                                  (sc + Eigen::Vector3d(x, -0.6 * sr.y(), 0.2 * sr.z())) * s,
                                  (sc + Eigen::Vector3d(x, 0.6 * sr.y(), 0.5 * sr.z())) * s, 2.5 * s));
  }
  a.start = NamedPose{"nostril", Eigen::Isometry3d::Identity(), "procedural"};
  a.start.pose.translation() = V(0, 0, -8);
  a.targets.push_back(target("sella", (sella - Eigen::Vector3d(0, 1.5, 7.5)) * s));
  a.targets.push_back(target("clivus", (sc + Eigen::Vector3d(0, -0.45 * sr.y(), 0.55 * sr.z())) * s));
  a.targets.push_back(target("ostium", (0.5 * (end + ostium)) * s));
  std::ostringstream d;
  d << "sinus (seed " << spec.seed << "): nasal passage " << w << " mm wide with 3 turbinates and a septal spur, "
    << "sphenoid sinus " << 2 * sr.x() << " x " << 2 * sr.y() << " x " << 2 * sr.z() << " mm with the sella";
  a.description = d.str();
  return a;
}

}  // namespace

std::vector<std::string> proceduralTypes() {
  return {"intracardiac", "airway", "sinus"};
}

std::map<std::string, std::pair<double, std::string>> proceduralParameters(const std::string& type) {
  if (type == "intracardiac") return {};
  if (type == "airway")
    return {{"generations", {4, "bifurcation generations below the trachea (1..7)"}},
            {"trachea_radius", {0.008, "trachea radius (m)"}},
            {"length_ratio", {6.0, "branch length / branch radius"}}};
  if (type == "sinus") return {{"passage_width", {0.005, "width of the nasal slit (m)"}}};
  std::string known;
  for (const auto& t : proceduralTypes()) known += (known.empty() ? "" : ", ") + t;
  throw std::invalid_argument("unknown procedural type '" + type + "' (known: " + known + ")");
}

ProceduralAnatomy makeProcedural(const ProceduralSpec& spec) {
  const auto defs = proceduralParameters(spec.type);  // throws for an unknown type
  for (const auto& kv : spec.params) {
    if (defs.find(kv.first) == defs.end()) {
      std::string known;
      for (const auto& d : defs) known += (known.empty() ? "" : ", ") + d.first;
      throw std::invalid_argument("procedural type '" + spec.type + "' has no parameter '" + kv.first +
                                  "' (known: " + (known.empty() ? "none" : known) + ")");
    }
    if (!std::isfinite(kv.second)) throw std::invalid_argument("parameter '" + kv.first + "' must be finite");
  }
  if (!(spec.scale > 0.05 && spec.scale < 20.0)) throw std::invalid_argument("key 'scale' must be in (0.05, 20)");
  if (spec.type == "airway") {
    const double g = param(spec, "generations");
    if (g < 1 || g > 7 || g != std::round(g)) throw std::invalid_argument("key 'generations' must be an integer 1..7");
    const double r = param(spec, "trachea_radius");
    if (!(r >= 0.002 && r <= 0.02)) throw std::invalid_argument("key 'trachea_radius' must be in [0.002, 0.02] m");
    const double lr = param(spec, "length_ratio");
    if (!(lr >= 2 && lr <= 15)) throw std::invalid_argument("key 'length_ratio' must be in [2, 15]");
    return airway(spec);
  }
  if (spec.type == "sinus") {
    const double w = param(spec, "passage_width");
    if (!(w >= 0.002 && w <= 0.012)) throw std::invalid_argument("key 'passage_width' must be in [0.002, 0.012] m");
    return sinus(spec);
  }
  return intracardiac(spec);
}

void rasterizeProcedural(const ProceduralAnatomy& anatomy, VoxelGrid& grid) {
  const double res = grid.resolution();
  const double half_diag = 0.5 * std::sqrt(3.0) * res;
  const std::size_t n = grid.cells();
  std::vector<float> lumen(n, std::numeric_limits<float>::infinity());
  std::vector<std::uint8_t> hit(n, 0);
  Eigen::Vector3i lo, hi;
  for (const auto& p : anatomy.lumen) {
    if (!grid.cellRange(p.bounds(), lo, hi, 0.0)) continue;
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) {
          const std::size_t id = grid.index(i, j, k);
          const float g = static_cast<float>(p.g(grid.centre(i, j, k)));
          if (g < lumen[id]) lumen[id] = g;
        }
  }
  for (const auto& p : anatomy.obstacles) {
    if (!grid.cellRange(p.bounds().inflated(res), lo, hi, 0.0)) continue;
    for (int k = lo.z(); k <= hi.z(); ++k)
      for (int j = lo.y(); j <= hi.y(); ++j)
        for (int i = lo.x(); i <= hi.x(); ++i) {
          const std::size_t id = grid.index(i, j, k);
          if (hit[id]) continue;
          if (p.g(grid.centre(i, j, k)) <= half_diag) hit[id] = 1;
        }
  }
  auto& d = grid.data();
  for (std::size_t id = 0; id < n; ++id)
    d[id] = (lumen[id] < -half_diag && !hit[id]) ? VoxelGrid::kFree : VoxelGrid::kOccupied;
}

}  // namespace ctr::environments
