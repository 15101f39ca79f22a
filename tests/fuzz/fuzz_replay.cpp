// Replays files through the fuzz harnesses without libFuzzer (any compiler): the CTest test fuzz_corpus_replay runs
//   fuzz_replay CORPUS_ROOT REGRESSIONS_ROOT
// and feeds every file of ROOT/<target>/ to the harness of that target. A harness that crashes, hits a sanitizer
// error or lets an undocumented exception escape fails the test. `fuzz_replay --target NAME FILE...` replays
// single files.
#include <algorithm>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <iterator>
#include <string>
#include <vector>

#include "fuzz_common.hpp"

namespace fs = std::filesystem;

namespace {

std::vector<std::uint8_t> readBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

bool run(const std::string& target, const fs::path& file) {
  const auto bytes = readBytes(file);
  try {
    ctr::fuzz::registry().at(target)(bytes.data(), bytes.size());
    return true;
  } catch (const std::exception& e) {
    std::cerr << "FAIL " << target << " " << file.string() << ": undocumented exception escaped: " << e.what() << "\n";
  } catch (...) {
    std::cerr << "FAIL " << target << " " << file.string() << ": unknown exception escaped\n";
  }
  return false;
}

}  // namespace

int main(int argc, char** argv) {
  const auto& reg = ctr::fuzz::registry();
  if (argc >= 3 && std::string(argv[1]) == "--target") {
    if (!reg.count(argv[2])) {
      std::cerr << "unknown target " << argv[2] << "\n";
      return 2;
    }
    int failed = 0;
    for (int i = 3; i < argc; ++i) failed += run(argv[2], argv[i]) ? 0 : 1;
    return failed == 0 ? 0 : 1;
  }
  if (argc < 2) {
    std::cerr << "usage: fuzz_replay ROOT... | fuzz_replay --target NAME FILE...\n";
    return 2;
  }
  int files = 0, failed = 0;
  for (const auto& [name, entry] : reg) {
    int n = 0;
    for (int a = 1; a < argc; ++a) {
      const fs::path dir = fs::path(argv[a]) / name;
      if (!fs::is_directory(dir)) continue;
      std::vector<fs::path> list;
      for (const auto& e : fs::directory_iterator(dir))
        if (e.is_regular_file()) list.push_back(e.path());
      std::sort(list.begin(), list.end());
      for (const auto& f : list) {
        ++n;
        failed += run(name, f) ? 0 : 1;
      }
    }
    std::cout << name << ": " << n << " inputs replayed\n";
    files += n;
    if (n == 0) {
      std::cerr << "FAIL " << name << ": no inputs found\n";
      ++failed;
    }
  }
  std::cout << files << " inputs, " << failed << " failures\n";
  return failed == 0 ? 0 : 1;
}
