// Minimal dependency-free SVG line plots for the examples.
#pragma once

#include <algorithm>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace ctr::examples {

struct Series {
  std::string label;
  std::vector<double> x, y;
  std::string color = "#1f77b4";
  bool dashed = false;
  bool markers = false;
};

/// Writes an SVG plot with axes, ticks, a legend and the series as polylines.
inline void writeSvg(const std::string& path, const std::string& title, const std::string& xlabel,
                     const std::string& ylabel, const std::vector<Series>& series) {
  double x0 = 1e300, x1 = -1e300, y0 = 1e300, y1 = -1e300;
  for (const auto& s : series)
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!std::isfinite(s.y[i])) continue;
      x0 = std::min(x0, s.x[i]);
      x1 = std::max(x1, s.x[i]);
      y0 = std::min(y0, s.y[i]);
      y1 = std::max(y1, s.y[i]);
    }
  if (!(x1 > x0)) x1 = x0 + 1;
  if (!(y1 > y0)) y1 = y0 + 1;
  const double pad = 0.05 * (y1 - y0);
  y0 -= pad;
  y1 += pad;
  const double W = 720, H = 480, L = 80, R = 200, T = 40, B = 60;
  auto X = [&](double v) { return L + (v - x0) / (x1 - x0) * (W - L - R); };
  auto Y = [&](double v) { return H - B - (v - y0) / (y1 - y0) * (H - T - B); };
  std::ostringstream os;
  os << "<svg xmlns='http://www.w3.org/2000/svg' width='" << W << "' height='" << H
     << "' font-family='sans-serif' font-size='12'>\n<rect width='100%' height='100%' fill='white'/>\n";
  os << "<text x='" << W / 2 << "' y='20' text-anchor='middle' font-size='14'>" << title << "</text>\n";
  os << "<rect x='" << L << "' y='" << T << "' width='" << W - L - R << "' height='" << H - T - B
     << "' fill='none' stroke='black'/>\n";
  for (int k = 0; k <= 5; ++k) {
    const double vx = x0 + (x1 - x0) * k / 5, vy = y0 + (y1 - y0) * k / 5;
    os << "<text x='" << X(vx) << "' y='" << H - B + 16 << "' text-anchor='middle'>" << std::round(vx * 100) / 100
       << "</text>\n";
    os << "<text x='" << L - 6 << "' y='" << Y(vy) + 4 << "' text-anchor='end'>" << std::round(vy * 100) / 100
       << "</text>\n";
    os << "<line x1='" << L << "' x2='" << W - R << "' y1='" << Y(vy) << "' y2='" << Y(vy)
       << "' stroke='#ddd'/>\n";
  }
  os << "<text x='" << (L + W - R) / 2 << "' y='" << H - 20 << "' text-anchor='middle'>" << xlabel << "</text>\n";
  os << "<text transform='translate(20," << (T + H - B) / 2 << ") rotate(-90)' text-anchor='middle'>" << ylabel
     << "</text>\n";
  int li = 0;
  for (const auto& s : series) {
    os << "<polyline fill='none' stroke='" << s.color << "' stroke-width='1.8'"
       << (s.dashed ? " stroke-dasharray='6,4'" : "") << " points='";
    for (std::size_t i = 0; i < s.x.size(); ++i)
      if (std::isfinite(s.y[i])) os << X(s.x[i]) << ',' << Y(s.y[i]) << ' ';
    os << "'/>\n";
    if (s.markers)
      for (std::size_t i = 0; i < s.x.size(); ++i)
        if (std::isfinite(s.y[i]))
          os << "<circle cx='" << X(s.x[i]) << "' cy='" << Y(s.y[i]) << "' r='2.5' fill='" << s.color << "'/>\n";
    const double ly = T + 16 + 18 * li++;
    os << "<line x1='" << W - R + 10 << "' x2='" << W - R + 40 << "' y1='" << ly << "' y2='" << ly << "' stroke='"
       << s.color << "' stroke-width='2'" << (s.dashed ? " stroke-dasharray='6,4'" : "") << "/>\n";
    os << "<text x='" << W - R + 46 << "' y='" << ly + 4 << "'>" << s.label << "</text>\n";
  }
  os << "</svg>\n";
  std::ofstream(path) << os.str();
}

}  // namespace ctr::examples
