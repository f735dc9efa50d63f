// Test helpers for programs run as a user would run them, some on a virtual X server: a command's exit
// code, a file's text, and the xvfb-run prefix every display test of the suite shares.
#pragma once

#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace quad_test {

// The exit code of a shell command (-1 if it did not exit normally).
inline int exit_code(const std::string& cmd) {
  const int status = std::system(cmd.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

inline std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline bool have_xvfb() { return exit_code("command -v xvfb-run >/dev/null 2>&1") == 0; }

// The prefix that runs a command on a virtual X server of `screen` (e.g. "1280x720x24"), with `env`
// (variable assignments, e.g. sanitizer options) in its environment. One virtual display at a time across
// the suite: ctest runs tests in parallel, two `xvfb-run -a` starting together can pick the same display
// and one then fails cleaning up, so flock serialises them. `flock -o` keeps the lock in flock itself:
// inherited by the X server, a server left behind by a failed xvfb-run held it and every later display
// test waited for ever. The fixed auth file (safe under the lock) spares xvfb-run its temporary
// directory, whose failed removal made it exit 5 before stopping the server.
inline std::string xvfb_run(const std::string& screen, const std::string& env = "") {
  return std::string("flock -o /tmp/quad_xvfb.lock ") + (env.empty() ? "" : "env " + env + " ") +
         "xvfb-run -a -f /tmp/quad_xvfb.auth -s '-screen 0 " + screen + "' ";
}

}  // namespace quad_test
