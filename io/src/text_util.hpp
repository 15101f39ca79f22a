// Private helpers shared by the YAML and CSV readers/writers: number text <-> double, trimming, key suggestions.
#pragma once

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace ctr::io::detail {

/// Whitespace (space, tab, CR, LF, ...) removed from both ends.
inline std::string_view trim(std::string_view s) {
  auto space = [](char c) { return std::isspace(static_cast<unsigned char>(c)) != 0; };
  while (!s.empty() && space(s.front())) s.remove_prefix(1);
  while (!s.empty() && space(s.back())) s.remove_suffix(1);
  return s;
}

inline std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

enum class NumberStatus { kOk, kEmpty, kNotANumber, kNotFinite };

/// Parses the whole (trimmed) text as a double, locale-independent. YAML spellings (.nan, .inf, -.inf) and
/// C spellings (nan, inf) are recognised as non-finite so the caller can say "must be finite".
inline NumberStatus parseDouble(std::string_view text, double& out) {
  text = trim(text);
  if (text.empty()) return NumberStatus::kEmpty;
  const std::string l = lower(text);
  std::string_view body = l;
  if (!body.empty() && (body.front() == '+' || body.front() == '-')) body.remove_prefix(1);
  if (body == ".nan" || body == "nan" || body == ".inf" || body == "inf" || body == "infinity") {
    out = (body == ".nan" || body == "nan") ? std::nan("") : (l.front() == '-' ? -HUGE_VAL : HUGE_VAL);
    return NumberStatus::kNotFinite;
  }
  // from_chars takes no leading '+'; refuse "+-1".
  std::string_view digits = text;
  if (digits.front() == '+') {
    digits.remove_prefix(1);
    if (digits.empty() || digits.front() == '-' || digits.front() == '+') return NumberStatus::kNotANumber;
  }
  double v = 0.0;
  const auto res = std::from_chars(digits.data(), digits.data() + digits.size(), v);
  if (res.ec == std::errc::result_out_of_range) return NumberStatus::kNotFinite;
  if (res.ec != std::errc() || res.ptr != digits.data() + digits.size()) return NumberStatus::kNotANumber;
  out = v;
  return std::isfinite(v) ? NumberStatus::kOk : NumberStatus::kNotFinite;
}

/// Shortest "%.{15,16,17}g" text that reads back to exactly the same double (full precision, readable).
inline std::string formatNumber(double v) {
  if (std::isnan(v)) return "nan";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[40];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buf, sizeof buf, "%.*g", precision, v);
    double back = 0.0;
    if (parseDouble(buf, back) == NumberStatus::kOk && back == v) break;
  }
  return buf;
}

/// Edit distance (insert/delete/substitute) for "did you mean" suggestions.
inline std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

/// " did you mean 'x'?" for the closest known word when it is close enough, else "known keys: a, b, c".
inline std::string suggestion(const std::string& word, const std::vector<std::string>& known) {
  const std::string w = lower(word);
  std::string best;
  std::size_t best_d = std::string::npos;
  for (const std::string& k : known) {
    std::size_t d = editDistance(w, k);
    // A known key contained in the word (e.g. "curvature_1_per_m") counts as close.
    if (w.size() >= 4 && (w.find(k) != std::string::npos || k.find(w) != std::string::npos)) d = std::min<std::size_t>(d, 1);
    if (d < best_d) {
      best_d = d;
      best = k;
    }
  }
  std::string list;
  for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
  const std::size_t limit = std::max<std::size_t>(2, w.size() / 3);
  if (!best.empty() && best_d <= limit) return "did you mean '" + best + "'? (known keys: " + list + ")";
  return "known keys: " + list;
}

// Cells of one CSV line (no quoted commas in this numeric format; surrounding quotes are dropped).
inline std::vector<std::string> splitCells(std::string_view line) {
  std::vector<std::string> cells;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = line.find(',', start);
    std::string_view cell =
        trim(line.substr(start, comma == std::string_view::npos ? std::string_view::npos : comma - start));
    if (cell.size() >= 2 && cell.front() == '"' && cell.back() == '"') cell = trim(cell.substr(1, cell.size() - 2));
    cells.emplace_back(cell);
    if (comma == std::string_view::npos) break;
    start = comma + 1;
  }
  return cells;
}

// Physical lines (LF, CRLF or CR endings) with their 1-based numbers; blank and '#' comment lines dropped.
inline std::vector<std::pair<int, std::string_view>> contentLines(std::string_view text) {
  if (text.size() >= 3 && text.compare(0, 3, "\xEF\xBB\xBF") == 0) text.remove_prefix(3);  // UTF-8 BOM
  std::vector<std::pair<int, std::string_view>> out;
  int number = 0;
  std::size_t pos = 0;
  while (pos < text.size()) {
    std::size_t end = text.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) end = text.size();
    ++number;
    const std::string_view line = text.substr(pos, end - pos);
    const std::string_view t = trim(line);
    if (!t.empty() && t.front() != '#') out.emplace_back(number, line);
    pos = end;
    if (pos < text.size() && text[pos] == '\r') ++pos;
    if (pos < text.size() && text[pos] == '\n') ++pos;
  }
  return out;
}

}  // namespace ctr::io::detail
