// Import of lab tables into the recording CSV (docs/formats.md "Importing lab tables").
#include "ctr/diagnosis/import.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "ctr/io/file.hpp"

namespace ctr::diagnosis {

ImportOptions dupontLabImportOptions() {
  ImportOptions o;
  o.tubes = 3;
  o.columns["time"] = {1, 1.0, 0.0};
  for (int i = 1; i <= 3; ++i) {
    o.columns["alpha_" + std::to_string(i)] = {1 + i, 1.0, 0.0};
    o.columns["beta_" + std::to_string(i)] = {4 + i, 1e-3, 0.0};
    o.unwrap.push_back("alpha_" + std::to_string(i));
  }
  o.columns["tip_x"] = {8, 1e-3, 0.0};
  o.columns["tip_y"] = {9, 1e-3, 0.0};
  o.columns["tip_z"] = {10, 1e-3, 0.0};
  // Sensor x axis (columns 11-13) is anti-parallel to the robot tip tangent.
  o.columns["tip_tx"] = {11, -1.0, 0.0};
  o.columns["tip_ty"] = {12, -1.0, 0.0};
  o.columns["tip_tz"] = {13, -1.0, 0.0};
  return o;
}

std::pair<std::string, ColumnSource> parseColumnMapping(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos || eq == 0)
    throw std::invalid_argument("column mapping '" + text + "': expected NAME=COLUMN[*SCALE][+OFFSET]");
  const std::string name = text.substr(0, eq);
  std::string rest = text.substr(eq + 1);
  ColumnSource src;
  auto num = [&](const std::string& s, const std::string& what) {
    std::size_t used = 0;
    double v = 0;
    try {
      v = std::stod(s, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (s.empty() || used != s.size() || !std::isfinite(v))
      throw std::invalid_argument("column mapping '" + text + "': bad " + what + " '" + s + "'");
    return v;
  };
  // Split off "+offset" (a '+' or '-' after the first character that is not part of an exponent / after '*').
  std::size_t off_pos = std::string::npos;
  for (std::size_t k = 1; k < rest.size(); ++k) {
    if ((rest[k] == '+' || rest[k] == '-') && rest[k - 1] != '*' && rest[k - 1] != 'e' && rest[k - 1] != 'E') {
      off_pos = k;
      break;
    }
  }
  if (off_pos != std::string::npos) {
    src.offset = num(rest.substr(off_pos), "offset");
    rest = rest.substr(0, off_pos);
  }
  const auto star = rest.find('*');
  const double col = num(rest.substr(0, star), "column");
  // The upper bound keeps the cast to int defined (2.9e9 was UB; found by fuzz_import).
  if (col < 1 || col != std::floor(col) || col > 1e6)
    throw std::invalid_argument("column mapping '" + text + "': column must be an integer in [1, 1000000]");
  src.column = static_cast<int>(col);
  if (star != std::string::npos) src.scale = num(rest.substr(star + 1), "scale");
  return {name, src};
}

void unwrapAngles(Eigen::Ref<Eigen::VectorXd> a) {
  double shift = 0.0, last = std::numeric_limits<double>::quiet_NaN();
  for (Eigen::Index k = 0; k < a.size(); ++k) {
    if (!std::isfinite(a[k])) continue;
    const double raw = a[k];
    if (std::isfinite(last)) {
      const double d = raw - last;
      shift -= 2 * M_PI * std::round(d / (2 * M_PI));
    }
    last = raw;
    a[k] = raw + shift;
  }
}

io::Recording importTableText(const std::string& text, const std::string& source, const ImportOptions& o) {
  // Tubes.
  int n = o.tubes;
  if (n <= 0)
    for (const auto& kv : o.columns)
      if (kv.first.rfind("alpha_", 0) == 0) {
        // "alpha_<tube>" (a bad suffix used to escape as std::invalid_argument from std::stoi; found by fuzz_import).
        const std::string digits = kv.first.substr(6);
        if (digits.empty() || digits.size() > 6 || digits.find_first_not_of("0123456789") != std::string::npos)
          throw io::InputError(source, 0, kv.first, "mapped column is not alpha_<tube number>");
        n = std::max(n, std::stoi(digits));
      }
  if (n <= 0) throw io::InputError(source, 0, "alpha_1", "no alpha_* column mapped");
  for (int i = 1; i <= n; ++i)
    for (const char* p : {"alpha_", "beta_"})
      if (!o.columns.count(p + std::to_string(i)))
        throw io::InputError(source, 0, p + std::to_string(i),
                             "column not mapped (every alpha_i and beta_i is required)");
  // Parse rows.
  std::vector<std::vector<double>> table;
  std::vector<int> line_of;
  std::istringstream in(text);
  std::string line;
  int ln = 0;
  while (std::getline(in, line)) {
    ++ln;
    if (ln <= o.skip_rows) continue;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t,;") == std::string::npos) continue;
    if (line[line.find_first_not_of(" \t")] == '#') continue;
    std::vector<double> row;
    std::string cell;
    auto flush = [&](bool force) {
      if (cell.empty() && !force) return;
      if (cell.empty()) {
        row.push_back(std::numeric_limits<double>::quiet_NaN());
        return;
      }
      std::size_t used = 0;
      double v = 0;
      try {
        v = std::stod(cell, &used);
      } catch (const std::exception&) {
        used = 0;
      }
      if (used != cell.size())
        throw io::InputError(source, ln, "column " + std::to_string(row.size() + 1), "'" + cell + "' is not a number");
      row.push_back(v);
      cell.clear();
    };
    const bool comma = o.delimiter.empty() ? line.find(',') != std::string::npos : o.delimiter == ",";
    for (char c : line) {
      if (comma ? c == ',' : (c == ' ' || c == '\t' || (!o.delimiter.empty() && c == o.delimiter[0]))) {
        flush(comma);
      } else if (!(comma && (c == ' ' || c == '\t'))) {
        cell.push_back(c);
      }
    }
    flush(false);
    table.push_back(std::move(row));
    line_of.push_back(ln);
  }
  if (table.empty()) throw io::InputError(source, 0, "", "no data rows");
  const int rows = static_cast<int>(table.size());
  auto column = [&](const std::string& name) {
    const ColumnSource& s = o.columns.at(name);
    Eigen::VectorXd v(rows);
    for (int r = 0; r < rows; ++r) {
      const auto& row = table[static_cast<std::size_t>(r)];
      if (s.column > static_cast<int>(row.size()))
        throw io::InputError(
            source, line_of[static_cast<std::size_t>(r)], name,
            "row has " + std::to_string(row.size()) + " columns, column " + std::to_string(s.column) + " is mapped");
      v[r] = s.scale * row[static_cast<std::size_t>(s.column - 1)] + s.offset;
    }
    if (std::find(o.unwrap.begin(), o.unwrap.end(), name) != o.unwrap.end()) unwrapAngles(v);
    return v;
  };
  io::Recording rec;
  rec.tubes = n;
  std::vector<Eigen::VectorXd> a, b;
  for (int i = 1; i <= n; ++i) {
    a.push_back(column("alpha_" + std::to_string(i)));
    b.push_back(column("beta_" + std::to_string(i)));
  }
  for (int r = 0; r < rows; ++r) {
    Configuration q{Eigen::VectorXd(n), Eigen::VectorXd(n)};
    for (int i = 0; i < n; ++i) {
      q.alpha[i] = a[static_cast<std::size_t>(i)][r];
      q.beta[i] = b[static_cast<std::size_t>(i)][r];
      if (!std::isfinite(q.alpha[i]) || !std::isfinite(q.beta[i]))
        throw io::InputError(source, line_of[static_cast<std::size_t>(r)], "alpha/beta",
                             "actuation must be given in every row");
    }
    rec.commands.push_back(q);
  }
  if (o.columns.count("time")) rec.time = column("time");
  auto block = [&](const std::vector<std::string>& names, Eigen::MatrixXd& M) {
    int have = 0;
    for (const auto& nm : names) have += o.columns.count(nm) ? 1 : 0;
    if (have == 0) return;
    if (have != static_cast<int>(names.size()))
      throw io::InputError(source, 0, names[0], "map all of the columns of this quantity or none");
    M.resize(rows, static_cast<Eigen::Index>(names.size()));
    for (std::size_t c = 0; c < names.size(); ++c) M.col(static_cast<Eigen::Index>(c)) = column(names[c]);
  };
  std::vector<std::string> tw;
  for (int k = 2; k <= n; ++k) tw.push_back("twist_" + std::to_string(k));
  if (n >= 2) block(tw, rec.twist);
  block({"tip_x", "tip_y", "tip_z"}, rec.tip_position);
  block({"tip_tx", "tip_ty", "tip_tz"}, rec.tip_tangent);
  if (o.normalize_tangent && rec.hasTipTangent())
    for (int r = 0; r < rows; ++r) {
      const double nn = rec.tip_tangent.row(r).norm();
      if (nn > 0 && std::isfinite(nn)) rec.tip_tangent.row(r) /= nn;
    }
  for (const auto& kv : o.columns) {
    const std::string& k = kv.first;
    const bool known = k == "time" || k.rfind("alpha_", 0) == 0 || k.rfind("beta_", 0) == 0 ||
                       k.rfind("twist_", 0) == 0 || k.rfind("tip_", 0) == 0;
    if (!known) rec.warnings.push_back("mapping for unknown column '" + k + "' ignored");
  }
  if (!rec.hasTwist() && !rec.hasTipPosition() && !rec.hasTipTangent())
    throw io::InputError(source, 0, "", "no measured quantity mapped (twist_*, tip_*, tip_t*)");
  return rec;
}

io::Recording importTable(const std::string& path, const ImportOptions& options) {
  return importTableText(io::readFile(path), path, options);
}

}  // namespace ctr::diagnosis
