#include "farm/Slurm.h"

#include <fcntl.h>
#include <poll.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <sstream>
#include <stdexcept>

extern char** environ;

namespace cascade::farm {

namespace {

std::vector<std::string> split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream stream(text);
  while (std::getline(stream, part, separator)) parts.push_back(part);
  if (!text.empty() && text.back() == separator) parts.emplace_back();
  return parts;
}

std::string trim(const std::string& text) {
  const auto begin = text.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  return text.substr(begin, text.find_last_not_of(" \t\r\n") - begin + 1);
}

/// The first line of a command's complaint, for one-line errors.
std::string firstLine(const CommandOutput& output) {
  std::string text = trim(output.err.empty() ? output.out : output.err);
  text = text.substr(0, text.find('\n'));
  return text.empty() ? "exit status " + std::to_string(output.status) : text;
}

} // namespace

CommandOutput runCommand(const std::vector<std::string>& argv) {
  CommandOutput result;
  int outPipe[2], errPipe[2];
  if (::pipe2(outPipe, O_CLOEXEC) != 0) throw std::runtime_error("farm: cannot create a pipe");
  if (::pipe2(errPipe, O_CLOEXEC) != 0) {
    ::close(outPipe[0]);
    ::close(outPipe[1]);
    throw std::runtime_error("farm: cannot create a pipe");
  }
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, outPipe[1], 1);
  posix_spawn_file_actions_adddup2(&actions, errPipe[1], 2);
  posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  std::vector<std::string> copy = argv;
  std::vector<char*> args;
  for (std::string& a : copy) args.push_back(a.data());
  args.push_back(nullptr);
  pid_t pid = -1;
  const int spawned = ::posix_spawnp(&pid, args[0], &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(outPipe[1]);
  ::close(errPipe[1]);
  if (spawned != 0) {
    ::close(outPipe[0]);
    ::close(errPipe[0]);
    result.status = 127;
    result.err = argv[0] + ": cannot run it (" + std::string(std::strerror(spawned)) + ")";
    return result;
  }
  pollfd fds[2] = {{outPipe[0], POLLIN, 0}, {errPipe[0], POLLIN, 0}};
  std::string* sinks[2] = {&result.out, &result.err};
  int open = 2;
  char buffer[4096];
  while (open > 0) {
    if (::poll(fds, 2, -1) < 0) {
      if (errno == EINTR) continue;
      break;
    }
    for (int k = 0; k < 2; ++k) {
      if (fds[k].fd < 0 || !(fds[k].revents & (POLLIN | POLLHUP | POLLERR))) continue;
      const ssize_t n = ::read(fds[k].fd, buffer, sizeof buffer);
      if (n > 0) sinks[k]->append(buffer, std::size_t(n));
      else if (n == 0 || errno != EINTR) {
        ::close(fds[k].fd);
        fds[k].fd = -1;
        --open;
      }
    }
  }
  for (const pollfd& fd : fds)
    if (fd.fd >= 0) ::close(fd.fd);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  result.status = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
  return result;
}

std::string findOnPath(const std::string& program) {
  const char* path = std::getenv("PATH");
  if (!path) return "";
  for (const std::string& dir : split(path, ':')) {
    if (dir.empty()) continue;
    const std::filesystem::path candidate = std::filesystem::path(dir) / program;
    if (::access(candidate.c_str(), X_OK) == 0) return candidate.string();
  }
  return "";
}

bool JobState::live() const {
  static const char* const kLive[] = {"PENDING", "RUNNING", "CONFIGURING", "COMPLETING", "REQUEUED",
                                      "REQUEUE_HOLD", "REQUEUE_FED", "RESIZING", "SUSPENDED", "STOPPED",
                                      "SIGNALING", "STAGE_OUT"};
  return std::find(std::begin(kLive), std::end(kLive), state) != std::end(kLive);
}

std::map<std::string, JobState> queryJobs(const std::vector<std::string>& jobIds) {
  std::map<std::string, JobState> states;
  if (jobIds.empty()) return states;
  std::string list;
  for (const std::string& id : jobIds) list += (list.empty() ? "" : ",") + id;
  const CommandOutput output =
      runCommand({"squeue", "-h", "-r", "--states=all", "-j", list, "-O", "JobArrayID:|,State:|,Reason:|,exit_code:"});
  // squeue exits 1 when none of the ids is known any more: that is an answer, not a failure.
  if (output.status != 0 && output.err.find("Invalid job id") == std::string::npos)
    throw std::runtime_error("squeue: " + firstLine(output));
  std::istringstream lines(output.out);
  std::string line;
  while (std::getline(lines, line)) {
    const std::vector<std::string> fields = split(line, '|');
    if (fields.size() < 4) continue;
    JobState state;
    state.state = trim(fields[1]);
    state.reason = trim(fields[2]);
    state.exitCode = std::atoi(trim(fields[3]).c_str()) >> 8;  // squeue's raw wait status
    const std::string id = trim(fields[0]);
    const auto open = id.find("_[");
    if (open == std::string::npos) {
      states[id] = state;
      continue;
    }
    // Tasks not yet split off their array: "12_[3-5,9%2]".
    const std::string base = id.substr(0, open);
    std::string inside = id.substr(open + 2);
    inside = inside.substr(0, inside.find_first_of("]%"));
    for (const std::string& part : split(inside, ',')) {
      const auto dash = part.find('-');
      const int a = std::atoi(part.c_str());
      const int b = dash == std::string::npos ? a : std::atoi(part.c_str() + dash + 1);
      for (int task = a; task <= b && b - a < 100000; ++task) states[base + "_" + std::to_string(task)] = state;
    }
  }
  return states;
}

std::string submitScript(const std::string& script, const std::string& dependency) {
  std::vector<std::string> argv{"sbatch", "--parsable"};
  if (!dependency.empty()) argv.push_back("--dependency=" + dependency);
  argv.push_back(script);
  const CommandOutput output = runCommand(argv);
  if (output.status != 0) throw std::runtime_error("sbatch " + script + ": " + firstLine(output));
  // --parsable: "id" or "id;cluster"
  const std::string id = trim(output.out.substr(0, output.out.find(';')));
  if (id.empty() || id.find_first_not_of("0123456789") != std::string::npos)
    throw std::runtime_error("sbatch " + script + ": unexpected answer '" + trim(output.out) + "'");
  return id;
}

std::vector<Partition> listPartitions() {
  const CommandOutput output = runCommand({"sinfo", "-h", "-o", "%P|%c|%D"});
  if (output.status != 0) throw std::runtime_error("sinfo: " + firstLine(output));
  std::vector<Partition> partitions;
  std::istringstream lines(output.out);
  std::string line;
  while (std::getline(lines, line)) {
    const std::vector<std::string> fields = split(trim(line), '|');
    if (fields.size() < 3 || fields[0].empty()) continue;
    Partition p;
    p.name = fields[0];
    if (p.name.back() == '*') {
      p.isDefault = true;
      p.name.pop_back();
    }
    p.cpusPerNode = std::atoi(fields[1].c_str());
    p.nodes = std::atoi(fields[2].c_str());
    // One line per kind of node: the same partition again adds nodes.
    auto same = std::find_if(partitions.begin(), partitions.end(), [&](const Partition& q) { return q.name == p.name; });
    if (same == partitions.end()) partitions.push_back(p);
    else {
      same->nodes += p.nodes;
      same->cpusPerNode = std::min(same->cpusPerNode, p.cpusPerNode);
      same->isDefault = same->isDefault || p.isDefault;
    }
  }
  return partitions;
}

} // namespace cascade::farm
