// The mode tree file (config/mode_tree.xml) holds several behavior trees: the mode tree (ModeManager) and the
// waypoint recovery tree (WaypointRecovery). A factory that loads one of them must know every node type the
// file uses, so that the whole document validates (a typo in the other tree is still caught at load); the
// other trees' node types are registered without their context (building one throws). This is the one place
// that knows which trees share the file, so that neither tree's code depends on the other's.
#pragma once

#include "cairn/bt/behavior_tree.h"

namespace cairn::agent {

/// The tree a factory is being set up for.
enum class TreeInFile { kModeTree, kWaypointRecovery };

/// Registers in `factory`, context-free, the node types of every tree of the mode tree file other than
/// `loading`'s (whose own nodes, with their context, its code registers).
void RegisterOtherTreeNodeTypes(bt::TreeFactory& factory, TreeInFile loading);

}  // namespace cairn::agent
