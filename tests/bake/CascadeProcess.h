#pragma once
// The built `cascade` program as a child process for the bake tests: start it with its
// output to a log, wait for its exit status (128 + signal when killed), read the log.
#include "libsph/io/AtomicFile.h"

#include <fcntl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

namespace cascade::test {

inline const std::string& cascadeBinary() {
  static const std::string path = std::string(CASCADE_BINARY_DIR) + "/cascade";
  return path;
}

/// Starts `cascade args...` with stdout/stderr to `log`; returns the pid.
inline pid_t spawn(const std::vector<std::string>& args, const std::filesystem::path& log) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
    }
    std::vector<std::string> copy = args;
    std::string program = cascadeBinary();
    std::vector<char*> argv{program.data()};
    for (std::string& a : copy) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(cascadeBinary().c_str(), argv.data());
    std::_Exit(127);
  }
  return pid;
}

inline int waitFor(pid_t pid) {
  int status = 0;
  ::waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

inline int run(const std::vector<std::string>& args, const std::filesystem::path& log) { return waitFor(spawn(args, log)); }

/// The log's text, or "" if it cannot be read.
inline std::string readLog(const std::filesystem::path& log) {
  try {
    return readTextFile(log);
  } catch (...) {
    return "";
  }
}

} // namespace cascade::test
