// Cairn's operator GUI: the fleet at a glance in 3D, per robot only the actions valid now (from the state the
// robot publishes and this basestation's lock), notifications, a camera pane, touch, mouse, keyboard and a
// gamepad. Everything goes through cairn_base (the same FleetClient as its CLI) over the Foxglove WebSocket
// protocol; nothing here bypasses the control lock.
import { CairnLink, type CommandResult } from "./client";
import { FleetScene, modeColor } from "./scene";

// One component of a robot's agent (cairn_base health R).
interface Component {
  name: string;
  state: string;
  loop_rate_hz: number;
  target_rate_hz: number;
  cpu_percent: number;
  restarts: number;
  restart_in_s: number;
  last_error: string;
  degraded: boolean;  // beating, but under half its rate for a few seconds: slow, not hung
}

interface Robot {
  id: string;
  platform: string;
  online: boolean;
  lost_reason: string;
  heard_s_ago: number;
  link?: {
    class: string;
    budget_kbps: number;
    rtt_ms: number;
    rtt_max_ms: number;
    probe_wait_s: number;
    loss_pct: number;
    state_lost: number;
    state_received: number;
    sent_kbps: number;
    over_budget: boolean;
    usage: { topic_class: string; sent_kbps: number }[];
  };
  components?: Component[];
  mode: string;
  holder: string;
  holder_alive: boolean;
  you_hold: boolean;
  nav_status: string;
  nav_reason: string;
  goal?: { x_m: number; y_m: number; z_m: number };
  distance_left_m: number;
  eta_s: number;
  local_planner_status: string;
  pose?: { x_m: number; y_m: number; z_m: number; yaw_rad: number };
  speed_mps: number;
  in_contact: boolean;
  valid_actions: string[];
  max_speed_mps: number;
  max_reverse_speed_mps: number;
  max_yaw_rate_radps: number;
  camera_age_s: number;
  control_period_max_ms: number;
  exploration?: Exploration;
  convoy?: Convoy;
  yield?: YieldRecord;
}

// Get-out-of-the-way (cairn_base's `status --json` yield block): as the robot asked (moving_aside, aside,
// returning, refused) or as the robot asking (asking, blocked); `for`: the robot whose route passes it now.
interface YieldRecord {
  state: string;
  peer: string;
  reason: string;
  for: string;
}

// A convoy follower's record (cairn_base's `status --json` convoy block): the robots ahead of it, nearest
// first, the leader last (empty: not following).
interface Convoy {
  state: string;  // none | following | holding | lost | blocked
  ahead: string[];
  reason: string;
  gap_m?: number;
}

// The robot's exploration record (cairn_base's `status --json` exploration block).
interface Exploration {
  state: string; // none | exploring | complete | failed | stopped
  reason: string;
  task_id: number;
  explored_m2: number;
  frontiers: number;
  reachable_frontiers: number;
  targets_reached: number;
  targets_failed: number;
  peers: number;
  peer_seen_m2: number;
  target?: { x_m: number; y_m: number; z_m: number };
}

interface EventEntry {
  time: Date;
  level: number;
  kind: string;
  message: string;
}

const $ = <T extends HTMLElement>(id: string) => document.getElementById(id) as T;
const params = new URLSearchParams(location.search);

const state = {
  baseId: '',
  robots: [] as Robot[],
  selected: location.hash.startsWith('#robot=') ? decodeURIComponent(location.hash.slice(7)) : '',
  tab: 'fleet',
  events: [] as EventEntry[],
  toasts: [] as {
    text: string;
    shownMs: number;
    eventMs: number
  }[],
  lastResult: undefined as CommandResult | undefined,
  pickingGoal: false,
  goalVerb: 'goto' as 'goto' | 'peel',  // what a picked goal is sent as
  pendingGoal: undefined as {
    x: number;
    y: number;
    z?: number
  } | undefined,
  convoyOrder: undefined as string[] | undefined,  // a convoy being put together: the leader, then followers
  convoyNote: '',
  driving: false,
  drive: {vx: 0, wz: 0, active: false, source: '', stale: false, sent: 0},
  cameraUrls: new Map<
      string,
      {
        url: string;
        stamp: number
      }>(),
  statusText: 'connecting',
  ceilingAuto: true,  // hide map voxels 1.6 m above the highest robot (tunnel roofs, upper floors)
};

const scene = new FleetScene($("view"));
const link = new CairnLink(
  `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/`,
  (topic) => topic.startsWith("/") && topic !== "/tf" && topic !== "/robots",
  onMessage,
);
link.onState = (connected, text) => {
  state.statusText = text;
  $("conn").textContent = connected ? `● ${text}` : `○ ${text}`;
  $("conn").className = connected ? "ok" : "bad";
};

// ---- Messages from cairn_base -------------------------------------------------------------------------
function onMessage(topic: string, msg: any): void {
  if (topic === "/fleet") {
    state.baseId = msg.base_id;
    state.robots = msg.robots as Robot[];
    if (!state.selected && state.robots.length > 0 && params.get("select") !== "none") state.selected = state.robots[0].id;
    scene.selected = state.selected;
    const zs = state.robots.filter((r) => r.pose).map((r) => r.pose!.z_m);
    if (state.ceilingAuto && zs.length > 0) scene.setCeilingCut(Math.max(...zs) + 1.6);
    scene.setRobots(
      state.robots
        .filter((r) => r.pose)
        .map((r) => ({ id: r.id, x: r.pose!.x_m, y: r.pose!.y_m, z: r.pose!.z_m, yaw: r.pose!.yaw_rad, mode: r.mode, holder: r.holder, online: r.online })),
    );
    render();
  } else if (topic === "/fleet_map" || topic === "/paths" || topic === "/staircases") {
    scene.applySceneUpdate(msg);
  } else if (topic === "/events") {
    // A new subscriber is sent the last events first (some of them it may also get live): each is kept once,
    // and only a fresh one is a toast.
    const timeMs = Number(msg.timestamp.sec) * 1000 + Number(msg.timestamp.nsec) / 1e6;
    const key = `${msg.timestamp.sec}.${msg.timestamp.nsec}|${msg.name}|${msg.message}`;
    if (seenEvents.has(key)) return;
    seenEvents.add(key);
    const entry: EventEntry = { time: new Date(timeMs), level: msg.level, kind: msg.name, message: msg.message };
    state.events.unshift(entry);
    state.events.sort((a, b) => b.time.getTime() - a.time.getTime());
    state.events.length = Math.min(state.events.length, 300);
    if (Date.now() - timeMs < kToastMaxAgeMs) toast(msg.message, msg.level >= 3 ? "warn" : "info", timeMs);
    if (state.tab === "events") renderEvents();
  } else if (topic.endsWith("/camera")) {
    const robot = topic.split("/")[1];
    const old = state.cameraUrls.get(robot);
    if (old) URL.revokeObjectURL(old.url);
    const bytes = Uint8Array.from(atob(msg.data), (c) => c.charCodeAt(0));
    const url = URL.createObjectURL(new Blob([bytes], { type: `image/${msg.format}` }));
    state.cameraUrls.set(robot, { url, stamp: Date.now() });
    if (robot === state.selected) ($("camera") as HTMLImageElement).src = url;
  }
}

// ---- Notifications ------------------------------------------------------------------------------------
const kToastMaxAgeMs = 10000; // an event older than this when it arrives goes to the Events tab only
const seenEvents = new Set<string>();

/** A notification for 5 s; `eventMs` is when it happened (state.toasts keeps both times for tests). */
function toast(text: string, kind: "info" | "warn" | "ok" | "bad" = "info", eventMs = Date.now()): void {
  state.toasts.push({ text, shownMs: Date.now(), eventMs });
  if (state.toasts.length > 500) state.toasts.shift();
  const el = document.createElement("div");
  el.className = `toast ${kind}`;
  el.textContent = text;
  $("toasts").prepend(el);
  window.setTimeout(() => el.classList.add("gone"), 5000);
  window.setTimeout(() => el.remove(), 5600);
  while ($("toasts").children.length > 5) $("toasts").lastElementChild?.remove();
}

// ---- Commands (the CLI's lines, its semantics and reasons) ---------------------------------------------
async function run(line: string, quiet = false): Promise<CommandResult> {
  const result = await link.command(line);
  state.lastResult = result;
  if (!quiet || !result.ok) {
    const words = result.ok ? `${line}: ${result.result ?? "accepted"}` : `${line}: ${result.result ?? "failed"} — ${result.reason ?? ""}`;
    toast(words, result.ok ? "ok" : "bad");
  }
  render();
  return result;
}

function selectedRobot(): Robot | undefined {
  return state.robots.find((r) => r.id === state.selected);
}

function select(id: string): void {
  if (state.convoyOrder) return addToConvoy(id);
  state.selected = id;
  scene.selected = id;
  history.replaceState(null, "", `#robot=${encodeURIComponent(id)}`);
  const r = selectedRobot();
  const cam = state.cameraUrls.get(id);
  ($("camera") as HTMLImageElement).src = cam ? cam.url : "";
  if (r?.pose) scene.focus(r.pose.x_m, r.pose.y_m, r.pose.z_m);
  setTab("robot");
}

// ---- Rendering of the side panel ------------------------------------------------------------------------
function setTab(tab: string): void {
  state.tab = tab;
  for (const b of document.querySelectorAll<HTMLButtonElement>("#tabs button")) b.classList.toggle("active", b.dataset.tab === tab);
  for (const p of document.querySelectorAll<HTMLElement>(".tab")) p.hidden = p.id !== `tab-${tab}`;
  render();
  if (tab === "events") renderEvents();
}

function fmt(v: number | undefined, digits = 1, unit = ""): string {
  return v === undefined || v < 0 || !isFinite(v) ? "–" : `${v.toFixed(digits)}${unit}`;
}

// Sets an element's HTML only when it changed, so that elements under a finger (or a test's click) are not
// replaced by the 10 Hz /fleet updates.
const shownHtml = new WeakMap<HTMLElement, string>();
function setHtml(el: HTMLElement, html: string): void {
  if (shownHtml.get(el) === html) return;
  shownHtml.set(el, html);
  el.innerHTML = html;
}

function render(): void {
  $("base").textContent = state.baseId ? `basestation ${state.baseId}` : "";
  renderFleet();
  renderRobot();
  renderHealth();
}

function renderFleet(): void {
  // One row per robot, kept across updates (only its cells change).
  const body = $("fleet-rows");
  const ids = state.robots.map((r) => r.id);
  for (const row of Array.from(body.children) as HTMLElement[]) {
    if (!ids.includes(row.dataset.robot ?? "")) row.remove();
  }
  let previous: Element | null = null;
  for (const r of state.robots) {
    let row = body.querySelector<HTMLElement>(`tr[data-robot="${CSS.escape(r.id)}"]`);
    if (!row) {
      row = document.createElement("tr");
      row.dataset.robot = r.id;
    }
    if (row.previousElementSibling !== previous || row.parentElement !== body) {
      if (previous) previous.after(row);
      else body.prepend(row);
    }
    previous = row;
    row.className = `row ${r.id === state.selected ? "sel" : ""}`;
    const holder = r.holder ? (r.you_hold ? `${r.holder} (you)` : r.holder) : "free";
    setHtml(
        row,
        `<td><span class="dot ${r.online ? 'on' : 'off'}"></span>${r.id}</td>
      <td><span class="chip" style="background:${modeColor(r.mode)}">${r.mode || '?'}</span>${
            r.convoy?.ahead.length ? ` <span class="small">→ ${r.convoy.ahead[0]}</span>` : ''}</td>
      <td>${holder}</td><td>${r.online ? fmt(r.heard_s_ago, 1, ' s') : 'lost'}</td>`);
  }
  $("fleet-empty").hidden = state.robots.length > 0;
}

// The buttons of the robot's valid actions (ValidActions of cairn_base for this basestation).
function actionButtons(r: Robot): string {
  const b: string[] = [];
  for (const action of r.valid_actions) {
    if (action === "request-control") b.push(`<button class="act" data-cmd="request-control ${r.id}">Request control</button>`);
    else if (action === "release") b.push(`<button class="act" data-cmd="release ${r.id}">Release control</button>`);
    else if (action.startsWith("mode ")) {
      for (const mode of action.slice(5).split("|")) {
        if (mode === r.mode) continue;
        b.push(`<button class="act mode" data-cmd="mode ${r.id} ${mode}" style="border-color:${modeColor(mode)}">Mode ${mode.replace("_", " ")}</button>`);
      }
    } else if (action === "goto") b.push(`<button class="act" data-goto="1">${state.pickingGoal ? "Tap the map… (Esc)" : "Go to… (tap the map)"}</button>`);
    else if (action === "teleop") b.push(`<button class="act" data-drive="1">${state.driving ? "Stop driving" : "Drive (keys / gamepad)"}</button>`);
    else if (action === "explore") b.push(`<button class="act" data-cmd="explore ${r.id}">Explore</button>`);
    else if (action === "home") b.push(`<button class="act" data-cmd="home ${r.id}">Return home</button>`);
    else if (action === 'convoy' && !state.convoyOrder)
      b.push(`<button class="act" data-convoy="${r.id}">Lead a convoy…</button>`);
    else if (action === 'peel')
      b.push(`<button class="act" data-peel="1">${
          state.pickingGoal && state.goalVerb === 'peel' ? 'Tap the map… (Esc)' :
                                                           'Peel off… (tap the map)'}</button>`);
    else if (action === 'yield' && r.yield?.for)
      b.push(`<button class="act" data-cmd="yield ${r.id} for ${r.yield.for}">Get out of ${
          r.yield.for}'s way</button>`);
    else if (action === 'convoy-stop' && r.convoy?.ahead.length)
      b.push(`<button class="act" data-cmd="convoy-stop ${
          r.convoy.ahead[r.convoy.ahead.length - 1]}">Stop the convoy</button>`);
  }
  return b.join("");
}

function renderRobot(): void {
  const r = selectedRobot();
  if (!r) {
    setHtml($("robot-head"), `<p>Tap a robot in the 3D view or the fleet list.</p>`);
    setHtml($("actions"), "");
    setHtml($("robot-nav"), "");
    return;
  }
  const holder = r.holder ? `held by <b>${r.holder}</b>${r.you_hold ? " (you)" : ""}${r.holder_alive ? "" : " (not heard)"}` : "free";
  setHtml($("robot-head"), `<h2>${r.id} <span class="chip" style="background:${modeColor(r.mode)}">${r.mode || "?"}</span></h2>
    <p>${r.platform} · ${holder} · ${r.online ? "online" : `<b class="bad">lost</b> ${r.lost_reason}`}</p>`);
  // In explore mode the robot drives to its frontiers itself: its last waypoint goal's status is stale.
  const nav = r.mode === 'explore' ? 'following the exploration\'s targets' :
      r.mode === 'yield'           ? `getting out of ${r.yield?.peer || 'a robot'          }'s way` :
                r.nav_status === 'active' ? `to (${fmt(r.goal?.x_m, 2)}, ${fmt(r.goal?.y_m, 2)}) · ${
                                      fmt(r.distance_left_m, 1, ' m')} left · ETA ${fmt(r.eta_s, 0, ' s')}` :
                                            r.nav_status;
  setHtml(
      $('robot-nav'),
      `<p>navigation: <b>${nav}</b>${
          r.nav_reason ? `<br><span class="reason">${r.nav_reason}</span>` : ''}</p>
    <p class="small">local planner: ${r.local_planner_status || '–'} · speed ${
          fmt(Math.abs(r.speed_mps), 2, ' m/s')}</p>
    ${explorationHtml(r.exploration)}${convoyHtml(r.convoy)}${yieldHtml(r.yield)}`);
  setHtml($("actions"), actionButtons(r) + `<button class="act stop" data-cmd="stop ${r.id}">STOP</button>`);
  $("actions").dataset.robot = r.id;
  const cam = state.cameraUrls.get(r.id);
  $("camera-age").textContent = cam ? `camera: ${((Date.now() - cam.stamp) / 1000).toFixed(1)} s old` : "camera: no frame yet";
  const d = state.drive;
  $("drive-state").textContent = !state.driving ? ""
    : d.active ? `driving ${r.id}: ${d.source} v ${d.vx.toFixed(2)} m/s, w ${d.wz.toFixed(2)} rad/s`
    : d.stale ? `driving ${r.id}: gamepad stick silent for over 0.5 s: zero sent (move it to drive again)`
    : `driving ${r.id}: ${d.source || "no input"}: zero sent`;
}

// The exploration block of the robot tab: state, explored area, frontiers, target, team (nothing before the
// robot's first exploration).
function explorationHtml(e: Exploration | undefined): string {
  if (!e || !e.state || e.state === "none") return "";
  const target = e.target ? ` · target (${fmt(e.target.x_m, 1)}, ${fmt(e.target.y_m, 1)}, z ${fmt(e.target.z_m, 1)})` : "";
  const team = e.peers > 0 ? ` · ${e.peers} peer${e.peers > 1 ? "s" : ""} (${fmt(e.peer_seen_m2, 0, " m²")} seen)` : "";
  return `<p id="exploration">exploration ${e.task_id}: <b>${e.state}</b> · ${fmt(e.explored_m2, 0, " m²")} explored ·
    ${e.frontiers} frontiers (${e.reachable_frontiers} reachable)${target}${team} · ${e.targets_reached} reached, ${e.targets_failed} given up
    ${e.reason ? `<br><span class="reason">${e.reason}</span>` : ""}</p>`;
}

// The convoy block of the robot tab: whom it follows, how far behind along the path, the order to the leader.
function convoyHtml(c: Convoy|undefined): string {
  if (!c || c.ahead.length === 0) return '';
  const order = [...c.ahead].reverse().join(' ← ');
  const gap = c.gap_m === undefined ? '' : ` · ${fmt(c.gap_m, 1, ' m')} behind along its path`;
  const bad = c.state === 'lost' || c.state === 'blocked';
  return `<p id="convoy">convoy: <b${bad ? ' class="bad"' : ''}>${c.state}</b> behind <b>${c.ahead[0]}</b>${
      gap}
    <br><span class="small">order: ${order} ← ${state.selected}</span>
    ${c.reason ? `<br><span class="reason">${c.reason}</span>` : ''}</p>`;
}

// The yield block of the robot tab: getting out of a peer's way, or waiting for one to.
function yieldHtml(y: YieldRecord|undefined): string {
  if (!y || !y.state) return '';
  const bad = y.state === 'refused' || y.state === 'blocked';
  return `<p id="yield">get out of the way: <b${bad ? ' class="bad"' : ''}>${
      y.state.replace(
          '_', ' ')}</b> (${y.peer})${y.reason ? `<br><span class="reason">${y.reason}</span>` : ''}</p>`;
}

// One robot's link cells: probe round trip, state samples lost (10 s), what it sends against its budget.
function linkCells(r: Robot): string {
  const l = r.link;
  if (!l) return "<td>–</td><td>–</td><td>–</td>";
  const rtt = l.rtt_ms < 0 ? "–"
    : l.probe_wait_s > 0 ? `<b class="bad">no answer ${l.probe_wait_s.toFixed(0)} s</b>`
    : `${l.rtt_ms.toFixed(l.rtt_ms < 10 ? 1 : 0)} ms`;
  const loss = `${l.loss_pct.toFixed(0)} %`;
  const classes = l.usage.map((u) => `${u.topic_class} ${u.sent_kbps.toFixed(0)}`).join(", ");
  const budget = l.budget_kbps > 0 ? ` / ${l.budget_kbps.toFixed(0)}` : "";
  const sends = `<span title="${classes}">${l.sent_kbps.toFixed(0)}${budget} kbit/s</span>`;
  return `<td>${rtt}</td><td${l.loss_pct >= 5 ? ' class="bad"' : ""}>${loss}</td><td${l.over_budget ? ' class="bad"' : ""}>${l.over_budget ? "OVER " : ""}${sends}</td>`;
}

function hasDown(r: Robot): boolean {
  return (r.components ?? []).some((c) => c.state !== "active");
}

function renderHealth(): void {
  const rows = state.robots.map(
    (r) => `<tr><td>${r.id}</td><td>${r.online ? "online" : "lost"}</td><td>${fmt(r.heard_s_ago, 1, " s")}</td>
      ${linkCells(r)}<td>${fmt(r.control_period_max_ms, 0, " ms")}</td><td>${r.in_contact ? "CONTACT" : "–"}</td><td>${fmt(r.camera_age_s, 1, " s")}</td></tr>`,
  );
  setHtml($("health-rows"), rows.join(""));
  // Components, robot by robot (those with a part down first): a restart button where this basestation holds
  // the robot's lock (the only ones a robot accepts it from).
  const robots = [...state.robots].sort((a, b) => Number(hasDown(b)) - Number(hasDown(a)));
  setHtml($("component-rows"), robots.filter((r) => (r.components ?? []).length > 0).map((r) => {
    const head = `<tr class="group"><td colspan="6"><b>${r.id}</b>${hasDown(r) ? ' <b class="bad">component down</b>' : ""}</td></tr>`;
    return head + (r.components ?? []).map((c) => {
      const stateText = c.state === "down" ? `<b class="bad">DOWN</b> ${c.restart_in_s.toFixed(0)} s`
        : c.degraded ? '<b class="slow">degraded</b>' : c.state;
      // A rate under half its target is shown in the warning colour (slow, not down).
      const slow = c.state === "active" && (c.degraded || c.loop_rate_hz < 0.5 * c.target_rate_hz);
      const restart = r.you_hold && r.online
        ? `<button class="restart" title="restart ${c.name}" data-cmd="restart ${r.id} ${c.name}">restart</button>` : "";
      // The last error under the component's name (the panel is narrow): what made it fail last.
      const error = c.last_error ? `<br><span class="reason error">${c.last_error}</span>` : "";
      return `<tr data-robot-id="${r.id}"><td>${c.name}${error}</td><td>${stateText}</td>
        <td${slow ? ' class="slow"' : ""}>${c.loop_rate_hz.toFixed(0)}/${c.target_rate_hz.toFixed(0)}</td><td>${c.cpu_percent.toFixed(0)}</td>
        <td>${c.restarts}</td><td>${restart}</td></tr>`;
    }).join("");
  }).join(""));
  $("health-link").textContent = `link: ${state.statusText} · received ${(link.bytesReceived / 1e6).toFixed(1)} MB · 3D: ${scene.voxelCount} voxels, ${scene.fps.toFixed(0)} fps`;
}

function renderEvents(): void {
  $("event-rows").innerHTML = state.events
    .map((e) => `<li class="${e.level >= 3 ? "warn" : ""}"><time>${e.time.toLocaleTimeString()}</time> ${e.message}</li>`)
    .join("");
}

// ---- Input: panel buttons ---------------------------------------------------------------------------------
document.addEventListener('click', (ev) => {
  const target =
      (ev.target as HTMLElement)
          .closest<HTMLElement>(
              '[data-cmd],[data-goto],[data-peel],[data-convoy],[data-drive],[data-robot],[data-tab],#confirm-goto,#cancel-goto,#topdown,#ceiling');
  if (!target) return;
  if (target.dataset.tab)
    setTab(target.dataset.tab);
  else if (target.dataset.cmd)
    void run(target.dataset.cmd);
  else if (target.dataset.goto)
    startGoalPick(!state.pickingGoal, 'goto');
  else if (target.dataset.peel)
    startGoalPick(!state.pickingGoal, 'peel');
  else if (target.dataset.convoy)
    startConvoy(target.dataset.convoy);
  else if (target.dataset.drive)
    void setDriving(!state.driving);
  else if (target.id === "confirm-goto")
    void confirmGoal();
  else if (target.id === "cancel-goto")
    cancelGoal();
  else if (target.id === "ceiling") {
    state.ceilingAuto = !state.ceilingAuto;
    target.textContent = state.ceilingAuto ? "Ceiling: cut" : "Ceiling: shown";
    if (!state.ceilingAuto) scene.setCeilingCut(Infinity);
  } else if (target.id === "topdown") {
    scene.setTopDown(!scene.isTopDown);
    target.textContent = scene.isTopDown ? "Orbit view" : "Top-down view";
  } else if (target.dataset.robot)
    select(target.dataset.robot);
});

// ---- Input: the 3D view (tap = select or goal, long press = goal) ----------------------------------------
let press: { x: number; y: number; t: number; timer: number; moved: boolean } | undefined;
const canvas = scene.renderer.domElement;
canvas.addEventListener("pointerdown", (ev) => {
  if (!ev.isPrimary) return;
  const timer = window.setTimeout(() => {
    if (press && !press.moved) onLongPress(press.x, press.y);
  }, 600);
  press = { x: ev.clientX, y: ev.clientY, t: performance.now(), timer, moved: false };
});
canvas.addEventListener("pointermove", (ev) => {
  if (press && Math.hypot(ev.clientX - press.x, ev.clientY - press.y) > 8) press.moved = true;
});
canvas.addEventListener("pointerup", (ev) => {
  if (!press) return;
  window.clearTimeout(press.timer);
  const tap = !press.moved && performance.now() - press.t < 600;
  press = undefined;
  if (tap) onTap(ev.clientX, ev.clientY);
});

function groundZ(): number {
  return selectedRobot()?.pose?.z_m ?? 0;
}

function onTap(x: number, y: number): void {
  const hit = scene.pick(x, y, groundZ());
  if (state.pickingGoal && hit.point) {
    proposeGoal(hit.point.x, hit.point.y, hit.surface ? hit.point.z : undefined);
    return;
  }
  if (hit.robot) select(hit.robot);
}

function onLongPress(x: number, y: number): void {
  const r = selectedRobot();
  if (!r || !r.valid_actions.includes("goto")) {
    toast(r ? `${r.id}: goto is not valid now (valid: ${r.valid_actions.join(", ")})` : "select a robot first", "warn");
    return;
  }
  const hit = scene.pick(x, y, groundZ());
  if (hit.point) proposeGoal(hit.point.x, hit.point.y, hit.surface ? hit.point.z : undefined);
}

function startGoalPick(on: boolean, verb: 'goto'|'peel' = 'goto'): void {
  state.pickingGoal = on;
  state.goalVerb = verb;
  $("banner").hidden = !on;
  $('banner').textContent = !on ?
      '' :
      verb === 'peel' ?
      `Tap the map where ${state.selected} should go when it leaves its convoy (Esc cancels)` :
      `Tap the map where ${state.selected} should go (Esc cancels)`;
  render();
}

// ---- Convoy: the leader, then the followers in order, tapped in the 3D view or the fleet list ------------
function startConvoy(leader: string): void {
  state.convoyOrder = [leader];
  state.convoyNote = '';
  setTab('fleet');  // the robots to tap, beside the 3D view
  showConvoyOrder();
}

function addToConvoy(id: string): void {
  const order = state.convoyOrder;
  if (!order || order.includes(id)) return;
  const r = state.robots.find((x) => x.id === id);
  // Only a robot this basestation may send into a convoy now (its valid actions, as cairn_base's help R).
  if (!r || !r.valid_actions.includes('convoy')) {
    state.convoyNote =
        `${id} cannot follow: ${r?.you_hold ? 'it cannot drive by itself now' : 'you do not hold it'}`;
  } else {
    order.push(id);
    state.convoyNote = '';
  }
  showConvoyOrder();
}

function showConvoyOrder(): void {
  const order = state.convoyOrder ?? [];
  // One box: the order so far and what to do next (the banner would sit under it).
  $('banner').hidden = true;
  $('confirm-text').textContent =
      (order.length < 2 ? `Convoy behind ${order[0]}: tap the first follower` :
                          `Convoy: ${order.join(' ← ')} · tap the next follower, or confirm`) +
      (state.convoyNote ? ` · ${state.convoyNote}` : '');
  ($('confirm-goto') as HTMLButtonElement).disabled = order.length < 2;
  $('confirm').hidden = false;
  render();
}

// A tapped surface more than this above or below the robot names its level (goto --z): another floor, a
// landing; nearer ones are the robot's own level.
const kOtherLevelM = 0.5;

/** Asks to confirm a goal at (x, y) in the map frame, m; `z` (m) names the level when it is not the robot's. */
function proposeGoal(x: number, y: number, z?: number): void {
  const robotZ = selectedRobot()?.pose?.z_m ?? 0;
  const level = z !== undefined && Math.abs(z - robotZ) > kOtherLevelM ? z : undefined;
  state.pendingGoal = { x, y, z: level };
  state.pickingGoal = false;
  $("banner").hidden = true;
  ($('confirm-goto') as HTMLButtonElement).disabled = false;
  $('confirm-text').textContent =
      `${state.goalVerb === 'peel' ? 'Peel' : 'Send'} ${state.selected} ${
          state.goalVerb === 'peel' ? 'off ' : ''}to (${x.toFixed(2)}, ${y.toFixed(2)})` +
      (level === undefined ? '?' : ` on the level at z ${level.toFixed(2)} m?`);
  $("confirm").hidden = false;
  render();
}

async function confirmGoal(): Promise<void> {
  const g = state.pendingGoal;
  const order = state.convoyOrder;
  $("confirm").hidden = true;
  state.pendingGoal = undefined;
  if (order) {
    state.convoyOrder = undefined;
    $('banner').hidden = true;
    if (order.length >= 2) await run(`convoy ${order.join(' ')}`);
    render();
    return;
  }
  if (g && state.selected) {
    if (state.goalVerb === 'peel')
      await run(`peel ${state.selected} ${g.x.toFixed(2)} ${g.y.toFixed(2)}`);
    else
      await run(`goto ${state.selected} ${g.x.toFixed(2)} ${g.y.toFixed(2)}${
          g.z === undefined ? '' : ` --z ${g.z.toFixed(2)}`}`);
  }
}

function cancelGoal(): void {
  state.pendingGoal = undefined;
  state.convoyOrder = undefined;
  ($('confirm-goto') as HTMLButtonElement).disabled = false;
  $("confirm").hidden = true;
  startGoalPick(false);
}

// ---- Driving: keyboard and gamepad (deadman), streamed on /cairn/teleop at 10 Hz ---------------------------
const keys = new Set<string>();
async function setDriving(on: boolean): Promise<void> {
  const r = selectedRobot();
  if (on && r && r.mode !== "manual" && r.mode !== "smart_joystick") {
    const result = await run(`mode ${r.id} manual`);
    if (!result.ok) return;
  }
  state.driving = on && !!r;
  if (!state.driving) {
    if (r) link.teleop(r.id, 0, 0);
    state.drive = { vx: 0, wz: 0, active: false, source: "", stale: false, sent: state.drive.sent };
  }
  render();
}

let lastPadStamp = -1;
let zerosToSend = 0;
let lastPadChange = performance.now();
function driveTick(): void {
  const r = selectedRobot();
  if (!state.driving || !r) return;
  const vmax = r.max_speed_mps > 0 ? Math.min(r.max_speed_mps, 1.0) : 0.5;
  const wmax = r.max_yaw_rate_radps > 0 ? Math.min(r.max_yaw_rate_radps, 1.2) : 1.0;
  let vx = 0, wz = 0, active = false, source = "", stale = false;
  const pad = Array.from(navigator.getGamepads?.() ?? []).find((p) => p && p.connected);
  if (pad) {
    const deadman = [4, 5, 6, 7].some((i) => pad.buttons[i]?.pressed);
    if (pad.timestamp !== lastPadStamp) {
      lastPadStamp = pad.timestamp;
      lastPadChange = performance.now();
    }
    stale = performance.now() - lastPadChange > 500;
    source = `gamepad${deadman ? " (deadman held)" : " (deadman released)"}`;
    if (deadman && !stale) {
      const ax = (v: number) => (Math.abs(v) < 0.08 ? 0 : v);
      vx = -ax(pad.axes[1] ?? 0) * vmax;
      wz = -ax(pad.axes[0] ?? 0) * wmax;
      active = true;
    }
  }
  if (!active && keys.size > 0) {
    source = "keyboard";
    vx = ((keys.has("ArrowUp") || keys.has("w") ? 1 : 0) - (keys.has("ArrowDown") || keys.has("s") ? 1 : 0)) * vmax * 0.6;
    wz = ((keys.has("ArrowLeft") || keys.has("a") ? 1 : 0) - (keys.has("ArrowRight") || keys.has("d") ? 1 : 0)) * wmax * 0.6;
    active = true;
  }
  if (state.drive.active && !active) zerosToSend = 5;
  state.drive = { vx, wz, active, source, stale, sent: state.drive.sent };
  // While active: the twist at 10 Hz. On release (or a silent stick): zero for 0.5 s (one may be lost), then
  // silence; the robot's mux also stops it when the twists stop (teleop_timeout_s).
  if (active) {
    if (link.teleop(r.id, vx, wz)) state.drive.sent++;
  } else if (zerosToSend > 0) {
    zerosToSend--;
    if (link.teleop(r.id, 0, 0)) state.drive.sent++;
  }
  renderRobot();
}
window.setInterval(driveTick, 100);

window.addEventListener("keydown", (ev) => {
  if ((ev.target as HTMLElement).tagName === "INPUT") return;
  if (state.driving && ["ArrowUp", "ArrowDown", "ArrowLeft", "ArrowRight", "w", "a", "s", "d"].includes(ev.key)) {
    keys.add(ev.key);
    ev.preventDefault();
    return;
  }
  if (ev.key === "Escape") cancelGoal();
  else if (ev.key === " " && state.selected) {
    ev.preventDefault();
    void run(`stop ${state.selected}`);
  } else if (ev.key === "t") $("topdown").click();
  else if (ev.key === "g" && selectedRobot()?.valid_actions.includes("goto")) startGoalPick(true);
  else if (/^[1-9]$/.test(ev.key) && state.robots[Number(ev.key) - 1]) select(state.robots[Number(ev.key) - 1].id);
});
window.addEventListener("keyup", (ev) => keys.delete(ev.key));
window.addEventListener("blur", () => keys.clear());

window.setInterval(() => {
  renderHealth();
  renderRobot();
}, 1000);

// For tests and benches (Playwright reads it; nothing in the page depends on it).
(window as any).cairn = { state, scene, link, run, select, proposeGoal, confirmGoal };

setTab(state.selected ? "robot" : "fleet");
const bench = params.get("bench_voxels");
if (bench) {
  scene.continuous = true; // the frame-rate bench: draw every frame
  link.onState(false, `bench: ${bench} synthetic voxels, no server`);
  scene.addSyntheticVoxels(Number(bench));
}
else link.connect();
