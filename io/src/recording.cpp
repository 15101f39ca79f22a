#include "ctr/io/recording.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <new>
#include <sstream>
#include <stdexcept>

#include "ctr/io/file.hpp"
#include "text_util.hpp"

namespace ctr::io {
namespace {

using detail::contentLines;
using detail::formatNumber;
using detail::NumberStatus;
using detail::splitCells;
using detail::trim;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

enum class Kind { kAlpha, kBeta, kTwist, kTip, kTangent, kTime, kIgnored };

// One header column: what it holds and, for indexed columns, the 1-based tube (alpha/beta/twist) or
// the component 0..2 (tip/tangent).
struct Column {
  std::string name;
  Kind kind = Kind::kIgnored;
  int index = 0;
};

// "alpha_12" -> 12 when the name is prefix + a positive integer without leading zeros, else 0.
int indexAfter(const std::string& name, const std::string& prefix) {
  if (name.compare(0, prefix.size(), prefix) != 0) return 0;
  const std::string digits = name.substr(prefix.size());
  if (digits.empty() || digits.size() > 6 || digits[0] == '0') return 0;
  for (char c : digits)
    if (!std::isdigit(static_cast<unsigned char>(c))) return 0;
  return std::stoi(digits);
}

Column classify(const std::string& name) {
  Column c{name, Kind::kIgnored, 0};
  static const char* const tip[] = {"tip_x", "tip_y", "tip_z"};
  static const char* const tangent[] = {"tip_tx", "tip_ty", "tip_tz"};
  if (int k = indexAfter(name, "alpha_")) return {name, Kind::kAlpha, k};
  if (int k = indexAfter(name, "beta_")) return {name, Kind::kBeta, k};
  if (int k = indexAfter(name, "twist_"); k >= 2) return {name, Kind::kTwist, k};
  for (int i = 0; i < 3; ++i) {
    if (name == tip[i]) return {name, Kind::kTip, i};
    if (name == tangent[i]) return {name, Kind::kTangent, i};
  }
  if (name == "time") return {name, Kind::kTime, 0};
  return c;
}

std::string actuationHelp(int n) {
  const std::string k = n > 0 ? std::to_string(n) : std::string("n");
  return "a recording needs alpha_1..alpha_" + k + " and beta_1..beta_" + k + " (docs/formats.md)";
}

std::string tubesText(int n) { return std::to_string(n) + (n == 1 ? " tube" : " tubes"); }

// Short number text for messages about computed values.
std::string shortNumber(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v);
  return buf;
}

Recording parse(const std::string& text, const std::string& src, int tubes, bool require_measurement) {
  auto fail = [&](int line, const std::string& key, const std::string& message) {
    throw InputError(src, line, key, message);
  };
  if (tubes == 0) fail(0, "", "the robot has 0 tubes; cannot read a recording for it");
  const auto lines = contentLines(text);
  if (lines.empty())
    fail(0, "", "empty file; expected a header line with alpha_k, beta_k, ... columns (docs/formats.md)");

  // Header.
  const int header_line = lines[0].first;
  std::vector<std::string> names = splitCells(lines[0].second);
  while (!names.empty() && names.back().empty()) names.pop_back();  // trailing commas
  Recording rec;
  std::vector<Column> cols;
  std::map<std::string, std::size_t> seen;
  int max_index = 0;
  for (std::size_t c = 0; c < names.size(); ++c) {
    Column col = classify(names[c]);
    if (names[c].empty()) {
      rec.warnings.push_back("column " + std::to_string(c + 1) + " has no name; ignored");
    } else if (auto s = seen.find(names[c]); s != seen.end()) {
      fail(header_line, names[c],
           "duplicate column (columns " + std::to_string(s->second + 1) + " and " + std::to_string(c + 1) + ")");
    } else {
      seen[names[c]] = c;
      if (col.kind == Kind::kIgnored)
        rec.warnings.push_back("unknown column '" + names[c] + "' (column " + std::to_string(c + 1) + ") ignored");
    }
    if (col.kind == Kind::kAlpha || col.kind == Kind::kBeta || col.kind == Kind::kTwist)
      max_index = std::max(max_index, col.index);
    cols.push_back(col);
  }

  // Number of tubes: given, or the largest alpha/beta/twist index.
  const int n = tubes > 0 ? tubes : max_index;
  if (n == 0) fail(header_line, "alpha_1", "no actuation columns; " + actuationHelp(0));
  bool has_twist = false, has_tip = false, has_tangent = false, has_time = false;
  std::array<bool, 3> tip_given{}, tangent_given{};
  for (const Column& col : cols) {
    if ((col.kind == Kind::kAlpha || col.kind == Kind::kBeta || col.kind == Kind::kTwist) && col.index > n)
      fail(header_line, col.name,
           "column for tube " + std::to_string(col.index) + " but the robot has " + tubesText(n));
    has_twist = has_twist || col.kind == Kind::kTwist;
    has_time = has_time || col.kind == Kind::kTime;
    if (col.kind == Kind::kTip) tip_given[static_cast<std::size_t>(col.index)] = has_tip = true;
    if (col.kind == Kind::kTangent) tangent_given[static_cast<std::size_t>(col.index)] = has_tangent = true;
  }
  for (int k = 1; k <= n; ++k)
    for (const char* prefix : {"alpha_", "beta_"}) {
      const std::string name = prefix + std::to_string(k);
      if (!seen.count(name)) fail(header_line, name, "missing column; " + actuationHelp(n));
    }
  const char* const tip_names[] = {"tip_x", "tip_y", "tip_z"};
  const char* const tangent_names[] = {"tip_tx", "tip_ty", "tip_tz"};
  for (std::size_t i = 0; i < 3; ++i) {
    if (has_tip && !tip_given[i])
      fail(header_line, tip_names[i], "missing column; tip position needs all of tip_x, tip_y, tip_z");
    if (has_tangent && !tangent_given[i])
      fail(header_line, tangent_names[i], "missing column; tip tangent needs all of tip_tx, tip_ty, tip_tz");
  }
  if (require_measurement && !has_twist && !has_tip && !has_tangent)
    fail(header_line, "",
         "no measured quantity: needs twist_2..twist_n, tip_x/tip_y/tip_z or tip_tx/tip_ty/tip_tz "
         "columns besides alpha/beta (docs/formats.md)");
  if (lines.size() < 2) fail(header_line, "", "header only: no data rows");

  // Rows.
  const int rows = static_cast<int>(lines.size()) - 1;
  rec.tubes = n;
  rec.commands.reserve(static_cast<std::size_t>(rows));
  rec.lines.reserve(static_cast<std::size_t>(rows));
  if (has_twist) rec.twist = Eigen::MatrixXd::Constant(rows, n - 1, kNaN);
  if (has_tip) rec.tip_position = Eigen::MatrixXd::Constant(rows, 3, kNaN);
  if (has_tangent) rec.tip_tangent = Eigen::MatrixXd::Constant(rows, 3, kNaN);
  if (has_time) rec.time = Eigen::VectorXd::Constant(rows, kNaN);
  bool measured = false;
  int last_time_line = 0;
  double last_time = kNaN;
  for (int r = 0; r < rows; ++r) {
    // Not a structured binding: the lambdas below capture `line` (clang < 16 cannot capture bindings).
    const int line = lines[static_cast<std::size_t>(r) + 1].first;
    const std::string_view content = lines[static_cast<std::size_t>(r) + 1].second;
    std::vector<std::string> cells = splitCells(content);
    // Cells past the header must be empty (trailing commas).
    while (cells.size() > cols.size() && cells.back().empty()) cells.pop_back();
    if (cells.size() != cols.size())
      fail(line, "",
           "row has " + std::to_string(cells.size()) + " cells, the header has " + std::to_string(cols.size()) +
               " columns");
    Configuration q(Eigen::VectorXd::Constant(n, kNaN), Eigen::VectorXd::Constant(n, kNaN));
    for (std::size_t c = 0; c < cols.size(); ++c) {
      const Column& col = cols[c];
      if (col.kind == Kind::kIgnored) continue;
      double v = kNaN;
      const NumberStatus st = detail::parseDouble(cells[c], v);
      const bool actuation = col.kind == Kind::kAlpha || col.kind == Kind::kBeta;
      if (st == NumberStatus::kNotANumber)
        fail(line, col.name, "'" + cells[c].substr(0, 40) + "' is not a number (row " + std::to_string(r + 1) + ")");
      if (actuation && st == NumberStatus::kEmpty)
        fail(line, col.name, "missing actuation value (row " + std::to_string(r + 1) + "); every row needs all " +
                                 "alpha_k and beta_k");
      if (st == NumberStatus::kNotFinite) {
        // A NaN measurement is "not measured"; NaN actuation or infinities are errors.
        if (actuation || !std::isnan(v))
          fail(line, col.name, "'" + cells[c] + "' is not a finite number (row " + std::to_string(r + 1) + ")");
        v = kNaN;
      }
      const int k = col.index;
      switch (col.kind) {
        case Kind::kAlpha: q.alpha[k - 1] = v; break;
        case Kind::kBeta: q.beta[k - 1] = v; break;
        case Kind::kTwist: rec.twist(r, k - 2) = v; break;
        case Kind::kTip: rec.tip_position(r, k) = v; break;
        case Kind::kTangent: rec.tip_tangent(r, k) = v; break;
        case Kind::kTime: rec.time[r] = v; break;
        case Kind::kIgnored: break;
      }
      if (col.kind != Kind::kTime && !actuation && !std::isnan(v)) measured = true;
    }
    // Triplets are measured together or not at all.
    auto triplet = [&](Eigen::MatrixXd& m, const char* const* names, const char* what) {
      if (m.cols() == 0) return;
      const int given = (!std::isnan(m(r, 0))) + (!std::isnan(m(r, 1))) + (!std::isnan(m(r, 2)));
      if (given == 0 || given == 3) return;
      for (int i = 0; i < 3; ++i)
        if (std::isnan(m(r, i)))
          fail(line, names[i], std::string("empty while other ") + what + " components are given (row " +
                                   std::to_string(r + 1) + "); give all three or none");
    };
    triplet(rec.tip_position, tip_names, "tip position");
    triplet(rec.tip_tangent, tangent_names, "tip tangent");
    if (has_tangent && !std::isnan(rec.tip_tangent(r, 0))) {
      const double norm = rec.tip_tangent.row(r).norm();
      if (!(norm >= 0.5 && norm <= 1.5))
        fail(line, "tip_tx",
             "tip tangent (tip_tx, tip_ty, tip_tz) of row " + std::to_string(r + 1) + " has length " +
                 shortNumber(norm) + "; expected a unit vector (length within [0.5, 1.5])");
    }
    if (has_time && !std::isnan(rec.time[r])) {
      if (!std::isnan(last_time) && !(rec.time[r] > last_time))
        fail(line, "time",
             "time " + formatNumber(rec.time[r]) + " s of row " + std::to_string(r + 1) +
                 " is not after the previous time " + formatNumber(last_time) + " s (line " +
                 std::to_string(last_time_line) + "); rows must be in the order the samples were taken");
      last_time = rec.time[r];
      last_time_line = line;
    }
    rec.commands.push_back(std::move(q));
    rec.lines.push_back(line);
  }
  if (require_measurement && !measured)
    fail(header_line, "", "no measured value in any row (twist, tip position and tip tangent cells are all empty)");
  return rec;
}

}  // namespace

Recording parseRecording(const std::string& text, const std::string& source, int tubes, bool require_measurement) {
  try {
    return parse(text, source, tubes, require_measurement);
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(source, 0, "", "out of memory while reading the recording");
  } catch (const std::exception& e) {
    throw InputError(source, 0, "", e.what());
  }
}

Recording loadRecording(const std::string& path, int tubes, bool require_measurement) {
  return parseRecording(readFile(path), path, tubes, require_measurement);
}

std::string recordingToCsv(const Recording& rec) {
  const int rows = rec.rows();
  const int n = rec.tubes > 0 ? rec.tubes : (rows > 0 ? rec.commands[0].size() : 0);
  if (n <= 0) throw std::invalid_argument("recordingToCsv: the recording has no tubes");
  for (const Configuration& q : rec.commands)
    if (q.alpha.size() != n || q.beta.size() != n)
      throw std::invalid_argument("recordingToCsv: a command does not have " + std::to_string(n) + " tubes");
  auto checkShape = [&](const Eigen::MatrixXd& m, int cols, const char* what) {
    if (m.cols() > 0 && (m.rows() != rows || m.cols() != cols))
      throw std::invalid_argument(std::string("recordingToCsv: ") + what + " has the wrong shape");
  };
  checkShape(rec.twist, n - 1, "twist");
  checkShape(rec.tip_position, 3, "tip_position");
  checkShape(rec.tip_tangent, 3, "tip_tangent");
  if (rec.hasTime() && rec.time.size() != rows) throw std::invalid_argument("recordingToCsv: time has the wrong size");

  std::ostringstream os;
  std::string sep;
  auto head = [&](const std::string& name) {
    os << sep << name;
    sep = ",";
  };
  for (int i = 1; i <= n; ++i) head("alpha_" + std::to_string(i));
  for (int i = 1; i <= n; ++i) head("beta_" + std::to_string(i));
  if (rec.hasTwist())
    for (int i = 2; i <= n; ++i) head("twist_" + std::to_string(i));
  if (rec.hasTipPosition())
    for (const char* c : {"tip_x", "tip_y", "tip_z"}) head(c);
  if (rec.hasTipTangent())
    for (const char* c : {"tip_tx", "tip_ty", "tip_tz"}) head(c);
  if (rec.hasTime()) head("time");
  os << "\n";
  // NaN (not measured) is an empty cell.
  auto cell = [](double v) { return std::isnan(v) ? std::string() : formatNumber(v); };
  for (int r = 0; r < rows; ++r) {
    const Configuration& q = rec.commands[static_cast<std::size_t>(r)];
    std::string line;
    sep.clear();
    auto put = [&](double v) {
      line += sep + cell(v);
      sep = ",";
    };
    for (int i = 0; i < n; ++i) put(q.alpha[i]);
    for (int i = 0; i < n; ++i) put(q.beta[i]);
    for (int i = 0; i < rec.twist.cols(); ++i) put(rec.twist(r, i));
    for (int i = 0; i < rec.tip_position.cols(); ++i) put(rec.tip_position(r, i));
    for (int i = 0; i < rec.tip_tangent.cols(); ++i) put(rec.tip_tangent(r, i));
    if (rec.hasTime()) put(rec.time[r]);
    os << line << "\n";
  }
  return os.str();
}

void saveRecording(const Recording& rec, const std::string& path) { writeFileAtomic(path, recordingToCsv(rec)); }

}  // namespace ctr::io
