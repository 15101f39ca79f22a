#include "ctr/io/tip_path.hpp"

#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <new>

#include "ctr/io/file.hpp"
#include "text_util.hpp"

namespace ctr::io {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Column roles: 0..2 tip position, 3..5 tip direction, 6 time, -1 ignored silently (recording columns), -2 unknown.
int role(const std::string& name) {
  static const char* const names[] = {"tip_x", "tip_y", "tip_z", "tip_tx", "tip_ty", "tip_tz", "time"};
  for (int k = 0; k < 7; ++k)
    if (name == names[k]) return k;
  for (const char* prefix : {"alpha_", "beta_", "twist_"})
    if (name.rfind(prefix, 0) == 0) return -1;
  return -2;
}

TipPath parse(const std::string& text, const std::string& src) {
  auto fail = [&](int line, const std::string& key, const std::string& message) {
    throw InputError(src, line, key, message);
  };
  const auto lines = detail::contentLines(text);
  if (lines.empty()) fail(0, "", "empty file; expected a header line with tip_x, tip_y, tip_z columns");
  const int header_line = lines[0].first;
  std::vector<std::string> names = detail::splitCells(lines[0].second);
  while (!names.empty() && names.back().empty()) names.pop_back();
  TipPath out;
  std::vector<int> roles;
  std::map<std::string, std::size_t> seen;
  bool given[7] = {};
  for (std::size_t c = 0; c < names.size(); ++c) {
    const int r = names[c].empty() ? -1 : role(names[c]);
    if (names[c].empty()) out.warnings.push_back("column " + std::to_string(c + 1) + " has no name; ignored");
    if (!names[c].empty()) {
      if (auto s = seen.find(names[c]); s != seen.end())
        fail(header_line, names[c],
             "duplicate column (columns " + std::to_string(s->second + 1) + " and " + std::to_string(c + 1) + ")");
      seen[names[c]] = c;
    }
    if (r == -2)
      out.warnings.push_back("unknown column '" + names[c] + "' (column " + std::to_string(c + 1) + ") ignored");
    if (r >= 0) given[r] = true;
    roles.push_back(r);
  }
  const char* const tip[] = {"tip_x", "tip_y", "tip_z"};
  const char* const dir[] = {"tip_tx", "tip_ty", "tip_tz"};
  for (int i = 0; i < 3; ++i)
    if (!given[i]) fail(header_line, tip[i], "missing column; a tip path needs tip_x, tip_y, tip_z (m, base frame)");
  const bool has_dir = given[3] || given[4] || given[5];
  for (int i = 0; i < 3; ++i)
    if (has_dir && !given[3 + i])
      fail(header_line, dir[i], "missing column; a tip direction needs all of tip_tx, tip_ty, tip_tz");
  if (lines.size() < 2) fail(header_line, "", "header only: no targets");
  const int rows = static_cast<int>(lines.size()) - 1;
  out.position = Eigen::MatrixXd::Constant(rows, 3, kNaN);
  if (has_dir) out.direction = Eigen::MatrixXd::Constant(rows, 3, kNaN);
  if (given[6]) out.time = Eigen::VectorXd::Constant(rows, kNaN);
  for (int r = 0; r < rows; ++r) {
    const int line = lines[static_cast<std::size_t>(r) + 1].first;
    std::vector<std::string> cells = detail::splitCells(lines[static_cast<std::size_t>(r) + 1].second);
    while (cells.size() > roles.size() && cells.back().empty()) cells.pop_back();
    if (cells.size() != roles.size())
      fail(line, "",
           "row has " + std::to_string(cells.size()) + " cells, the header has " + std::to_string(roles.size()) +
               " columns");
    const std::string row = " (target " + std::to_string(r + 1) + ")";
    for (std::size_t c = 0; c < roles.size(); ++c) {
      const int k = roles[c];
      if (k < 0) continue;
      double v = kNaN;
      const detail::NumberStatus st = detail::parseDouble(cells[c], v);
      if (st == detail::NumberStatus::kNotANumber)
        fail(line, names[c], "'" + cells[c].substr(0, 40) + "' is not a number" + row);
      if (st == detail::NumberStatus::kNotFinite)
        fail(line, names[c], "'" + cells[c] + "' is not a finite number" + row);
      if (st == detail::NumberStatus::kEmpty) {
        if (k < 3) fail(line, names[c], "missing tip position" + row + "; every target needs tip_x, tip_y, tip_z");
        continue;
      }
      if (k < 3)
        out.position(r, k) = v;
      else if (k < 6)
        out.direction(r, k - 3) = v;
      else
        out.time[r] = v;
    }
    if (has_dir) {
      const int n =
          (!std::isnan(out.direction(r, 0))) + (!std::isnan(out.direction(r, 1))) + (!std::isnan(out.direction(r, 2)));
      if (n != 0 && n != 3)
        for (int i = 0; i < 3; ++i)
          if (std::isnan(out.direction(r, i)))
            fail(line, dir[i], "empty while other direction components are given" + row + "; give all three or none");
      if (n == 3) {
        const double norm = out.direction.row(r).norm();
        if (!(norm >= 0.5 && norm <= 1.5)) {
          char buf[32];
          std::snprintf(buf, sizeof buf, "%.6g", norm);
          fail(line, "tip_tx",
               "tip direction (tip_tx, tip_ty, tip_tz)" + row + " has length " + buf +
                   "; expected a unit vector (length within [0.5, 1.5])");
        }
      }
    }
    if (given[6] && r > 0 && !std::isnan(out.time[r]) && !std::isnan(out.time[r - 1]) &&
        !(out.time[r] > out.time[r - 1]))
      fail(line, "time",
           "time " + detail::formatNumber(out.time[r]) + " s" + row + " is not after the previous one (" +
               detail::formatNumber(out.time[r - 1]) + " s); targets are reached in file order");
    out.lines.push_back(line);
  }
  return out;
}

}  // namespace

TipPath parseTipPath(const std::string& text, const std::string& source) {
  try {
    return parse(text, source);
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(source, 0, "", "out of memory while reading the tip path");
  } catch (const std::exception& e) {
    throw InputError(source, 0, "", e.what());
  }
}

TipPath loadTipPath(const std::string& path) {
  return parseTipPath(readFile(path), path);
}

}  // namespace ctr::io
