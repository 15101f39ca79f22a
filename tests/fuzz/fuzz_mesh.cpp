// Fuzz target: mesh loading through the project's wrapper (ctr::environments::loadMesh, then extent and closedness).
// The first byte picks the file extension (.stl, .obj, .ply, .off); the rest is the file.
#include <string>

#include "ctr/environments/mesh_source.hpp"
#include "ctr/io/input_error.hpp"
#include "fuzz_common.hpp"

CTR_FUZZ_TARGET(mesh) {
  if (size == 0) return 0;
  static const char* const kExt[] = {"stl", "obj", "ply", "off"};
  const std::string path = ctr::fuzz::writeScratch(std::string("input.") + kExt[data[0] % 4], data + 1, size - 1);
  try {
    const ctr::environments::TriangleMesh mesh = ctr::environments::loadMesh(path, 1e-3);
    (void)mesh.extent();
    (void)mesh.openEdges();
  } catch (const ctr::io::InputError&) {
  }
  return 0;
}
