// A command line run through the shell for the tests that drive the product's executables: what it
// printed (stderr joined to stdout) and its exit status.
#pragma once

#include <sys/wait.h>

#include <cstdio>
#include <string>

namespace quad::test {

struct CommandOutput {
  int status = -1;  // the exit code; −1 when it could not start or did not exit (a signal)
  std::string out;
};

inline CommandOutput run_command(const std::string& command) {
  CommandOutput result;
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return result;
  char buffer[4096];
  for (size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;) result.out.append(buffer, n);
  const int status = pclose(pipe);
  result.status = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

}  // namespace quad::test
