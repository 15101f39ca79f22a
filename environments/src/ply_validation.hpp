/// @file ply_validation.hpp
/// @brief Strict well-formedness check of a whole PLY file (header and body), run by loadMesh before the bytes reach
/// assimp. Debian's assimp 5.2.5 keeps its ai_asserts and trusts the file: malformed PLY content made it abort,
/// loop forever, allocate gigabytes or read past its buffers (found by fuzz_mesh, docs/reliability.md "Fuzzing").
/// This is a validator, not an importer: assimp still builds the mesh from a file that passed.
#pragma once

#include <cstddef>
#include <string>

namespace ctr::environments::detail {

/// Upper bound on the length of any list property (face vertex indices included); larger counts are refused
/// before anything is allocated. Polygons with more vertices than this do not occur in anatomy meshes, and
/// assimp's polygon triangulation is quadratic in the polygon size.
constexpr std::size_t kPlyMaxListLength = 1024;

/// @brief Throws ctr::io::InputError (naming `path`, the line for ASCII bodies or the byte offset for binary ones,
/// the element / property and what is wrong) unless `bytes` is a PLY file that assimp reads exactly as declared:
///  - header: `ply`, then `format ascii|binary_little_endian|binary_big_endian 1.0`, then `comment` / `obj_info`
///    lines, `element NAME COUNT` (unique names among vertex, face, edge and material; other names only with
///    COUNT 0; COUNT at most the file size) each followed by its `property TYPE NAME` / `property list COUNT_TYPE
///    ITEM_TYPE NAME` lines (known types, integer list counts and vertex indices, unique names), then `end_header`;
///    words separated by single spaces, no blank or malformed lines, no control characters; no comment before the
///    first element that assimp would read as an element (`comment 5 ...`, `comment vertex ...`);
///  - ASCII body: one line per element instance with exactly the declared values (a list: its length, then that
///    many items), every value valid for its type (integers in range, finite decimal numbers), no missing or extra
///    lines (trailing whitespace allowed), every element line ending with '\n' (the last one included);
///  - binary body: the declared properties and lists fit in the file, list lengths are non-negative and at most
///    kPlyMaxListLength, floating-point values are finite;
///  - face `vertex_indices` / `vertex_index` lists have 1 to kPlyMaxListLength entries, each in [0, vertex count).
/// @return npos, or, for a binary body that starts with a '\n' byte right after "end_header\n" (assimp 5.2.5 would
/// skip that byte as part of the line end and read every value one byte late), the offset of that line's '\n':
/// the caller must give assimp a copy with '\r' inserted there.
std::size_t validatePly(const std::string& path, const std::string& bytes);

}  // namespace ctr::environments::detail
