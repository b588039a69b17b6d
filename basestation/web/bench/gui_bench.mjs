// Operator GUI bench (docs/PERFORMANCE.md), real processes inside a private network namespace:
//   1. robot state -> WebSocket frame latency: each robot stamps its state (wall clock); a Foxglove client
//      subscribed as the Cairn GUI is takes the first /fleet frame that carries that state. Baseline in the
//      same run: the DDS hop alone (the state's stamp -> cairn_base received it, from /fleet's received_stamp).
//   2. bytes per second per GUI client with 3 robots driving through builtin:tunnels (maps growing, cameras,
//      paths), per channel; baseline in the same run: a client subscribed to /fleet only (the fleet list).
//   3. frame rate of the 3D view with 300k voxels in headless Chromium (software GL here: SwiftShader), the
//      map's faces merged with two levels of detail; baselines in the same run and browser: the same map drawn
//      box by box (one instanced box per voxel, as before), and the page with no voxels.
// Usage (./cairn bench runs it): tests/netns_run.sh node basestation/web/bench/gui_bench.mjs [SECONDS] [--3d-only]
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

import { launchBrowser, screenshot, sleep, startBase, startRobot, stopAll, waitFor } from "../test/harness.mjs";

const { FoxgloveClient } = wsProtocol;
const DOMAIN = 76;
const only3d = process.argv.includes("--3d-only");
const SECONDS = Number(process.argv.slice(2).find((a) => !a.startsWith("--")) ?? 30);
const decoder = new TextDecoder();

function quantile(values, q) {
  const v = [...values].sort((a, b) => a - b);
  return v.length ? v[Math.min(v.length - 1, Math.floor(q * v.length))] : NaN;
}
const ns = (t) => Number(t.sec) * 1e3 + Number(t.nsec) / 1e6; // milliseconds

/** A Foxglove client subscribed to the topics `wanted` picks; counts bytes per topic. */
function connect(url, wanted, onMessage = () => {}) {
  const client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  const topics = new Map();
  const stats = { bytes: new Map(), since: 0, counting: false, client, services: new Map() };
  client.on("advertise", (list) => {
    for (const c of list) {
      if (!wanted(c.topic)) continue;
      topics.set(client.subscribe(c.id), c.topic);
    }
  });
  client.on("advertiseServices", (list) => list.forEach((s) => stats.services.set(s.name, s)));
  client.on("message", ({ subscriptionId, data }) => {
    const topic = topics.get(subscriptionId);
    const receivedMs = Date.now();
    if (stats.counting) stats.bytes.set(topic, (stats.bytes.get(topic) ?? 0) + data.byteLength + 13); // + frame header
    onMessage(topic, data, receivedMs);
  });
  return stats;
}

let callId = 1;
function command(stats, line) {
  const id = callId++;
  return new Promise((resolve) => {
    const onResponse = (r) => {
      if (r.callId !== id) return;
      stats.client.off("serviceCallResponse", onResponse);
      resolve(JSON.parse(decoder.decode(r.data)));
    };
    stats.client.on("serviceCallResponse", onResponse);
    stats.client.sendServiceCallRequest({ serviceId: stats.services.get("/cairn/command").id, callId: id, encoding: "json",
      data: new TextEncoder().encode(JSON.stringify({ command: line })) });
  });
}

// ---- 1 and 2: three robots, one basestation, two clients ----------------------------------------------------
if (!only3d) await fleetFigures();
async function fleetFigures() {
await Promise.all(["r1", "r2", "r3"].map((id, i) => startRobot(id, { start: `slot:${i}`, domain: DOMAIN })));
const base = await startBase("op1", { domain: DOMAIN });
const wsUrl = base.url.replace(/^http/, "ws");
const seen = new Set();
const guiLatency = [], ddsLatency = [];
let measuring = false;
const gui = connect(wsUrl, (t) => t.startsWith("/") && t !== "/tf" && t !== "/robots", (topic, data, receivedMs) => {
  if (topic !== "/fleet" || !measuring) return;
  for (const r of JSON.parse(decoder.decode(data)).robots) {
    if (!r.state_stamp) continue;
    const key = `${r.id}/${r.state_stamp.sec}.${r.state_stamp.nsec}`;
    if (seen.has(key)) continue;
    seen.add(key);
    guiLatency.push(receivedMs - ns(r.state_stamp));
    ddsLatency.push(ns(r.received_stamp) - ns(r.state_stamp));
  }
});
const listOnly = connect(wsUrl, (t) => t === "/fleet");
await waitFor("the command service", () => gui.services.has("/cairn/command"), 10000);
await sleep(3000); // the robots' first maps and snapshots
// Each robot drives: r1 along the west tunnel, r2 and r3 into the crossing tunnels (goals on their own maps).
const goals = { r1: "14 20", r2: "26 20", r3: "38 20" };
for (const [id, goal] of Object.entries(goals)) {
  const held = await command(gui, `request-control ${id}`);
  const sent = await command(gui, `goto ${id} ${goal}`);
  if (!held.ok || !sent.ok) console.log(`note: ${id}: ${held.reason ?? ""} ${sent.reason ?? ""}`);
}
gui.counting = listOnly.counting = true;
measuring = true;
const t0 = Date.now();
await sleep(SECONDS * 1000);
const elapsedS = (Date.now() - t0) / 1000;
measuring = gui.counting = listOnly.counting = false;
const status = await command(gui, "robots");

const total = (m) => [...m.values()].reduce((a, b) => a + b, 0);
const guiBps = total(gui.bytes) / elapsedS, listBps = total(listOnly.bytes) / elapsedS;
console.log(`GUI bench: 3 robots in builtin:tunnels driving to goals, ${elapsedS.toFixed(1)} s`);
console.log(`state -> WebSocket frame latency over ${guiLatency.length} states: median ${quantile(guiLatency, 0.5).toFixed(1)} ms, ` +
  `p99 ${quantile(guiLatency, 0.99).toFixed(1)} ms; DDS hop alone (baseline): median ${quantile(ddsLatency, 0.5).toFixed(1)} ms, ` +
  `p99 ${quantile(ddsLatency, 0.99).toFixed(1)} ms; ratio of medians ${(quantile(guiLatency, 0.5) / quantile(ddsLatency, 0.5)).toFixed(1)}`);
console.log(`bytes per second per GUI client: ${(guiBps / 1e3).toFixed(1)} kB/s (${(guiBps * 8 / 1e6).toFixed(2)} Mbit/s); ` +
  `fleet list only (baseline): ${(listBps / 1e3).toFixed(1)} kB/s; ratio ${(guiBps / listBps).toFixed(1)}`);
for (const [topic, bytes] of [...gui.bytes.entries()].sort((a, b) => b[1] - a[1])) {
  console.log(`  ${topic.padEnd(14)} ${(bytes / elapsedS / 1e3).toFixed(1).padStart(8)} kB/s`);
}
if (!status.ok) console.log(`note: robots: ${status.reason}`);
gui.client.close();
listOnly.client.close();
stopAll();
}

// ---- 3: the 3D view's frame rate, 300k voxels against none, in one browser ----------------------------------
const browser = await launchBrowser();
// The page is served by a GUI server with no fleet (a basestation on an empty domain).
const empty = await startBase("bench", { domain: DOMAIN + 1 });
const results = {};
const views = [
  { name: "none", voxels: 0, wholeMap: false },
  { name: "orbit", voxels: 300000, wholeMap: false }, // the default orbit view over a robot (part of the map)
  { name: "whole", voxels: 300000, wholeMap: true }, // the whole 100 x 100 m map in view, from above
  { name: "orbit_boxes", voxels: 300000, wholeMap: false, boxes: true },
  { name: "whole_boxes", voxels: 300000, wholeMap: true, boxes: true },
];
for (const view of views) {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 } });
  await page.goto(`${empty.url}?bench_voxels=${view.voxels}${view.boxes ? "&bench_boxes=1" : ""}`);
  await waitFor("the voxels", () => page.evaluate((n) => window.cairn.scene.voxelCount >= n, view.voxels), 60000);
  if (view.wholeMap) {
    await page.evaluate(() => {
      const s = window.cairn.scene;
      s.controls.target.set(50, 50, 0);
      s.camera.position.set(50, 49.9, 120);
      s.invalidate();
    });
  }
  await sleep(3000);
  const frames0 = await page.evaluate(() => window.cairn.scene.framesDrawn);
  const start = Date.now();
  await sleep(10000);
  const frames1 = await page.evaluate(() => window.cairn.scene.framesDrawn);
  results[view.name] = (frames1 - frames0) / ((Date.now() - start) / 1000);
  results[`${view.name}_quads`] = await page.evaluate(() => window.cairn.scene.mapQuads);
  results[`${view.name}_drawn`] = await page.evaluate(() => {
    const r = window.cairn.scene.renderer.info.render;
    return `${r.calls} draw calls, ${r.triangles} triangles`;
  });
  results.gl = await page.evaluate(() => (window.cairn.scene.softwareGl ? "software GL (SwiftShader)" : "GPU"));
  await page.evaluate(() => { window.cairn.scene.continuous = false; });
  await sleep(2000);
  await screenshot(page, `bench_3d_${view.name}`).catch((e) => console.log(`note: no screenshot of ${view.name}: ${e.message.split("\n")[0]}`));
  await page.close();
}
console.log(`3D view, headless Chromium, ${results.gl}, 1280x800, no voxels ${results.none.toFixed(1)} fps; 300k voxels ` +
  `(merged faces: ${results.orbit_quads} rectangles; box by box: ${results.orbit_boxes_quads}):`);
for (const [name, what] of [["orbit", "orbit view over a robot"], ["whole", "whole map from above"]]) {
  console.log(`  ${what}: merged faces + LOD ${results[name].toFixed(1)} fps, box by box (baseline) ` +
    `${results[`${name}_boxes`].toFixed(2)} fps, ratio ${(results[name] / results[`${name}_boxes`]).toFixed(1)}; ` +
    `${(results[name] / results.none).toFixed(2)} of the empty view; a frame: ${results[`${name}_drawn`]} ` +
    `(box by box ${results[`${name}_boxes_drawn`]})`);
}
await browser.close();
stopAll();
process.exit(0);
