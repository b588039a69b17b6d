#include "cairn/agent/modes/tree_file.h"

#include "cairn/agent/modes/mode_manager.h"
#include "cairn/agent/modes/waypoint_recovery.h"

namespace cairn::agent {

void RegisterOtherTreeNodeTypes(bt::TreeFactory& factory, TreeInFile loading) {
  if (loading != TreeInFile::kModeTree) ModeManager::RegisterModeNodes(factory);
  if (loading != TreeInFile::kWaypointRecovery) WaypointRecovery::RegisterNodes(factory, nullptr);
}

}  // namespace cairn::agent
