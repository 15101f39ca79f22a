/// @file fuzz_common.hpp
/// @brief Shared pieces of the fuzz harnesses. Each harness is written once with CTR_FUZZ_TARGET(name) and is
/// compiled two ways:
///  - with CTR_LIBFUZZER defined: the libFuzzer entry point LLVMFuzzerTestOneInput (one executable per target,
///    clang, -fsanitize=fuzzer,address,undefined; CTR_BUILD_FUZZERS=ON);
///  - otherwise: a function registered by name, linked into `fuzz_replay` (any compiler), which replays the seed
///    corpora and the regression inputs as the CTest test `fuzz_corpus_replay` in the normal build.
///
/// A harness returns normally for accepted input and for the documented exceptions (ctr::io::InputError,
/// std::invalid_argument, ...). Anything else (another exception escaping, a crash, a sanitizer report, a timeout)
/// is a finding.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <system_error>
#include <unistd.h>

namespace ctr::fuzz {

using Entry = int (*)(const std::uint8_t*, std::size_t);

inline std::map<std::string, Entry>& registry() {
  static std::map<std::string, Entry> r;
  return r;
}

struct Registrar {
  Registrar(const char* name, Entry e) { registry()[name] = e; }
};

/// @brief A private scratch folder (created once per process, removed at exit) for harnesses that must pass a
/// file to a loader. Nothing else lives in it, so relative paths inside fuzzed descriptions find nothing.
inline const std::filesystem::path& scratchDir() {
  static const std::filesystem::path dir = [] {
    std::error_code ec;
    const char* env = std::getenv("CTR_FUZZ_SCRATCH");  // scripts/run-fuzzers.sh: /dev/shm when available
    std::filesystem::path base = env && *env ? std::filesystem::path(env) : std::filesystem::temp_directory_path(ec);
    if (ec) base = "/tmp";
    std::string tmpl = (base / "ctr-fuzz-XXXXXX").string();
    if (!::mkdtemp(tmpl.data())) std::abort();
    return std::filesystem::path(tmpl);
  }();
  static const struct Cleanup {
    ~Cleanup() {
      std::error_code ec;
      std::filesystem::remove_all(scratchDir(), ec);
    }
  } cleanup;
  return dir;
}

/// @brief Writes the bytes to scratchDir()/name and returns the path.
inline std::string writeScratch(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::filesystem::path p = scratchDir() / name;
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) std::abort();
  return p.string();
}

}  // namespace ctr::fuzz

#ifdef CTR_LIBFUZZER
#define CTR_FUZZ_TARGET(name) extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size)
#else
#define CTR_FUZZ_TARGET(name)                                                                   \
  static int ctr_fuzz_##name(const std::uint8_t* data, std::size_t size);                      \
  static const ::ctr::fuzz::Registrar ctr_fuzz_registrar_##name(#name, &ctr_fuzz_##name);      \
  static int ctr_fuzz_##name(const std::uint8_t* data, std::size_t size)
#endif
