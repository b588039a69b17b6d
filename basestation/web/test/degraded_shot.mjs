// Screenshot of the Health tab with slow robots: four robots exploring builtin:tunnels on this 2-core machine
// run degraded (perception under half its rate), which the tab shows in the warning colour. Run inside a
// private network namespace: tests/netns_run.sh node basestation/web/test/degraded_shot.mjs
import { execFileSync } from "node:child_process";
import { writeFileSync } from "node:fs";
import { join } from "node:path";
import { BUILD, launchBrowser, openGui, screenshot, sleep, startBase, startRobot, stopAll, LOGS } from "./harness.mjs";

const domain = 58;
try {
  const ids = ["r1", "r2", "r3", "r4"];
  await Promise.all(ids.map((id, k) => startRobot(id, { domain, start: `slot:${k}` })));
  const { url } = await startBase("op1", { domain });
  const browser = await launchBrowser();
  const page = await openGui(browser, url, { width: 1400, height: 900 });
  // Another operator sends them exploring (a script), then the monitors judge them slow.
  const script = join(LOGS, "explore.cairn");
  writeFileSync(script, ids.map((id) => `wait ${id} online 30\n`).join("") + `request-control ${ids.join(" ")}\n` +
    ids.map((id) => `explore ${id}\n`).join(""));
  execFileSync(join(BUILD, "basestation", "cairn_base"), ["--base-id", "op2", "--domain", String(domain), "--script", script],
    { stdio: "inherit" });
  await page.click('button[data-tab="health"]');
  await sleep(25000);
  console.log(`degraded_shot: ${await screenshot(page, "health_degraded")} (logs in ${LOGS})`);
  await browser.close();
} finally {
  stopAll();
}
