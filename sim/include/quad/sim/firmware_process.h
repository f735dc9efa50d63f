// The firmware as a child process: started with the HIL ports' paths, stopped when the run ends.
#pragma once

#include <string>
#include <sys/types.h>
#include <vector>

namespace quad::sim {

class FirmwareProcess {
 public:
  // argv[0] is the executable (searched in PATH when it has no slash); output goes to log_path.
  FirmwareProcess(const std::vector<std::string>& argv, const std::string& log_path);
  ~FirmwareProcess();  // terminates it (SIGTERM, then SIGKILL after 2 s)
  FirmwareProcess(const FirmwareProcess&) = delete;
  FirmwareProcess& operator=(const FirmwareProcess&) = delete;

  // False once the process has exited; `status` then describes how.
  bool running();
  const std::string& status() const { return status_; }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  std::string status_;
};

}  // namespace quad::sim
