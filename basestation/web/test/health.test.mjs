// The Health tab's warning rules (src/health.ts, as the build emits it): late control loops and rates below
// target are warnings; a loop on time, a rate at target and a component that is down (styled as down) are not.
import assert from "node:assert/strict";
import { join } from "node:path";
import { test } from "node:test";
import { pathToFileURL } from "node:url";

import { BUILD } from "./harness.mjs";

const { controlLate, rateLow } = await import(pathToFileURL(join(BUILD, "web", "health.mjs")).href);

const component = (over = {}) =>
  ({ name: "navigation", state: "active", degraded: false, loop_rate_hz: 20, target_rate_hz: 20, ...over });

test("a control loop is late only past 1.5 times the navigation component's period", () => {
  const robot = (period_ms, components = [component()]) => ({ control_period_max_ms: period_ms, components });
  assert.equal(controlLate(robot(50)), false);  // 20 Hz: 50 ms is on time
  assert.equal(controlLate(robot(75)), false);  // exactly 1.5 periods
  assert.equal(controlLate(robot(76)), true);
  assert.equal(controlLate(robot(500, [])), false, "no navigation component: no target to be late against");
  assert.equal(controlLate(robot(500, [component({ target_rate_hz: 0 })])), false, "no target rate");
  assert.equal(controlLate({ control_period_max_ms: 500 }), false, "no components reported yet");
});

test("a rate is low below 90 % of its target, or when the component says it is degraded", () => {
  assert.equal(rateLow(component()), false);
  assert.equal(rateLow(component({ loop_rate_hz: 18 })), false);  // 90 %
  assert.equal(rateLow(component({ loop_rate_hz: 17.9 })), true);
  assert.equal(rateLow(component({ degraded: true })), true);
  assert.equal(rateLow(component({ loop_rate_hz: 3, target_rate_hz: 0 })), false, "no target rate");
  assert.equal(rateLow(component({ state: "down", loop_rate_hz: 0 })), false, "down is its own style, not slow");
});
