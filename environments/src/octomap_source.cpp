#include "ctr/environments/octomap_source.hpp"

#include <octomap/AbstractOcTree.h>
#include <octomap/OcTree.h>

#include <cmath>
#include <fstream>
#include <iostream>
#include <sstream>

#include "ctr/io/input_error.hpp"

namespace ctr::environments {

namespace {

// Captures std::cerr (where OctoMap reports problems) for the lifetime of the object.
class CerrCapture {
 public:
  CerrCapture() : old_(std::cerr.rdbuf(buf_.rdbuf())) {}
  ~CerrCapture() { std::cerr.rdbuf(old_); }
  std::string text() const {
    std::string s = buf_.str();
    while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
    for (char& c : s)
      if (c == '\n') c = ' ';
    return s;
  }

 private:
  std::ostringstream buf_;
  std::streambuf* old_;
};

[[noreturn]] void fail(const std::string& path, const std::string& msg, const std::string& captured = {}) {
  throw io::InputError(path, 0, "", captured.empty() ? msg : msg + " (octomap: " + captured + ")");
}

bool endsWith(const std::string& s, const char* e) {
  const std::string x(e);
  return s.size() >= x.size() && s.compare(s.size() - x.size(), x.size(), x) == 0;
}

}  // namespace

std::shared_ptr<octomap::OcTree> loadOcTreeFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) fail(path, "cannot open the octree file (missing or unreadable)");
  std::string first;
  std::getline(in, first);
  if (!first.empty() && first.back() == '\r') first.pop_back();
  std::shared_ptr<octomap::OcTree> tree;
  if (endsWith(path, ".bt")) {
    if (first.rfind("# Octomap OcTree binary file", 0) != 0)
      fail(path, "not an OctoMap binary file (the first line must be '# Octomap OcTree binary file')");
    // Header: id, size, res, data.
    long long declared = -1;
    double res = 0.0;
    std::string line;
    bool data = false;
    while (std::getline(in, line)) {
      std::istringstream ss(line);
      std::string key;
      ss >> key;
      if (key == "size") ss >> declared;
      if (key == "res") ss >> res;
      if (key == "data") {
        data = true;
        break;
      }
    }
    if (!data || !(res > 0.0) || !std::isfinite(res)) fail(path, "corrupt OctoMap binary header (no 'res' or 'data')");
    in.clear();
    in.seekg(0);
    tree = std::make_shared<octomap::OcTree>(res);
    CerrCapture cap;
    const bool ok = tree->readBinary(in);
    const std::size_t n = tree->size();
    const bool stream_ok = !in.fail();
    const std::string msg = cap.text();
    if (!ok || !stream_ok) fail(path, "corrupt or truncated OctoMap binary data", msg);
    if (declared >= 0 && static_cast<long long>(n) != declared) {
      std::ostringstream os;
      os << "corrupt OctoMap binary data: header says " << declared << " nodes, " << n << " were read";
      fail(path, os.str(), msg);
    }
  } else if (endsWith(path, ".ot")) {
    if (first.rfind("# Octomap OcTree file", 0) != 0)
      fail(path, "not an OctoMap .ot file (the first line must be '# Octomap OcTree file')");
    in.clear();
    in.seekg(0);
    octomap::AbstractOcTree* raw = nullptr;
    std::string msg;
    {
      CerrCapture cap;
      raw = octomap::AbstractOcTree::read(in);
      msg = cap.text();
    }
    if (raw == nullptr) fail(path, "corrupt or unsupported OctoMap .ot file", msg);
    auto* oc = dynamic_cast<octomap::OcTree*>(raw);
    if (oc == nullptr) {
      const std::string type = raw->getTreeType();
      delete raw;
      fail(path, "the .ot file holds a '" + type + "', not an OcTree");
    }
    tree.reset(oc);
  } else {
    fail(path, "octree files must end in .bt or .ot");
  }
  if (tree->getRoot() == nullptr || tree->size() == 0) fail(path, "the octree is empty");
  tree->updateInnerOccupancy();
  return tree;
}

}  // namespace ctr::environments
