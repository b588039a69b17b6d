// Clean SIGINT/SIGTERM handling: signals are blocked in every thread and received by one waiter thread, so
// no DDS thread is interrupted and the process tears its participants down (no /dev/shm leftovers).
#pragma once

#include <chrono>

namespace cairn::core {

/// Exit status of a process that a signal's shutdown did not end in time (EX_SOFTWARE: a part of it did not
/// stop), and of one given a second SIGINT/SIGTERM.
constexpr int kForcedExitStatus = 70;
/// How long a process has, from the SIGINT or SIGTERM that asked it to shut down, before it is ended.
constexpr std::chrono::milliseconds kDefaultShutdownDeadline{1500};

/// Blocks SIGINT and SIGTERM in the calling thread (and so in every thread created after it) and starts the
/// thread that waits for them. Call once at the top of main(), before any DDS entity exists.
/// Shutdown by signal has two stages: the first SIGINT/SIGTERM requests it (ShutdownRequested(); the process
/// tears down cleanly), and if the process is still running SetShutdownDeadline's time later (default
/// kDefaultShutdownDeadline) or a second SIGINT/SIGTERM arrives, it writes why on stderr and ends with
/// _exit(kForcedExitStatus), whatever its threads are doing. A RequestShutdown() call arms no deadline.
void InstallShutdownHandler();

/// The second stage's deadline, counted from the first SIGINT/SIGTERM (e.g. longer for a process that writes
/// a large file at exit). @throws std::invalid_argument unless `deadline` is in [1 ms, 10 min].
void SetShutdownDeadline(std::chrono::milliseconds deadline);

/// Makes SIGINT call `on_interrupt` (on the waiter thread; it must be async-safe with respect to the
/// caller's state, e.g. set an atomic flag) instead of requesting shutdown: an interactive console's Ctrl-C
/// cancels the running wait or clears the line. nullptr restores the default. SIGTERM always shuts down.
void SetInterruptHandler(void (*on_interrupt)());

/// True once SIGTERM arrived, or SIGINT without an interrupt handler (or RequestShutdown() was called).
bool ShutdownRequested();

/// Marks shutdown as requested and wakes every waiter (used by tests and by commands that end the process).
void RequestShutdown();

/// Sleeps up to `timeout`, returning early (true) if shutdown is requested meanwhile.
bool WaitForShutdown(std::chrono::milliseconds timeout);

}  // namespace cairn::core
