// Runs a shell command for the CLI tests: exit code, standard output, and standard error (through a file in `dir`).
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace ctr_test {

struct Proc {
  int code = -1;
  std::string out, err;
};

/// Runs `cmd` through the shell; stderr goes to dir/stderr.txt and is read back (dir is created).
inline Proc runShell(const std::string& cmd, const std::filesystem::path& dir) {
  std::filesystem::create_directories(dir);
  const std::string errf = (dir / "stderr.txt").string();
  Proc r;
  FILE* p = ::popen((cmd + " 2>" + errf).c_str(), "r");
  std::array<char, 4096> buf{};
  while (p && std::fgets(buf.data(), buf.size(), p)) r.out += buf.data();
  const int st = p ? ::pclose(p) : -1;
  r.code = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
  std::ifstream e(errf);
  std::stringstream ss;
  ss << e.rdbuf();
  r.err = ss.str();
  return r;
}

}  // namespace ctr_test
