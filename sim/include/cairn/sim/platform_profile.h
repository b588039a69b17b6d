// Copyright Cairn authors.
//
// A navigation platform profile's dimensions for the simulated platform. Header-only: the simulator takes
// numbers from the profile (limits, footprint, step and body height) and never links navigation, whose
// classifier it must not share (see BodyTerrain).
#pragma once

#include "cairn/nav/platform.h"
#include "cairn/sim/simulated_platform.h"

namespace cairn::sim {

/// Sets `options`' base limits, footprint radius and body (largest step, height needed) from `profile`.
inline void ApplyPlatformProfile(const nav::PlatformProfile& profile, SimulatedPlatformOptions* options) {
  options->limits = profile.limits;
  options->footprint_radius_m = profile.footprint_radius_m;
  options->body.max_step_m = profile.traversability.max_step_m;
  options->body.body_height_m = profile.traversability.robot_height_m;
}

}  // namespace cairn::sim
