// Clean SIGINT/SIGTERM handling: signals are blocked in every thread and received by one waiter thread, so
// no DDS thread is interrupted and the process tears its participants down (no /dev/shm leftovers).
#pragma once

#include <chrono>

namespace cairn::core {

/// Blocks SIGINT and SIGTERM in the calling thread (and so in every thread created after it) and starts the
/// thread that waits for them. Call once at the top of main(), before any DDS entity exists.
void InstallShutdownHandler();

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
