// Copyright Cairn authors.
//
// Private: the built-in world "plant" (an industrial building of survey-scan size), kept in its own file
// because its layout is large. Listed and built through builtin_worlds.cpp; the layout is described in
// builtin_worlds.h.
#pragma once

#include <cstdint>

#include "cairn/sim/builtin_worlds.h"
#include "cairn/sim/world.h"

namespace cairn::sim::internal {

/// Builds "builtin:plant" (layout in builtin_worlds.h). `seed` varies only the rack gaps, the machines and
/// the pallet stacks; the shell, the offices, the mezzanine, its staircase, the starts and the places do not
/// move. Deterministic on every platform (a SplitMix64 stream, no std distributions).
World MakePlant(std::uint32_t seed);

/// Description, starts, far goal and staircase of "plant", valid for every seed.
BuiltinWorldInfo PlantInfo();

}  // namespace cairn::sim::internal
