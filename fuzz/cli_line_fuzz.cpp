// Fuzz harness: operator command lines (cairn_base's REPL, scripts, `--` one-shots, the GUI's command box)
// through CommandShell::Execute on a real FleetClient. Every line must be run, refused or reported invalid
// (exit code 0, 1 or 2) with nothing thrown out of Execute.
//
// The input: its first byte picks the output (bit 0: --json); the rest is a script of up to 16 lines, each
// completed (its last word, as Tab does) and run by the shell's Execute in turn (places defined by one line
// are seen by the next).
//
// The client is made once per process: DDS on domain 232 (the shipped loopback-only profile; run in a private
// network namespace, tests/netns_run.sh), no robot on it, and short discovery (10 ms) and command (5 ms)
// timeouts, so a command to a robot is refused at once and a stop (sent even to unknown robots) gives up
// after 5 ms. The first `robots`, `links` or `stop all` waits once for discovery (1.5-2.5 s after the client
// started). Other waits (teleop, watch, --wait) are cancelled at their first check, as by Ctrl-C. Files are
// written only into a scratch folder of this process, emptied after every input (LineToRun()).
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "cairn/base/command_shell.h"
#include "cairn/base/fleet_client.h"

namespace {

constexpr int kMaxLines = 16;

struct Harness {
  Harness() {
    scratch = std::filesystem::temp_directory_path() / ("cairn_fuzz_cli_" + std::to_string(::getpid()));
    std::filesystem::create_directories(scratch);
    cairn::base::FleetClientOptions options;
    options.base_id = "fuzz";
    options.domain_id = 232;
    options.discovery_s = 0.01;
    options.command_timeout_s = 0.005;
    options.command_retry_s = 0.002;
    client = std::make_unique<cairn::base::FleetClient>(options);
  }
  ~Harness() {
    client.reset();
    std::error_code ignored;
    std::filesystem::remove_all(scratch, ignored);
  }
  void EmptyScratch() {
    std::error_code ignored;
    for (const auto& entry : std::filesystem::directory_iterator(scratch, ignored)) {
      std::filesystem::remove_all(entry.path(), ignored);
    }
  }

  std::filesystem::path scratch;
  std::unique_ptr<cairn::base::FleetClient> client;
};

// The line to run for `line`, or "" to skip it. `wait` and `sleep` are skipped: with no robot on the domain
// they only wait (100 ms, then cancelled) and would slow the run tenfold; their numbers go through the same
// ParseNumber as every other command's. The FILE of `map R --save FILE` and `snapshot R FILE` is moved into
// the scratch folder ('/' becomes '_'), so that no input writes anywhere else.
std::string LineToRun(const std::string& line, const std::filesystem::path& scratch) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string word; in >> word;) words.push_back(word);
  if (words.empty()) return line;
  const std::string& command = words[0];
  if (command == "wait" || command == "sleep") return "";
  const std::size_t file = command == "map" ? 3 : command == "snapshot" ? 2 : 0;
  if (file == 0 || words.size() <= file) return line;
  std::replace(words[file].begin(), words[file].end(), '/', '_');
  words[file] = (scratch / words[file]).string();
  std::string rebuilt;
  for (const std::string& word : words) rebuilt += (rebuilt.empty() ? "" : " ") + word;
  return rebuilt;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static Harness harness;
  if (size == 0) return 0;
  std::atomic<bool> cancel{false};
  cairn::base::ShellOptions options;
  options.json = (data[0] & 1) != 0;
  options.cancel = &cancel;
  std::ostringstream out;
  cairn::base::CommandShell shell(*harness.client, options, out);
  std::istringstream script(std::string(reinterpret_cast<const char*>(data) + 1, size - 1));
  std::string line;
  for (int n = 0; n < kMaxLines && std::getline(script, line); ++n) {
    line = LineToRun(line, harness.scratch);
    if (line.empty()) continue;
    std::istringstream words_in(line);
    std::vector<std::string> words;
    for (std::string word; words_in >> word;) words.push_back(word);
    if (!words.empty()) {  // Tab completion of the last word, given the words before it
      const std::string prefix = words.back();
      words.pop_back();
      (void)shell.Complete(words, prefix);
    }
    cancel = true;
    const int code = shell.Execute(line);
    if (code != cairn::base::kOk && code != cairn::base::kRefused && code != cairn::base::kUsage) {
      std::fprintf(stderr, "cli_line: exit code %d for line '%s'\n", code, line.c_str());
      std::abort();
    }
    out.str("");
  }
  harness.EmptyScratch();
  return 0;
}
