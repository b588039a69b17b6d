// The side panel, drawn from the state: the fleet list, the selected robot (its valid actions as buttons, its
// navigation, exploration, convoy and yield), health (links and components), events, and notifications.
// Action buttons carry their command as JSON (data-command: a wire.ts CommandRequest); input.ts sends it.
import { controlLate, rateLow } from "./health";
import { modeColor, type GoalMarker } from "./scene";
import { $, link, scene, selectedRobot, state } from "./state";
import { Command, type CommandRequest, type Convoy, type Exploration, type Robot, type YieldRecord } from "./wire";

// ---- Notifications ------------------------------------------------------------------------------------
export const kToastMaxAgeMs = 10000; // an event older than this when it arrives goes to the Events tab only
export const seenEvents = new Set<string>();

/** A notification for 5 s; `eventMs` is when it happened (state.toasts keeps both times for tests). */
export function toast(text: string, kind: "info" | "warn" | "ok" | "bad" = "info", eventMs = Date.now()): void {
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

// ---- Rendering of the side panel ------------------------------------------------------------------------
export function setTab(tab: string): void {
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

export function render(): void {
  $("base").textContent = state.baseId ? `basestation ${state.baseId}` : "";
  renderStops();
  renderFleet();
  renderRobot();
  renderHealth();
  renderRequests();
}

/** The header's STOP (the selected robot) and STOP ALL: any basestation may stop any robot (no lock needed). */
function renderStops(): void {
  const one = $("stop-selected") as HTMLButtonElement;
  const id = state.selected;
  const command = id ? JSON.stringify(Command.stop(id)) : "";
  if ((one.dataset.command ?? "") !== command) {
    if (id) one.dataset.command = command;
    else delete one.dataset.command;
    one.textContent = id ? `STOP ${id}` : "STOP";
    one.disabled = !id;
  }
  const all = $("stop-all");
  const stopAll = JSON.stringify(Command.stopAll());
  if (all.dataset.command !== stopAll) all.dataset.command = stopAll;
}

/** The requests for control locks: to this basestation's operator, when it holds a lock another asks for (with
 *  Grant and Deny), and when it waits for another's answer. Shown over the 3D view whatever the tab. */
export function renderRequests(): void {
  const cards: string[] = [];
  const left = new Map<string, string>();
  for (const r of state.robots) {
    const from = r.control_request?.from;
    if (!from) continue;
    left.set(r.id, `${Math.max(0, Math.ceil(r.control_request!.left_s))} s left`);
    if (r.you_hold) {
      cards.push(`<div class="request" data-request="${r.id}"><b>${from}</b> asks for control of <b>${r.id}</b> (<span class="left"></span>)
        <button class="act" ${commandAttribute(Command.grant(r.id, from))}>Grant</button>
        <button class="act" ${commandAttribute(Command.deny(r.id, from))}>Deny</button></div>`);
    } else if (from === state.baseId) {
      cards.push(`<div class="request mine" data-request="${r.id}">waiting for <b>${r.holder}</b> to answer your request for <b>${r.id}</b> (<span class="left"></span>)</div>`);
    }
  }
  // The cards are rebuilt only when the requests change (their buttons stay put under a finger); the seconds
  // left are updated in place.
  setHtml($("requests"), cards.join(""));
  for (const card of Array.from($("requests").querySelectorAll<HTMLElement>("[data-request]"))) {
    const span = card.querySelector<HTMLElement>(".left");
    const text = left.get(card.dataset.request ?? "") ?? "";
    if (span && span.textContent !== text) span.textContent = text;
  }
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
        `<td><span class="swatch" style="background:${r.color}"></span>${r.id}<span class="dot ${r.online ? 'on' : 'off'}"></span></td>
      <td><span class="chip" style="background:${modeColor(r.mode)}">${r.mode || '?'}</span>${
            r.convoy?.ahead.length ? ` <span class="small">→ ${r.convoy.ahead[0]}</span>` : ''}</td>
      <td>${holder}</td><td>${r.online ? fmt(r.heard_s_ago, 1, ' s') : 'lost'}</td>`);
  }
  $("fleet-empty").hidden = state.robots.length > 0;
}

const escapeAttribute = (text: string) => text.replace(/&/g, "&amp;").replace(/"/g, "&quot;").replace(/</g, "&lt;");

/** The attributes that make an element send `request` when tapped (input.ts reads it back), with the
 *  command's help from cairn_base's table as its tooltip. */
export function commandAttribute(request: CommandRequest): string {
  const help = state.commandTable.get(request.name)?.help;
  return `data-command="${escapeAttribute(JSON.stringify(request))}"${help ? ` title="${escapeAttribute(help)}"` : ""}`;
}

// The buttons of the robot's valid actions (ValidActions of cairn_base for this basestation).
function actionButtons(r: Robot): string {
  const b: string[] = [];
  const button = (request: CommandRequest, label: string, style = "") =>
    b.push(`<button class="act${style ? " mode" : ""}" ${commandAttribute(request)}${style ? ` style="${style}"` : ""}>${label}</button>`);
  for (const action of r.valid_actions) {
    if (action === "request-control")
      button(Command.requestControl(r.id), r.holder && !r.you_hold ? `Ask ${r.holder} for control` : "Request control");
    else if (action.startsWith("grant ")) button(Command.grant(r.id, action.slice(6)), `Grant control to ${action.slice(6)}`);
    else if (action.startsWith("deny ")) button(Command.deny(r.id, action.slice(5)), `Deny ${action.slice(5)}`);
    else if (action === "release") button(Command.release(r.id), "Release control");
    else if (action.startsWith("mode ")) {
      for (const mode of action.slice(5).split("|")) {
        if (mode === r.mode) continue;
        button(Command.mode(r.id, mode), `Mode ${mode.replace("_", " ")}`, `border-color:${modeColor(mode)}`);
      }
    } else if (action === "goto") b.push(`<button class="act" data-goto="1">${state.pickingGoal ? "Tap the map… (Esc)" : "Go to… (tap the map)"}</button>`);
    else if (action === "teleop") b.push(`<button class="act" data-drive="1">${state.driving ? "Stop driving" : "Drive (keys / gamepad)"}</button>`);
    else if (action === "explore") button(Command.explore(r.id), "Explore");
    else if (action === "home") button(Command.home(r.id), "Return home");
    else if (action === "convoy" && !state.convoyOrder) b.push(`<button class="act" data-convoy="${r.id}">Lead a convoy…</button>`);
    else if (action === "peel")
      b.push(`<button class="act" data-peel="1">${
          state.pickingGoal && state.goalVerb === "peel" ? "Tap the map… (Esc)" : "Peel off… (tap the map)"}</button>`);
    else if (action === "yield" && r.yield?.for) button(Command.yieldFor(r.id, r.yield.for), `Get out of ${r.yield.for}'s way`);
    else if (action === "convoy-stop" && r.convoy?.ahead.length)
      button(Command.convoyStop(r.convoy.ahead[r.convoy.ahead.length - 1]), "Stop the convoy");
  }
  return b.join("");
}

export function renderRobot(): void {
  const r = selectedRobot();
  if (!r) {
    setHtml($("robot-head"), `<p>Tap a robot in the 3D view or the fleet list.</p>`);
    setHtml($("actions"), "");
    setHtml($("robot-nav"), "");
    return;
  }
  const holder = r.holder ? `held by <b>${r.holder}</b>${r.you_hold ? " (you)" : ""}${r.holder_alive ? "" : " (not heard)"}` : "free";
  setHtml($("robot-head"), `<h2><span class="swatch" style="background:${r.color}"></span>${r.id} <span class="chip" style="background:${modeColor(r.mode)}">${r.mode || "?"}</span></h2>
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
          r.nav_reason ? `<br><span class="reason${r.nav_status === "failed" || r.nav_status === "active" ? " warn" : ""}">${r.nav_reason}</span>` : ''}</p>
    <p class="small">local planner: ${r.local_planner_status || '–'} · speed ${
          fmt(Math.abs(r.speed_mps), 2, ' m/s')}</p>
    ${explorationHtml(r.exploration)}${convoyHtml(r.convoy)}${yieldHtml(r.yield)}`);
  setHtml($("actions"), actionButtons(r) + `<button class="act stop" ${commandAttribute(Command.stop(r.id))}>STOP</button>`);
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
  return `<p id="exploration">exploration ${shortId(e.task_id)}: <b>${e.state}</b> · ${fmt(e.explored_m2, 0, " m²")} explored ·
    ${e.frontiers} frontiers (${e.reachable_frontiers} reachable)${target}${team} · ${e.targets_reached} reached, ${e.targets_failed} given up
    ${e.reason ? `<br><span class="reason${e.state === "failed" || e.state === "stopped" || e.state === "paused" ? " warn" : ""}">${e.reason}</span>` : ""}</p>`;
}

/** A goal or exploration id as the console prints it: "#845", its last three digits (a robot numbers them up
 *  from a random start); "#7" under 1000. */
export function shortId(id: number): string {
  return id < 1000 ? `#${id}` : `#${String(id % 1000).padStart(3, "0")}`;
}

/** The goal markers of the 3D view: the goal being chosen (faint, before it is sent), and each goal sent from
 *  this page until its robot reaches or drops it (or another goal replaces it). */
export function renderGoalMarkers(): void {
  const markers: GoalMarker[] = [];
  const now = Date.now();
  for (const [id, g] of state.sentGoals) {
    const r = state.robots.find((x) => x.id === id);
    // For 3 s after sending, the robot's state may not show the goal yet.
    const fresh = now - g.sentMs < 3000;
    const driving = r?.nav_status === "active" && !!r.goal && Math.hypot(r.goal.x_m - g.x, r.goal.y_m - g.y) < 0.3;
    if (!r || (!fresh && !driving)) {
      state.sentGoals.delete(id);
      continue;
    }
    if (state.pendingGoal && id === state.selected) continue; // one marker per robot: the new one
    markers.push({ robot: id, x: g.x, y: g.y, z: g.z, color: r.color, pending: false });
  }
  const p = state.pendingGoal;
  const r = selectedRobot();
  if (p && r && !state.convoyOrder) markers.push({ robot: r.id, x: p.x, y: p.y, z: p.z ?? r.pose?.z_m ?? 0, color: r.color, pending: true });
  scene.setGoalMarkers(markers);
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
    ${c.reason ? `<br><span class="reason${bad ? ' warn' : ''}">${c.reason}</span>` : ''}</p>`;
}

// The yield block of the robot tab: getting out of a peer's way, or waiting for one to.
function yieldHtml(y: YieldRecord|undefined): string {
  if (!y || !y.state) return '';
  const bad = y.state === 'refused' || y.state === 'blocked';
  return `<p id="yield">get out of the way: <b${bad ? ' class="bad"' : ''}>${
      y.state.replace(
          '_', ' ')}</b> (${y.peer})${y.reason ? `<br><span class="reason${bad ? ' warn' : ''}">${y.reason}</span>` : ''}</p>`;
}

// One robot's link: probe round trip, state samples lost (10 s), what it sends against its budget; each a
// labelled cell (the panel wraps them into as many columns as fit).
function linkCells(r: Robot): string[] {
  const l = r.link;
  if (!l) return [cell("probe", "–"), cell("lost", "–"), cell("sends", "–")];
  const rtt = l.rtt_ms < 0 ? "–"
    : l.probe_wait_s > 0 ? `<b class="bad">no answer ${l.probe_wait_s.toFixed(0)} s</b>`
    : `${l.rtt_ms.toFixed(l.rtt_ms < 10 ? 1 : 0)} ms`;
  const classes = l.usage.map((u) => `${u.topic_class} ${u.sent_kbps.toFixed(0)}`).join(", ");
  const budget = l.budget_kbps > 0 ? ` / ${l.budget_kbps.toFixed(0)}` : "";
  const sends = `<span title="${classes}">${l.over_budget ? "OVER " : ""}${l.sent_kbps.toFixed(0)}${budget} kbit/s</span>`;
  return [cell("probe", rtt, "link-probe round trip"), cell("lost", `${l.loss_pct.toFixed(0)} %`, "state samples lost over 10 s", l.loss_pct >= 5 ? "bad" : ""),
    cell("sends", sends, "what it sends / its link budget", l.over_budget ? "bad" : "")];
}

function cell(name: string, value: string, title = "", style = ""): string {
  return `<div${title ? ` title="${title}"` : ""}><dt>${name}</dt><dd${style ? ` class="${style}"` : ""}>${value}</dd></div>`;
}

function hasDown(r: Robot): boolean {
  return (r.components ?? []).some((c) => c.state !== "active");
}

export function renderHealth(): void {
  // One block per robot: its name and status on a line, then labelled cells that wrap to the panel's width
  // (no column is ever clipped, whatever the window).
  const rows = state.robots.map((r) => {
    const status = r.online ? "online" : '<b class="bad">lost</b>';
    const cells = [cell("heard", fmt(r.heard_s_ago, 1, " s")), ...linkCells(r),
      cell("loop", fmt(r.control_period_max_ms, 0, " ms"), "worst control-loop period lately", controlLate(r) ? "slow" : ""),
      cell("contact", r.in_contact ? "CONTACT" : "–", "bumper contact", r.in_contact ? "bad" : ""),
      cell("cam", fmt(r.camera_age_s, 1, " s"), "camera frame age")];
    return `<div class="health-robot" data-robot-id="${r.id}"><div class="head"><span class="swatch" style="background:${r.color}"></span><b>${r.id}</b> ${status}</div>
      <dl class="cells">${cells.join("")}</dl></div>`;
  });
  setHtml($("health-rows"), rows.join(""));
  // Components, robot by robot (those with a part down first): a restart button where this basestation holds
  // the robot's lock (the only ones a robot accepts it from).
  const robots = [...state.robots].sort((a, b) => Number(hasDown(b)) - Number(hasDown(a)));
  setHtml($("component-rows"), robots.filter((r) => (r.components ?? []).length > 0).map((r) => {
    const head = `<tr class="group"><td colspan="6"><span class="swatch" style="background:${r.color}"></span><b>${r.id}</b>${hasDown(r) ? ' <b class="bad">component down</b>' : ""}</td></tr>`;
    return head + (r.components ?? []).map((c) => {
      const stateText = c.state === "down" ? `<b class="bad">DOWN</b> ${c.restart_in_s.toFixed(0)} s`
        : c.degraded ? '<b class="slow">degraded</b>' : c.state;
      const restart = r.you_hold && r.online
        ? `<button class="restart" ${commandAttribute(Command.restart(r.id, c.name))}>restart</button>` : "";
      // The last error under the component's name (the panel is narrow): what made it fail last.
      const error = c.last_error ? `<br><span class="reason error">${c.last_error}</span>` : "";
      // Long names break after an underscore, not inside a word.
      return `<tr data-robot-id="${r.id}"><td>${c.name.replace(/_/g, "_<wbr>")}${error}</td><td>${stateText}</td>
        <td${rateLow(c) ? ' class="slow"' : ""}>${c.loop_rate_hz.toFixed(0)}/${c.target_rate_hz.toFixed(0)}</td><td>${c.cpu_percent.toFixed(0)}</td>
        <td>${c.restarts}</td><td>${restart}</td></tr>`;
    }).join("");
  }).join(""));
  $("health-link").textContent = `link: ${state.statusText} · received ${(link.bytesReceived / 1e6).toFixed(1)} MB · 3D: ${scene.voxelCount} voxels, ${scene.fps.toFixed(0)} fps`;
}

/** A time of day as the console prints it: 24-hour HH:MM:SS, local time. */
export function clockText(t: Date): string {
  const two = (n: number) => String(n).padStart(2, "0");
  return `${two(t.getHours())}:${two(t.getMinutes())}:${two(t.getSeconds())}`;
}

export function renderEvents(): void {
  $("event-rows").innerHTML = state.events
    .map((e) => `<li class="${e.level >= 3 ? "warn" : ""}"><time>${clockText(e.time)}</time> ${e.message}</li>`)
    .join("");
}

