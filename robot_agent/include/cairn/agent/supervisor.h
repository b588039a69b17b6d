// cairn_agent --supervise: the process runs the agent as its child and starts it again after a crash, with
// --resume, as a systemd unit with Restart=on-failure would (config/cairn-agent@.service).
#pragma once

#include <string>
#include <vector>

namespace cairn::agent {

/// Runs `argv` (argv[0] is the agent's executable; no --supervise in it) as a child process until it ends by
/// itself: exit status 0 (shut down) or 2 (bad input: starting it again would not help) ends the supervisor
/// with that status. Any other end (a signal such as SIGKILL or SIGSEGV, another status) starts it again
/// after a back-off (1 s, doubling to 30 s; back to 1 s after a child that ran 60 s), with --resume added so
/// that it comes back idle with its lock, map and goal offer. The child runs with CAIRN_SUPERVISED=1 in its
/// environment: it then exits with RobotAgent::kRestartExitStatus when a part of it does not stop when asked.
/// SIGINT and SIGTERM are passed to the child and end the supervisor once the child has exited
/// (core::InstallShutdownHandler). `robot_id` names the robot in log lines.
/// @return the exit status.
int SuperviseAgent(std::vector<std::string> argv, const std::string& robot_id);

}  // namespace cairn::agent
