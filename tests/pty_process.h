// A child process on a pseudo-terminal, for tests that drive an interactive console as a person would: keys
// (including Tab and Ctrl-C) go in, the screen's bytes come out. Test-only helper.
#pragma once

#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <sys/wait.h>
#include <termios.h>
#include <unistd.h>

#include <chrono>
#include <optional>
#include <stdexcept>
#include <string>
#include <vector>

namespace cairn::testing {

class PtyProcess {
 public:
  explicit PtyProcess(const std::vector<std::string>& argv, int columns = 160, int rows = 48) {
    winsize size{};
    size.ws_col = static_cast<unsigned short>(columns);
    size.ws_row = static_cast<unsigned short>(rows);
    pid_ = forkpty(&master_, nullptr, nullptr, &size);
    if (pid_ < 0) throw std::runtime_error("forkpty failed");
    if (pid_ == 0) {
      setenv("TERM", "xterm", 1);
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      execv(args[0], args.data());
      _exit(127);
    }
  }
  ~PtyProcess() {
    if (Running()) {
      kill(pid_, SIGTERM);
      Wait(std::chrono::seconds(5));
    }
    if (Running()) {
      kill(pid_, SIGKILL);
      Wait(std::chrono::seconds(5));
    }
    close(master_);
  }
  PtyProcess(const PtyProcess&) = delete;
  PtyProcess& operator=(const PtyProcess&) = delete;

  /// Types `keys` ("\t" is Tab, "\x03" Ctrl-C, "\r" Enter).
  void Type(const std::string& keys) {
    if (write(master_, keys.data(), keys.size()) != static_cast<ssize_t>(keys.size())) {
      throw std::runtime_error("write to pty failed");
    }
  }

  /// Reads the screen's bytes until `needle` appears in what was read since the last Mark(), or `timeout`.
  bool WaitFor(const std::string& needle, std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (output_.find(needle, mark_) == std::string::npos) {
      const auto left =
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
      if (left.count() <= 0) return false;
      Pump(left);
    }
    return true;
  }
  /// Reads whatever arrives for `duration`.
  void Drain(std::chrono::milliseconds duration) {
    const auto deadline = std::chrono::steady_clock::now() + duration;
    while (std::chrono::steady_clock::now() < deadline) {
      Pump(
          std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now()));
    }
  }
  /// Later WaitFor() calls look only at output after this point.
  void Mark() { mark_ = output_.size(); }
  /// Output since the last Mark().
  std::string SinceMark() const { return output_.substr(mark_); }
  const std::string& output() const { return output_; }

  bool Running() {
    if (exited_) return false;
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      exited_ = true;
      status_ = status;
    }
    return !exited_;
  }
  std::optional<int> Wait(std::chrono::milliseconds timeout) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (Running()) {
      if (std::chrono::steady_clock::now() > deadline) return std::nullopt;
      Drain(std::chrono::milliseconds(10));
    }
    return status_;
  }

 private:
  void Pump(std::chrono::milliseconds timeout) {
    pollfd p{master_, POLLIN, 0};
    if (poll(&p, 1, static_cast<int>(std::max<long>(1, std::min<long>(timeout.count(), 100)))) <= 0) return;
    char chunk[4096];
    const ssize_t n = read(master_, chunk, sizeof(chunk));
    if (n > 0) output_.append(chunk, static_cast<std::size_t>(n));
  }

  pid_t pid_ = -1;
  int master_ = -1;
  std::string output_;
  std::size_t mark_ = 0;
  bool exited_ = false;
  int status_ = 0;
};

}  // namespace cairn::testing
