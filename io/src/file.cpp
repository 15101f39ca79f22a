#include "ctr/io/file.hpp"

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <new>

#include "ctr/io/data.hpp"

namespace fs = std::filesystem;

namespace ctr::io {
namespace {

std::string errnoText(int err) {
  return err ? std::string(std::strerror(err)) : std::string("unknown error");
}

}  // namespace

void writeFileAtomic(const std::string& path, const std::string& content) {
  if (path.empty()) throw InputError("<output>", 0, "", "empty output file name");
  const fs::path target(path);
  if (!target.has_filename()) throw InputError(path, 0, "", "not a file name (ends with a separator)");
  // A unique temporary name beside the target, so that the rename stays on one file system.
  static std::atomic<unsigned long> counter{0};
  const auto stamp = static_cast<unsigned long>(std::chrono::steady_clock::now().time_since_epoch().count());
  std::FILE* f = nullptr;
  std::string tmp;
  int err = 0;
  for (int attempt = 0; attempt < 16 && !f; ++attempt) {
    tmp = (target.parent_path() / ("." + target.filename().string() + ".tmp" + std::to_string(stamp % 1000000007UL) +
                                   "_" + std::to_string(counter++)))
              .string();
    errno = 0;
    f = std::fopen(tmp.c_str(), "wbx");  // x: fail if it exists (C11)
    err = errno;
    if (!f && err != EEXIST) break;
  }
  if (!f) throw InputError(path, 0, "", "cannot write the file: " + errnoText(err));
  errno = 0;
  bool ok = std::fwrite(content.data(), 1, content.size(), f) == content.size();
  ok = std::fflush(f) == 0 && ok;
  err = errno;
  ok = std::fclose(f) == 0 && ok;
  if (ok) {
    errno = 0;
    ok = std::rename(tmp.c_str(), path.c_str()) == 0;
    err = errno;
  }
  if (!ok) {
    std::remove(tmp.c_str());
    throw InputError(path, 0, "", "cannot write the file: " + errnoText(err));
  }
}

std::string readFile(const std::string& path) {
  if (path.empty()) throw InputError("<input>", 0, "", "empty file name");
  const std::string file = expandDataPath(path);  // "${CTR_DATA}/..." is a file of the data folder
  std::error_code ec;
  const fs::file_status st = fs::status(file, ec);
  if (!fs::exists(st)) {
    throw InputError(path, 0, "",
                     ec && ec != std::errc::no_such_file_or_directory ? "cannot access the file: " + ec.message()
                     : isDataPath(path)                               ? missingDataMessage(path)
                                                                      : std::string("file not found"));
  }
  if (fs::is_directory(st)) throw InputError(path, 0, "", "is a directory, not a file");
  try {
    errno = 0;
    std::ifstream in(file, std::ios::binary);
    if (!in) throw InputError(path, 0, "", "cannot open the file for reading: " + errnoText(errno));
    // Chunked read with a size cap, so that a device such as /dev/zero cannot exhaust memory.
    constexpr std::size_t kMaxBytes = std::size_t{1} << 30;
    std::string out;
    char buf[1 << 16];
    while (in.read(buf, sizeof buf) || in.gcount() > 0) {
      out.append(buf, static_cast<std::size_t>(in.gcount()));
      if (out.size() > kMaxBytes) throw InputError(path, 0, "", "file is larger than 1 GiB; not an input file?");
    }
    if (in.bad()) throw InputError(path, 0, "", "read error: " + errnoText(errno));
    return out;
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(path, 0, "", "file too large to read into memory");
  } catch (const std::exception& e) {
    throw InputError(path, 0, "", std::string("cannot read the file: ") + e.what());
  }
}

}  // namespace ctr::io
