// The Health tab's warning rules, apart from the DOM so that the tests can check them (test/health.test.mjs).
import type { Component, Robot } from "./wire";

// A control loop whose worst period lately is over 1.5 times its own (the navigation component's target rate)
// is late: shown in the warning colour.
export function controlLate(r: Pick<Robot, "components" | "control_period_max_ms">): boolean {
  const nav = (r.components ?? []).find((c) => c.name === "navigation");
  return !!nav && nav.target_rate_hz > 0 && r.control_period_max_ms > 1.5 * (1000 / nav.target_rate_hz);
}

// A running component below 90 % of its target rate, or one that says it is degraded, is shown in the warning
// colour (slow, not down: a component that is down has its own, stronger, style).
export function rateLow(c: Pick<Component, "state" | "degraded" | "loop_rate_hz" | "target_rate_hz">): boolean {
  return c.state === "active" && (c.degraded || (c.target_rate_hz > 0 && c.loop_rate_hz < 0.9 * c.target_rate_hz));
}
