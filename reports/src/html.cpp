// Assembly of a self-contained HTML report from the embedded bundles.
#include <stdexcept>

#include "ctr/io/file.hpp"
#include "ctr/reports/reports.hpp"

namespace ctr::reports {
namespace detail {
const std::string& bundle(const std::string& name);  // generated/report_bundles.cpp
}

namespace {
std::string escapeHtml(const std::string& s) {
  std::string o;
  for (char c : s) {
    switch (c) {
      case '&':
        o += "&amp;";
        break;
      case '<':
        o += "&lt;";
        break;
      case '>':
        o += "&gt;";
        break;
      case '"':
        o += "&quot;";
        break;
      default:
        o += c;
    }
  }
  return o;
}

// JSON text safe inside <script>: "</" cannot close the element ("<\/" is the same JSON string).
std::string scriptSafe(const std::string& json) {
  std::string o;
  o.reserve(json.size());
  for (std::size_t k = 0; k < json.size(); ++k) {
    if (json[k] == '<' && k + 1 < json.size() && (json[k + 1] == '/' || json[k + 1] == '!')) {
      o += "\\u003c";
    } else {
      o += json[k];
    }
  }
  return o;
}

}  // namespace

const char* toString(ReportKind kind) {
  switch (kind) {
    case ReportKind::Diagnosis:
      return "diagnosis";
    case ReportKind::Planning:
      return "planning";
    case ReportKind::Sweep:
      return "sweep";
    case ReportKind::Bench:
      return "bench";
    case ReportKind::Design:
      return "design";
  }
  return "diagnosis";
}

std::string renderHtml(ReportKind kind, const std::string& title, const std::string& data_json) {
  const std::string name = toString(kind);
  const std::string& js = detail::bundle(name + ".js");
  if (js.empty()) throw std::runtime_error("the " + name + " report bundle is missing from this build");
  std::string h;
  h.reserve(js.size() + data_json.size() + 4096);
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  h += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h += "<meta name=\"generator\" content=\"ctr " + name + " report\">\n";
  h += "<title>" + escapeHtml(title) + "</title>\n<style>\n" + detail::bundle("style.css") + "\n</style>\n</head>\n";
  h += "<body class=\"ctr-" + name + "\">\n<div id=\"app\" data-kind=\"" + name + "\"></div>\n";
  h += "<script type=\"application/json\" id=\"ctr-data\">" + scriptSafe(data_json) + "</script>\n";
  h += "<script>\n" + js + "\n</script>\n</body>\n</html>\n";
  return h;
}

std::string benchHtml(const std::string& summary_json, const std::string& title) {
  return renderHtml(ReportKind::Bench, title, summary_json);
}

void writeHtml(const std::string& path, const std::string& html) {
  io::writeFileAtomic(path, html);
}

}  // namespace ctr::reports
