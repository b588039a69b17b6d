// Real processes for the GUI tests and bench: cairn_agent robots, cairn_base --gui basestations, and headless
// Chromium driven by playwright-core (Debian's /usr/bin/chromium). Run inside a private network namespace
// (tests/netns_run.sh): every DDS participant and the GUI's TCP port stay on loopback there.
import { spawn } from "node:child_process";
import { createWriteStream, mkdirSync, readFileSync } from "node:fs";
import { basename, join } from "node:path";
import { pathToFileURL } from "node:url";
import { chromium } from "playwright-core";

export const BUILD = process.env.CAIRN_BUILD_DIR ?? new URL("../../../build", import.meta.url).pathname;
// One folder per test or bench file (gui, foxglove, gui_bench...): each keeps its own process logs.
export const LOGS = join(BUILD, "test-logs", "gui", basename(process.argv[1] ?? "gui", ".mjs").replace(/\.test$/, ""));
mkdirSync(LOGS, { recursive: true });

/** The GUI's wire module (src/wire.ts: channels, message types, the commands it sends), as the build emits it
 *  for tests (web/wire.mjs): the tests send what the GUI sends. */
export function loadWire() {
  return import(pathToFileURL(join(BUILD, "web", "wire.mjs")).href);
}

const children = [];
export const sleep = (ms) => new Promise((r) => setTimeout(r, ms));

/** Waits until `predicate()` (sync or async) is truthy; returns its value or throws naming `what`. */
export async function waitFor(what, predicate, timeoutMs = 15000, periodMs = 100) {
  const deadline = Date.now() + timeoutMs;
  let last;
  while (Date.now() < deadline) {
    last = await predicate();
    if (last) return last;
    await sleep(periodMs);
  }
  throw new Error(`timed out after ${timeoutMs / 1000} s waiting for ${what}`);
}

function startProcess(name, args) {
  const log = createWriteStream(join(LOGS, `${name}.log`));
  const child = spawn(args[0], args.slice(1), { stdio: ["ignore", "pipe", "pipe"] });
  let out = "";
  child.stdout.on("data", (d) => {
    out += d.toString();
    log.write(d);
  });
  child.stderr.on("data", (d) => log.write(d));
  child.output = () => out;
  children.push(child);
  return child;
}

/** A simulated robot; resolves once it printed READY. */
export async function startRobot(id, { world = "builtin:tunnels", start = "slot:0", domain, platform = "wheeled" }) {
  const child = startProcess(id, [join(BUILD, "robot_agent/cairn_agent"), "--robot-id", id, "--world", world, "--start",
    start, "--platform", platform, "--domain", String(domain)]);
  await waitFor(`${id} READY`, () => child.output().includes("READY"), 90000);
  return child;
}

/** A basestation with its GUI on a free loopback port; resolves with its URL. */
export async function startBase(baseId, { domain, port = 0, places = "" }) {
  const child = startProcess(baseId, [join(BUILD, "basestation/cairn_base"), "--base-id", baseId, "--domain", String(domain),
    "--gui", "--listen", `127.0.0.1:${port}`, ...(places ? ["--places", places] : [])]);
  const line = await waitFor(`${baseId} GUI line`, () => child.output().match(/^GUI (http:\/\/\S+)/m), 20000);
  return { child, url: line[1] };
}

// No GPU here: WebGL and the compositor both run on SwiftShader in Chromium's GPU process (ANGLE). With
// --disable-gpu the compositor is software instead and reads every WebGL frame back on the page's main thread
// (GLES2::ReadPixels in the commit, ~300 ms a frame on this machine while the robots run): the page's 10 Hz
// teleop stream then had 0.6 s gaps, past the robot's teleop staleness. A real GPU has neither cost.
export async function launchBrowser() {
  return chromium.launch({
    executablePath: process.env.CAIRN_CHROMIUM ?? "/usr/bin/chromium",
    args: ["--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist", "--no-sandbox",
      "--no-first-run", "--disable-quic", "--disable-background-networking", "--disable-component-update",
      "--disable-sync", "--disable-dev-shm-usage"],
  });
}

/** A page of the GUI at `url`, its console errors collected in page.errors. */
export async function openGui(browser, url, { width = 1280, height = 800 } = {}) {
  const page = await browser.newPage({ viewport: { width, height } });
  page.errors = [];
  page.on("pageerror", (e) => page.errors.push(e.message));
  page.on("console", (m) => {
    if (m.type() === "error") page.errors.push(m.text());
  });
  await page.goto(url);
  return page;
}

/** The robot `id` as the page last received it on /fleet. */
export function robotState(page, id) {
  return page.evaluate((rid) => window.cairn.state.robots.find((r) => r.id === rid) ?? null, id);
}

export async function screenshot(page, name) {
  const path = join(LOGS, `${name}.png`);
  await page.screenshot({ path });
  return path;
}

export function stopAll() {
  for (const c of children.splice(0)) {
    if (c.exitCode === null) c.kill("SIGTERM");
  }
}
process.on("exit", stopAll);

export function tail(name, lines = 30) {
  try {
    return readFileSync(join(LOGS, `${name}.log`), "utf8").split("\n").slice(-lines).join("\n");
  } catch {
    return "";
  }
}
