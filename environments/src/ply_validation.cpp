#include "ply_validation.hpp"

#include <algorithm>
#include <cfloat>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <system_error>
#include <vector>

#include "ctr/io/input_error.hpp"

namespace ctr::environments::detail {
namespace {

enum class Type { Char, UChar, Short, UShort, Int, UInt, Float, Double };

// The type names assimp's PLY reader knows (other spellings, e.g. "double64", are refused).
bool parseType(std::string_view s, Type& t) {
  static const struct {
    const char* name;
    Type type;
  } kTypes[] = {{"char", Type::Char},   {"int8", Type::Char},     {"uchar", Type::UChar},   {"uint8", Type::UChar},
                {"short", Type::Short}, {"int16", Type::Short},   {"ushort", Type::UShort}, {"uint16", Type::UShort},
                {"int", Type::Int},     {"int32", Type::Int},     {"uint", Type::UInt},     {"uint32", Type::UInt},
                {"float", Type::Float}, {"float32", Type::Float}, {"double", Type::Double}, {"float64", Type::Double}};
  for (const auto& k : kTypes)
    if (s == k.name) {
      t = k.type;
      return true;
    }
  return false;
}

// Facts about each type, one row per Type in enum order: canonical name, size in bytes, integer range.
struct TypeTraits {
  const char* name;
  std::size_t size;
  bool integer;
  long long lo, hi;  // 0, 0 for the real types
};
constexpr TypeTraits kTraits[] = {{"char", 1, true, INT8_MIN, INT8_MAX},
                                  {"uchar", 1, true, 0, UINT8_MAX},
                                  {"short", 2, true, INT16_MIN, INT16_MAX},
                                  {"ushort", 2, true, 0, UINT16_MAX},
                                  {"int", 4, true, INT32_MIN, INT32_MAX},
                                  {"uint", 4, true, 0, UINT32_MAX},
                                  {"float", 4, false, 0, 0},
                                  {"double", 8, false, 0, 0}};
static_assert(sizeof(kTraits) / sizeof(kTraits[0]) == static_cast<std::size_t>(Type::Double) + 1, "one row per Type");
const TypeTraits& traits(Type t) {
  return kTraits[static_cast<std::size_t>(t)];
}

std::size_t sizeOf(Type t) {
  return traits(t).size;
}
bool isInteger(Type t) {
  return traits(t).integer;
}
bool isSigned(Type t) {
  return traits(t).lo < 0;
}
const char* typeName(Type t) {
  return traits(t).name;
}

struct Property {
  std::string name, type_text;  // type_text: as declared ("float", "list uchar int")
  bool list = false;
  Type count_type = Type::UChar, type = Type::Float;
  bool vertex_index = false;  // face vertex_indices / vertex_index
  bool texcoord = false;      // face texcoord list
};

struct Element {
  std::string name;
  unsigned long long count = 0;
  int line = 0;
  std::vector<Property> props;
};

enum class Format { Ascii, LittleEndian, BigEndian };

// A token for a message: at most 40 characters, control and non-ASCII bytes as \xNN.
std::string quote(std::string_view s) {
  std::string out = "'";
  const std::size_t n = std::min<std::size_t>(s.size(), 40);
  for (std::size_t i = 0; i < n; ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += static_cast<char>(c);
    } else {
      static const char* const kHex = "0123456789abcdef";
      out += "\\x";
      out += kHex[c >> 4];
      out += kHex[c & 15];
    }
  }
  if (s.size() > n) out += "...";
  return out + "'";
}

std::vector<std::string_view> splitTokens(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t b = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > b) out.push_back(line.substr(b, i - b));
  }
  return out;
}

bool printableName(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c > 0x20 && c < 0x7f; });
}

// assimp's header parser consumes exactly one separator after some words ("list" in a property line): words must
// be separated by single spaces or tabs.
bool singleSeparators(std::string_view line) {
  std::size_t a = line.find_first_not_of(" \t"), b = line.find_last_not_of(" \t");
  if (a == std::string_view::npos) return true;
  for (std::size_t i = a; i < b; ++i)
    if ((line[i] == ' ' || line[i] == '\t') && (line[i + 1] == ' ' || line[i + 1] == '\t')) return false;
  return true;
}

bool allDigits(std::string_view s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// An integer token as assimp reads it: digits only for unsigned types (its strtoul10 stops at a sign), an optional
// sign for signed ones; the value must fit the declared type.
bool parseInteger(std::string_view s, Type t, long long& v, std::string& why) {
  std::string_view d = s;
  bool neg = false;
  if (isSigned(t) && !d.empty() && (d[0] == '-' || d[0] == '+')) {
    neg = d[0] == '-';
    d.remove_prefix(1);
  }
  if (!allDigits(d)) {
    why = "is not a valid integer";
    return false;
  }
  while (d.size() > 1 && d[0] == '0') d.remove_prefix(1);
  const long long lo = traits(t).lo, hi = traits(t).hi;
  if (d.size() > 12) {
    why = "is out of range";
    return false;
  }
  v = 0;
  for (char c : d) v = v * 10 + (c - '0');
  if (neg) v = -v;
  if (v < lo || v > hi) {
    why = "is out of range [" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
    return false;
  }
  return true;
}

// A decimal number as assimp's fast_atoreal_move reads it without misparsing: [+-](D+[.D+]|.D+)[(e|E)[+-]D+].
// No "nan" / "inf", no "5." (assimp would leave the '.' for the next value); at most 18 integer digits (assimp's
// 64-bit accumulation throws beyond); finite and within the float range (assimp keeps coordinates as float).
bool parseReal(std::string_view s, double& v, std::string& why) {
  std::size_t i = 0;
  if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
  const std::size_t int_begin = i;
  while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
  const std::size_t int_digits = i - int_begin;
  std::size_t frac_digits = 0;
  if (i < s.size() && s[i] == '.') {
    ++i;
    const std::size_t b = i;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
    frac_digits = i - b;
    if (frac_digits == 0) {
      why = "is not a valid number";
      return false;
    }
  }
  if (int_digits == 0 && frac_digits == 0) {
    why = "is not a valid number";
    return false;
  }
  if (i < s.size() && (s[i] == 'e' || s[i] == 'E')) {
    ++i;
    if (i < s.size() && (s[i] == '+' || s[i] == '-')) ++i;
    const std::size_t b = i;
    while (i < s.size() && s[i] >= '0' && s[i] <= '9') ++i;
    if (i == b) {
      why = "is not a valid number";
      return false;
    }
  }
  if (i != s.size()) {
    why = "is not a valid number";
    return false;
  }
  std::size_t lead = int_begin;
  while (lead < int_begin + int_digits && s[lead] == '0') ++lead;
  if (int_begin + int_digits - lead > 18) {
    why = "is out of range";
    return false;
  }
  const std::string copy(s[0] == '+' ? s.substr(1) : s);  // from_chars does not take a '+'
  const auto r = std::from_chars(copy.data(), copy.data() + copy.size(), v);
  if (r.ec != std::errc() || r.ptr != copy.data() + copy.size() || !std::isfinite(v) || std::abs(v) > FLT_MAX) {
    why = "is out of range (not a finite 32-bit float)";
    return false;
  }
  return true;
}

class Validator {
 public:
  Validator(const std::string& path, const std::string& bytes) : path_(path), b_(bytes) {}

  // The offset at which assimp needs a '\r' inserted (see binaryBody), or npos.
  std::size_t run() {
    parseHeader();
    if (format_ == Format::Ascii)
      asciiBody();
    else
      binaryBody();
    return crlf_patch_at_;
  }

 private:
  [[noreturn]] void fail(int line, const std::string& msg) const { throw io::InputError(path_, line, "", msg); }
  [[noreturn]] void failAt(std::size_t offset, const std::string& msg) const {
    throw io::InputError(path_, 0, "", "byte offset " + std::to_string(offset) + ": " + msg);
  }

  // "element 'face', property 'vertex_indices'" (ASCII: the line locates the instance), or with the instance
  // number ("element 'face' instance 3, property ...") for binary bodies.
  static std::string where(const Element& e, const Property& p, const std::string& instance = "") {
    return "element '" + e.name + "'" + instance + ", property '" + p.name + "'";
  }

  // The next '\n'-terminated line from pos_ (without '\n' and one trailing '\r'); false at the end of the file.
  bool nextLine(std::string_view& line, bool& had_cr, bool& had_lf) {
    if (pos_ >= b_.size()) return false;
    const std::size_t nl = b_.find('\n', pos_);
    const std::size_t end = nl == std::string::npos ? b_.size() : nl;
    line = std::string_view(b_).substr(pos_, end - pos_);
    had_lf = nl != std::string::npos;
    pos_ = had_lf ? nl + 1 : b_.size();
    had_cr = !line.empty() && line.back() == '\r';
    if (had_cr) line.remove_suffix(1);
    ++line_;
    return true;
  }

  void parseHeader() {
    std::string_view line;
    bool cr = false, lf = false;
    if (!nextLine(line, cr, lf) || line.substr(0, 3) != "ply" || line.find_first_not_of(" \t", 3) != std::string::npos)
      fail(1, "not a PLY file (the first line must be 'ply')");
    if (!nextLine(line, cr, lf)) fail(2, "the PLY header has no end_header line");
    {
      const auto t = splitTokens(line);
      const bool ok = t.size() == 3 && t[0] == "format" && t[2] == "1.0" && singleSeparators(line) &&
                      (t[1] == "ascii" || t[1] == "binary_little_endian" || t[1] == "binary_big_endian");
      if (!ok)
        fail(2, "the second PLY header line must be 'format ascii|binary_little_endian|binary_big_endian 1.0', not " +
                    quote(line));
      format_ = t[1] == "ascii"                  ? Format::Ascii
                : t[1] == "binary_little_endian" ? Format::LittleEndian
                                                 : Format::BigEndian;
    }
    while (true) {
      if (line_ >= 1000) fail(line_, "the PLY header has no end_header line within its first 1000 lines");
      if (!nextLine(line, cr, lf)) fail(line_, "the PLY header has no end_header line");
      if (std::any_of(line.begin(), line.end(), [](char c) {
            const auto u = static_cast<unsigned char>(c);
            return (u < 0x20 && c != '\t') || u == 0x7f;
          }))
        fail(line_, "control character in the PLY header line " + quote(line));
      const auto t = splitTokens(line);
      if (t.empty()) fail(line_, "blank line in the PLY header");
      const std::string_view kw = t[0];
      if (kw == "end_header") {
        if (t.size() != 1) fail(line_, "malformed PLY header line " + quote(line));
        if (!lf) fail(line_, "the end_header line does not end with a line break");
        header_crlf_ = cr;
        break;
      }
      if (kw == "comment") {
        // assimp parses a comment before the first element as an element ("comment vertex 3" declares 3 vertices
        // without properties, "comment 5 x" 5 instances of an unnamed element): refuse those forms there.
        if (elements_.empty() && t.size() >= 2) {
          static const char* const kSemantics[] = {"vertex", "face", "tristrips", "edge", "material"};
          const bool semantic =
              std::any_of(std::begin(kSemantics), std::end(kSemantics), [&](const char* s) { return t[1] == s; });
          if (semantic || (t[1][0] >= '0' && t[1][0] <= '9'))
            fail(line_,
                 "a comment before the first element must not start with a number or an element name "
                 "(assimp would read it as an element): " +
                     quote(line));
        }
        continue;
      }
      if (kw == "obj_info") {
        // Between properties, assimp would end the element's property list at this line.
        if (!elements_.empty()) fail(line_, "obj_info lines must come before the first element");
        continue;
      }
      if (kw == "element") {
        if (t.size() != 3 || !printableName(t[1]) || !singleSeparators(line))
          fail(line_, "malformed PLY element line " + quote(line) +
                          " (expected 'element NAME COUNT', words separated by single spaces)");
        if (!allDigits(t[2]))
          fail(line_,
               "element '" + std::string(t[1]) + "': the count " + quote(t[2]) + " is not a non-negative integer");
        std::string_view d = t[2];
        while (d.size() > 1 && d[0] == '0') d.remove_prefix(1);
        // Every instance takes at least one byte: a larger count cannot be genuine (assimp would allocate it).
        if (d.size() > 18 || std::stoull(std::string(d)) > std::min<unsigned long long>(b_.size(), UINT32_MAX))
          fail(line_, "the header declares " + std::string(d) + " elements but the file has only " +
                          std::to_string(b_.size()) + " bytes");
        Element e;
        e.name = std::string(t[1]);
        e.count = std::stoull(std::string(d));
        e.line = line_;
        if (e.name == "tristrips" || e.name == "TextureFile")
          fail(line_, "element '" + e.name + "' is not supported (assimp's PLY reader mishandles it)");
        // assimp 5.2.5 reads the count of an element it does not know from the start of its name (0, or the
        // name's leading digits): its instances would be misread as the next element's.
        const bool known = e.name == "vertex" || e.name == "face" || e.name == "edge" || e.name == "material";
        if (!known && (e.count > 0 || (e.name[0] >= '0' && e.name[0] <= '9')))
          fail(line_, "element '" + e.name +
                          "' is not supported: assimp's PLY reader knows only the elements vertex, "
                          "face, edge and material and would misread the instances of any other");
        for (const auto& o : elements_)
          if (o.name == e.name) fail(line_, "element '" + e.name + "' is declared twice");
        elements_.push_back(e);
        continue;
      }
      if (kw == "property") {
        if (elements_.empty()) fail(line_, "property line before any element: " + quote(line));
        Element& e = elements_.back();
        Property p;
        bool ok = false;
        if (t.size() == 3 && t[1] != "list") {
          ok = parseType(t[1], p.type) && printableName(t[2]);
          p.name = std::string(t[2]);
          p.type_text = std::string(t[1]);
        } else if (t.size() == 5 && t[1] == "list") {
          p.list = true;
          ok = parseType(t[2], p.count_type) && parseType(t[3], p.type) && printableName(t[4]);
          p.name = std::string(t[4]);
          p.type_text = "list " + std::string(t[2]) + " " + std::string(t[3]);
          if (ok && !isInteger(p.count_type))
            fail(line_, "element '" + e.name + "', property '" + p.name +
                            "': the list length type must be an "
                            "integer type, not " +
                            quote(t[2]));
        }
        if (!ok || !singleSeparators(line))
          fail(line_, "malformed PLY property line " + quote(line) +
                          " (expected 'property TYPE NAME' or 'property list COUNT_TYPE ITEM_TYPE NAME', words "
                          "separated by single spaces)");
        for (const auto& o : e.props)
          if (o.name == p.name) fail(line_, "element '" + e.name + "': property '" + p.name + "' is declared twice");
        if (e.name == "face") {
          p.vertex_index = p.name == "vertex_indices" || p.name == "vertex_index";
          p.texcoord = p.list && p.name == "texcoord";
          if (p.vertex_index && !isInteger(p.type))
            fail(line_, "element 'face', property '" + p.name + "': vertex indices must have an integer type, not " +
                            quote(p.type_text));
        }
        e.props.push_back(p);
        continue;
      }
      fail(line_, "malformed PLY header line " + quote(line));
    }
    for (const auto& e : elements_) {
      if (e.count > 0 && e.props.empty())
        fail(e.line, "element '" + e.name + "' has " + std::to_string(e.count) + " instances but no properties");
      if (e.name == "vertex") vertex_count_ = e.count;
      if (e.name == "face") {
        const bool has_indices =
            std::any_of(e.props.begin(), e.props.end(), [](const Property& p) { return p.list && p.vertex_index; });
        const bool has_texcoord =
            std::any_of(e.props.begin(), e.props.end(), [](const Property& p) { return p.texcoord; });
        if (has_texcoord && !has_indices) fail(e.line, "element 'face' has a texcoord list but no vertex_indices list");
      }
    }
  }

  // Checks that apply to both encodings once an instance has been read: `values[k]` holds the list items (or the
  // single value) of property k.
  template <class Fail>
  void checkInstance(const Element& e, const std::vector<std::vector<double>>& values, const std::string& instance,
                     Fail&& failHere) const {
    if (e.name != "face") return;
    std::size_t n_indices = 0;
    for (std::size_t k = 0; k < e.props.size(); ++k) {
      const Property& p = e.props[k];
      if (!p.vertex_index) continue;
      if (p.list) {
        if (values[k].empty())
          failHere(where(e, p, instance) + ": a face needs at least one vertex index, the list is empty");
        n_indices = values[k].size();
      }
      for (double v : values[k])
        if (v < 0 || v >= static_cast<double>(vertex_count_))
          failHere(where(e, p, instance) + ": vertex index " + std::to_string(static_cast<long long>(v)) +
                   " is out of range [0, " + std::to_string(vertex_count_) + ") (the file has " +
                   std::to_string(vertex_count_) + " vertices)");
    }
    for (std::size_t k = 0; k < e.props.size(); ++k) {
      const Property& p = e.props[k];
      if (p.texcoord && values[k].size() > 2 * n_indices)
        failHere(where(e, p, instance) + ": " + std::to_string(values[k].size()) +
                 " texture coordinates for a face with " + std::to_string(n_indices) + " vertex indices (at most " +
                 std::to_string(2 * n_indices) + ")");
    }
  }

  void asciiBody() {
    std::vector<std::vector<double>> values;
    for (const Element& e : elements_) {
      values.assign(e.props.size(), {});
      for (unsigned long long i = 0; i < e.count; ++i) {
        std::string_view line;
        bool cr = false, lf = false;
        if (!nextLine(line, cr, lf))
          fail(line_, "the file ends after line " + std::to_string(line_) + ": element '" + e.name + "' declares " +
                          std::to_string(e.count) + " instances but the body has only " + std::to_string(i));
        // assimp 5.2.5 does not terminate a last line without '\n': it would read the rest of an earlier, longer
        // line as part of it ("3 0 1 2" became "3 0 1 223456").
        if (!lf) fail(line_, "the last line does not end with a line break ('\\n')");
        const auto t = splitTokens(line);
        std::size_t k = 0;
        auto next = [&](const Property& p, const std::string& what) -> std::string_view {
          if (k >= t.size())
            fail(line_,
                 where(e, p) + ": missing " + what + " (the line has only " + std::to_string(t.size()) + " values)");
          return t[k++];
        };
        auto value = [&](const Property& p, Type type, std::string_view tok) {
          std::string why;
          if (isInteger(type)) {
            long long v = 0;
            if (!parseInteger(tok, type, v, why))
              fail(line_, where(e, p) + ": " + quote(tok) + " " + why + " for type " + typeName(type));
            return static_cast<double>(v);
          }
          double v = 0;
          if (!parseReal(tok, v, why))
            fail(line_, where(e, p) + ": " + quote(tok) + " " + why + " for type " + typeName(type));
          return v;
        };
        for (std::size_t pi = 0; pi < e.props.size(); ++pi) {
          const Property& p = e.props[pi];
          auto& out = values[pi];
          out.clear();
          if (!p.list) {
            out.push_back(value(p, p.type, next(p, "value")));
            continue;
          }
          const std::string_view ct = next(p, "list length");
          const double len = value(p, p.count_type, ct);
          if (len < 0) fail(line_, where(e, p) + ": the list length " + quote(ct) + " is negative");
          if (len > static_cast<double>(kPlyMaxListLength))
            fail(line_, where(e, p) + ": the list length " + quote(ct) + " exceeds the limit of " +
                            std::to_string(kPlyMaxListLength));
          const auto n = static_cast<std::size_t>(len);
          if (t.size() - k < n)
            fail(line_, where(e, p) + ": the list declares " + std::to_string(n) + " items but the line has only " +
                            std::to_string(t.size() - k) + " more values");
          for (std::size_t j = 0; j < n; ++j) out.push_back(value(p, p.type, t[k++]));
        }
        if (k != t.size())
          fail(line_, "element '" + e.name + "': " + std::to_string(t.size() - k) +
                          " extra value(s) after the declared properties, starting with " + quote(t[k]));
        const int here = line_;
        checkInstance(e, values, "", [&](const std::string& msg) { fail(here, msg); });
      }
    }
    // Only whitespace may follow the last element.
    std::string_view line;
    bool cr = false, lf = false;
    while (nextLine(line, cr, lf)) {
      const auto t = splitTokens(line);
      if (!t.empty()) fail(line_, "unexpected data after the last element: " + quote(line));
      if (line.find('\r') != std::string_view::npos) fail(line_, "stray '\\r' after the last element");
    }
  }

  // Reads one value of type t at pos_ (the caller checked that it fits).
  double readBinary(Type t) {
    unsigned char raw[8];
    const std::size_t n = sizeOf(t);
    std::memcpy(raw, b_.data() + pos_, n);
    pos_ += n;
    const bool swap = format_ == Format::BigEndian;  // hosts are little endian (x86-64, arm64)
    if (swap) std::reverse(raw, raw + n);
    switch (t) {
      case Type::Char:
        return static_cast<std::int8_t>(raw[0]);
      case Type::UChar:
        return raw[0];
      case Type::Short: {
        std::int16_t v;
        std::memcpy(&v, raw, 2);
        return v;
      }
      case Type::UShort: {
        std::uint16_t v;
        std::memcpy(&v, raw, 2);
        return v;
      }
      case Type::Int: {
        std::int32_t v;
        std::memcpy(&v, raw, 4);
        return v;
      }
      case Type::UInt: {
        std::uint32_t v;
        std::memcpy(&v, raw, 4);
        return v;
      }
      case Type::Float: {
        float v;
        std::memcpy(&v, raw, 4);
        return static_cast<double>(v);
      }
      case Type::Double: {
        double v;
        std::memcpy(&v, raw, 8);
        return v;
      }
    }
    return 0;
  }

  void binaryBody() {
    // assimp 5.2.5 skips one '\n' after the end_header line's line end: after "end_header\r\n" that is the '\n' of
    // the "\r\n", after "end_header\n" it is the first byte of the body, and every value would be read one byte
    // late (found by fuzz_mesh: faces without indices, then an abort in assimp's triangulation). Such a body is
    // valid: loadMesh gives assimp a copy whose end_header line ends with "\r\n" (inserted before its '\n').
    const bool has_data = std::any_of(elements_.begin(), elements_.end(), [](const Element& e) { return e.count > 0; });
    if (has_data && !header_crlf_ && pos_ < b_.size() && b_[pos_] == '\n') crlf_patch_at_ = pos_ - 1;
    std::vector<std::vector<double>> values;
    for (const Element& e : elements_) {
      values.assign(e.props.size(), {});
      for (unsigned long long i = 0; i < e.count; ++i) {
        const std::size_t start = pos_;
        const std::string inst = " instance " + std::to_string(i);
        auto need = [&](const Property& p, std::size_t bytes, const char* what) {
          if (b_.size() - pos_ < bytes)
            failAt(pos_, "the binary body is truncated: " + where(e, p, inst) + " needs " + std::to_string(bytes) +
                             " bytes for its " + what + " but the file has only " + std::to_string(b_.size() - pos_) +
                             " more (element '" + e.name + "' declares " + std::to_string(e.count) + " instances)");
        };
        auto value = [&](const Property& p, Type type) {
          const std::size_t at = pos_;
          const double v = readBinary(type);
          if (!std::isfinite(v) || std::abs(v) > FLT_MAX)
            failAt(at, where(e, p, inst) + ": the " + typeName(type) +
                           " value is not a finite 32-bit float (NaN, infinite or out of range)");
          return v;
        };
        for (std::size_t pi = 0; pi < e.props.size(); ++pi) {
          const Property& p = e.props[pi];
          auto& out = values[pi];
          out.clear();
          if (!p.list) {
            need(p, sizeOf(p.type), "value");
            out.push_back(value(p, p.type));
            continue;
          }
          need(p, sizeOf(p.count_type), "list length");
          const std::size_t at = pos_;
          const double len = readBinary(p.count_type);
          if (len < 0)
            failAt(at, where(e, p, inst) + ": the list length " + std::to_string(static_cast<long long>(len)) +
                           " is negative");
          if (len > static_cast<double>(kPlyMaxListLength))
            failAt(at, where(e, p, inst) + ": the list length " + std::to_string(static_cast<long long>(len)) +
                           " exceeds the limit of " + std::to_string(kPlyMaxListLength));
          const auto n = static_cast<std::size_t>(len);
          need(p, n * sizeOf(p.type), "list items");
          for (std::size_t j = 0; j < n; ++j) out.push_back(value(p, p.type));
        }
        checkInstance(e, values, " instance " + std::to_string(i), [&](const std::string& msg) { failAt(start, msg); });
      }
    }
    // Bytes after the last element are ignored (assimp does not read them).
  }

  const std::string& path_;
  const std::string& b_;
  std::size_t pos_ = 0;
  int line_ = 0;
  Format format_ = Format::Ascii;
  bool header_crlf_ = false;  // the end_header line ends with "\r\n"
  std::size_t crlf_patch_at_ = std::string::npos;
  std::vector<Element> elements_;
  unsigned long long vertex_count_ = 0;
};

}  // namespace

std::size_t validatePly(const std::string& path, const std::string& bytes) {
  return Validator(path, bytes).run();
}

}  // namespace ctr::environments::detail
