#include "ctr/environments/medmpd.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "ctr/environments/environment.hpp"
#include "ctr/io/input_error.hpp"

namespace ctr::environments {

namespace {

struct Number {
  double value;
  int line;
};

std::vector<Number> readNumbers(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw io::InputError(path, 0, "", "cannot open the file (missing or unreadable)");
  std::vector<Number> out;
  std::string line;
  int ln = 0;
  while (std::getline(in, line)) {
    ++ln;
    const auto hash = line.find('#');
    if (hash != std::string::npos) line.resize(hash);
    for (char& c : line)
      if (c == ',' || c == ';' || c == '[' || c == ']') c = ' ';
    std::istringstream ss(line);
    std::string tok;
    while (ss >> tok) {
      std::size_t used = 0;
      double v = 0.0;
      try {
        v = std::stod(tok, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != tok.size() || !std::isfinite(v))
        throw io::InputError(path, ln, "", "'" + tok + "' is not a finite number");
      out.push_back({v, ln});
    }
  }
  return out;
}

}  // namespace

Eigen::Isometry3d readMedMpdStart(const std::string& path) {
  const auto nums = readNumbers(path);
  if (nums.size() != 16) {
    std::ostringstream os;
    os << "a Med-MPD start pose is a 4x4 matrix (16 numbers); found " << nums.size();
    throw io::InputError(path, nums.empty() ? 0 : nums.back().line, "", os.str());
  }
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c) m(r, c) = nums[static_cast<std::size_t>(4 * r + c)].value;
  m.topRightCorner<3, 1>() *= 1e-3;  // RAS mm -> m
  try {
    return poseFromMatrix(m, 1e-3);
  } catch (const std::invalid_argument& e) {
    throw io::InputError(path, 0, "", e.what());
  }
}

Eigen::Vector3d readMedMpdTarget(const std::string& path) {
  const auto nums = readNumbers(path);
  if (nums.size() != 3) {
    std::ostringstream os;
    os << "a Med-MPD target is a RAS point (3 numbers, mm); found " << nums.size();
    throw io::InputError(path, nums.empty() ? 0 : nums.back().line, "", os.str());
  }
  return Eigen::Vector3d(nums[0].value, nums[1].value, nums[2].value) * 1e-3;
}

}  // namespace ctr::environments
