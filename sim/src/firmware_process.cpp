#include "quad/sim/firmware_process.h"

#include <cerrno>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <stdexcept>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>

namespace quad::sim {

FirmwareProcess::FirmwareProcess(const std::vector<std::string>& argv, const std::string& log_path) {
  if (argv.empty()) throw std::invalid_argument("firmware command is empty");
  std::vector<char*> args;
  for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  const int log = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log < 0) throw std::runtime_error(log_path + ": " + std::strerror(errno));
  // Report an exec failure through a close-on-exec pipe: EOF means exec succeeded.
  int pipe_fd[2];
  if (pipe2(pipe_fd, O_CLOEXEC) != 0) throw std::runtime_error(std::string("pipe: ") + std::strerror(errno));
  pid_ = fork();
  if (pid_ < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid_ == 0) {
    dup2(log, STDOUT_FILENO);
    dup2(log, STDERR_FILENO);
    execvp(args[0], args.data());
    const int err = errno;
    (void)!write(pipe_fd[1], &err, sizeof err);
    _exit(127);
  }
  close(log);
  close(pipe_fd[1]);
  int err = 0;
  const ssize_t n = read(pipe_fd[0], &err, sizeof err);
  close(pipe_fd[0]);
  if (n == static_cast<ssize_t>(sizeof err)) {
    waitpid(pid_, nullptr, 0);
    pid_ = -1;
    throw std::runtime_error("cannot start the firmware '" + argv[0] + "': " + std::strerror(err));
  }
}

bool FirmwareProcess::running() {
  if (pid_ < 0) return false;
  int st = 0;
  const pid_t r = waitpid(pid_, &st, WNOHANG);
  if (r == 0) return true;
  if (WIFEXITED(st)) status_ = "exited with status " + std::to_string(WEXITSTATUS(st));
  else if (WIFSIGNALED(st)) status_ = std::string("killed by signal ") + strsignal(WTERMSIG(st));
  pid_ = -1;
  return false;
}

FirmwareProcess::~FirmwareProcess() {
  if (!running()) return;
  kill(pid_, SIGTERM);
  for (int i = 0; i < 200; ++i) {
    if (waitpid(pid_, nullptr, WNOHANG) == pid_) return;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  kill(pid_, SIGKILL);
  waitpid(pid_, nullptr, 0);
}

}  // namespace quad::sim
