#include "process_util.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>

extern char** environ;

namespace sg::test {

std::string loopbackUri() { return std::string("file://") + SG_SOURCE_DIR + "/config/dds/loopback.xml"; }

void useLoopbackDds() {
  const char* uri = std::getenv("CYCLONEDDS_URI");
  if (uri == nullptr || uri[0] == '\0') setenv("CYCLONEDDS_URI", loopbackUri().c_str(), 1);
}

std::map<std::string, std::string> loopbackEnv(int domain) {
  return {{"CYCLONEDDS_URI", loopbackUri()}, {"SG_DDS_DOMAIN", std::to_string(domain)}};
}

ChildProcess::ChildProcess(std::vector<std::string> argv, const std::map<std::string, std::string>& env,
                           const std::string& log_path) {
  std::vector<std::string> env_strings;
  for (char** e = environ; *e != nullptr; ++e) {
    const std::string entry(*e);
    if (env.count(entry.substr(0, entry.find('='))) == 0) env_strings.push_back(entry);
  }
  for (const auto& [key, value] : env) env_strings.push_back(key + "=" + value);
  std::vector<char*> envp;
  for (auto& s : env_strings) envp.push_back(s.data());
  envp.push_back(nullptr);
  std::vector<char*> args;
  for (auto& s : argv) args.push_back(s.data());
  args.push_back(nullptr);
  const int log_fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (log_fd < 0) throw std::runtime_error("cannot write " + log_path);
  const pid_t parent = getpid();
  pid_ = fork();
  if (pid_ < 0) throw std::runtime_error(std::string("fork: ") + std::strerror(errno));
  if (pid_ == 0) {
    prctl(PR_SET_PDEATHSIG, SIGKILL);  // a crashed test leaves nothing behind
    if (getppid() != parent) _exit(1);
    dup2(log_fd, STDOUT_FILENO);
    dup2(log_fd, STDERR_FILENO);
    sigset_t none;
    sigemptyset(&none);
    sigprocmask(SIG_SETMASK, &none, nullptr);
    execve(args[0], args.data(), envp.data());
    _exit(127);
  }
  close(log_fd);
}

ChildProcess::~ChildProcess() {
  if (pid_ <= 0 || status_) return;
  kill(pid_, SIGTERM);
  if (!waitFor(std::chrono::milliseconds(5000))) {
    kill(pid_, SIGKILL);
    waitFor(std::chrono::milliseconds(5000));
  }
}

void ChildProcess::signal(int sig) const {
  if (pid_ > 0 && !status_) kill(pid_, sig);
}

std::optional<int> ChildProcess::waitFor(std::chrono::milliseconds timeout) {
  if (status_) return status_;
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  for (;;) {
    int status = 0;
    const pid_t r = waitpid(pid_, &status, WNOHANG);
    if (r == pid_) {
      status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      return status_;
    }
    if (std::chrono::steady_clock::now() >= deadline) return std::nullopt;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
}

std::vector<pid_t> childrenOf(pid_t pid) {
  std::vector<pid_t> out;
  const std::string task_dir = "/proc/" + std::to_string(pid) + "/task";
  DIR* dir = opendir(task_dir.c_str());
  if (dir == nullptr) return out;
  while (dirent* entry = readdir(dir)) {
    if (entry->d_name[0] == '.') continue;
    std::ifstream in(task_dir + "/" + entry->d_name + "/children");
    pid_t child = 0;
    while (in >> child) out.push_back(child);
  }
  closedir(dir);
  return out;
}

pid_t childMatching(pid_t pid, const std::string& needle) {
  for (pid_t child : childrenOf(pid)) {
    std::string cmdline = readFile("/proc/" + std::to_string(child) + "/cmdline");
    for (char& c : cmdline) {
      if (c == '\0') c = ' ';
    }
    if (cmdline.find(needle) != std::string::npos) return child;
  }
  return -1;
}

::testing::AssertionResult exitsWith(ChildProcess& child, int expected, std::chrono::milliseconds timeout,
                                     const std::string& log) {
  const auto status = child.waitFor(timeout);
  if (!status) return ::testing::AssertionFailure() << "did not end within the time limit\n" << tail(log);
  if (*status != expected) {
    return ::testing::AssertionFailure() << "exit status " << *status << ", expected " << expected << "\n"
                                         << tail(log);
  }
  return ::testing::AssertionSuccess();
}

std::string readFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream buffer;
  buffer << in.rdbuf();
  return buffer.str();
}

std::string tail(const std::string& path, int lines) {
  const std::string text = readFile(path);
  std::size_t pos = text.size();
  for (int i = 0; i <= lines && pos > 0; ++i) {
    pos = text.rfind('\n', pos - 1);
    if (pos == std::string::npos) {
      pos = 0;
      break;
    }
  }
  return "--- " + path + " ---\n" + text.substr(pos);
}

}  // namespace sg::test
