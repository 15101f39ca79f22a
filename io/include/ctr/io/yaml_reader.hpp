/// @file yaml_reader.hpp
/// @brief Reading values out of a YAML document with messages that name the file, line and key (InputError). Used by
/// the loaders of YAML inputs (queries, design spaces, environment descriptions); each adds the readers of its own
/// types on top.
#pragma once

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <set>
#include <string>

#include "ctr/io/input_error.hpp"

namespace ctr::io {

/// @brief Checked reads of YAML nodes of the document `file`; every failure throws InputError(file, line, key, ...).
struct YamlReader {
  std::string file;

  /// @brief 1-based line of the node (0 when undefined).
  static int lineOf(const YAML::Node& n) {
    if (!n.IsDefined()) return 0;
    const YAML::Mark m = n.Mark();
    return m.line >= 0 ? m.line + 1 : 0;
  }
  [[noreturn]] void fail(const YAML::Node& n, const std::string& key, const std::string& msg) const {
    throw InputError(file, lineOf(n), key, msg);
  }
  /// @brief Refuses any key of `map` not in `keys` (named `where.key`), listing the known ones.
  void allowOnly(const YAML::Node& map, const std::string& where, const std::set<std::string>& keys) const {
    for (const auto& kv : map) {
      if (kv.first.IsSequence() || kv.first.IsMap())
        fail(kv.first, where, "a key must be a name, not a list or a mapping");
      const std::string k = kv.first.as<std::string>("");
      if (!keys.count(k)) {
        std::string known;
        for (const auto& x : keys) known += (known.empty() ? "" : ", ") + x;
        throw InputError(file, lineOf(kv.first), where.empty() ? k : where + "." + k,
                         "unknown key (known: " + known + ")");
      }
    }
  }
  /// @brief A finite number.
  double number(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "must be a number");
    double v = 0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, key, "'" + n.Scalar() + "' is not a number");
    }
    if (!std::isfinite(v)) fail(n, key, "must be finite");
    return v;
  }
  /// @brief true or false (also yes/no, on/off as YAML 1.1 reads them).
  bool boolean(const YAML::Node& n, const std::string& key) const {
    bool v = false;
    if (!n.IsScalar() || !YAML::convert<bool>::decode(n, v)) fail(n, key, "must be true or false");
    return v;
  }
  /// @brief A scalar as text.
  std::string text(const YAML::Node& n, const std::string& key) const {
    if (!n.IsScalar()) fail(n, key, "must be a string");
    return n.Scalar();
  }
};

}  // namespace ctr::io
