// Clean SIGINT/SIGTERM handling: signals are blocked in every thread and received by one waiter thread, so
// no DDS thread is interrupted and the process tears its participants down (no /dev/shm leftovers).
#pragma once

#include <chrono>

namespace cairn::core {

/// Blocks SIGINT and SIGTERM in the calling thread (and so in every thread created after it) and starts the
/// thread that waits for them. Call once at the top of main(), before any DDS entity exists.
void InstallShutdownHandler();

/// True once SIGINT or SIGTERM arrived (or RequestShutdown() was called).
bool ShutdownRequested();

/// Marks shutdown as requested and wakes every waiter (used by tests and by commands that end the process).
void RequestShutdown();

/// Sleeps up to `timeout`, returning early (true) if shutdown is requested meanwhile.
bool WaitForShutdown(std::chrono::milliseconds timeout);

}  // namespace cairn::core
