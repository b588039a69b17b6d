// Scheduling classes of an agent's threads on a robot computer with few cores: the control loop and the
// sensor feeding its obstacle checks keep the default priority; mapping, the navigation map and global
// planning run as background work, so that a saturated CPU slows the map, never the loop that stops the
// robot (the paper's resilience lesson: a component's load must not take another down).
#pragma once

#include <string>

namespace cairn::core {

/// The Linux nice value of background threads (mapping, planning): 10, about a tenth of a default thread's
/// CPU share under the kernel's fair scheduler when both want the CPU.
inline constexpr int kBackgroundNice = 10;

/// Gives the calling thread (only it: Linux threads carry their own nice value) the nice value `nice`
/// (-20..19; raising it needs no privilege). Returns false and says why in `why` (if not null) when the
/// kernel refuses; the thread then keeps its priority, which is safe.
bool SetCurrentThreadNice(int nice, std::string* why = nullptr);

/// Lowers the calling thread to kBackgroundNice (never raises a thread already lower), ignoring a refusal.
void MakeCurrentThreadBackground();

}  // namespace cairn::core
