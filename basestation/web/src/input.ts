// The operator's input: panel buttons, taps and long presses in the 3D view, a goal or a convoy put together
// and confirmed, driving with keys or a gamepad (deadman), keyboard shortcuts. Every command goes to
// cairn_base as a structured request (wire.ts), with the CLI's semantics and reasons.
import { render, renderGoalMarkers, renderRobot, setTab, toast } from "./panels";
import { $, link, scene, selectedRobot, state } from "./state";
import { Command, checkAgainstTable, commandText, type CommandRequest, type CommandResult } from "./wire";

// ---- Commands (the CLI's semantics and reasons) -----------------------------------------------------------
/** Sends `request`; notifies its outcome (a refusal even when `quiet`) and re-renders. */
export async function run(request: CommandRequest, quiet = false): Promise<CommandResult> {
  const line = commandText(request);
  // Checked against cairn_base's table first (once it arrived): a usage error needs no round trip.
  const misfit = state.commandTable.size > 0 ? checkAgainstTable(request, state.commandTable) : "";
  const result: CommandResult = misfit ? { ok: false, result: "invalid", reason: misfit } : await link.command(request);
  state.lastResult = result;
  if (!quiet || !result.ok) {
    const words = result.ok ? `${line}: ${result.result ?? "accepted"}` : `${line}: ${result.result ?? "failed"} — ${result.reason ?? ""}`;
    // A request for a held lock is refused for now but waits for its holder's answer: news, not a failure.
    const waits = request.name === "request-control" && /asked \S+ to hand it over/.test(result.reason ?? "");
    toast(words, result.ok ? "ok" : waits ? "info" : "bad");
  }
  render();
  return result;
}

export function select(id: string): void {
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

// ---- Input: panel buttons ---------------------------------------------------------------------------------
function onClick(ev: MouseEvent): void {
  const target =
      (ev.target as HTMLElement)
          .closest<HTMLElement>(
              '[data-command],[data-goto],[data-peel],[data-convoy],[data-drive],[data-robot],[data-tab],#confirm-goto,#cancel-goto,#topdown,#ceiling,#frame-all');
  if (!target) return;
  if (target.dataset.tab)
    setTab(target.dataset.tab);
  else if (target.dataset.command)
    void run(JSON.parse(target.dataset.command) as CommandRequest);
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
  } else if (target.id === "frame-all") {
    scene.frame(state.robots.filter((r) => r.pose).map((r) => ({ x: r.pose!.x_m, y: r.pose!.y_m, z: r.pose!.z_m })));
  } else if (target.id === "topdown") {
    scene.setTopDown(!scene.isTopDown);
    target.textContent = scene.isTopDown ? "Orbit view" : "Top-down view";
  } else if (target.dataset.robot)
    select(target.dataset.robot);
}

// ---- Input: the 3D view (tap = select or goal, long press = goal) ----------------------------------------
let press: { x: number; y: number; t: number; timer: number; moved: boolean } | undefined;
function onPointerDown(ev: PointerEvent): void {
  if (!ev.isPrimary) return;
  const timer = window.setTimeout(() => {
    if (press && !press.moved) onLongPress(press.x, press.y);
  }, 600);
  press = { x: ev.clientX, y: ev.clientY, t: performance.now(), timer, moved: false };
}

function onPointerMove(ev: PointerEvent): void {
  if (press && Math.hypot(ev.clientX - press.x, ev.clientY - press.y) > 8) press.moved = true;
}

function onPointerUp(ev: PointerEvent): void {
  if (!press) return;
  window.clearTimeout(press.timer);
  const tap = !press.moved && performance.now() - press.t < 600;
  press = undefined;
  if (tap) onTap(ev.clientX, ev.clientY);
}

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

/** Asks to confirm a goal at (x, y) in the map frame, m; `z` (m) names the level when it is not the robot's. */
// A tapped surface more than this above or below the robot names its level (goto --z): another floor, a
// landing; nearer ones are the robot's own level.
const kOtherLevelM = 0.5;

export function proposeGoal(x: number, y: number, z?: number): void {
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
  renderGoalMarkers();
}

export async function confirmGoal(): Promise<void> {
  const g = state.pendingGoal;
  const order = state.convoyOrder;
  $("confirm").hidden = true;
  state.pendingGoal = undefined;
  if (order) {
    state.convoyOrder = undefined;
    $('banner').hidden = true;
    if (order.length >= 2) await run(Command.convoy(order));
    render();
    return;
  }
  if (g && state.selected) {
    const robot = state.selected;
    const groundZ = g.z ?? selectedRobot()?.pose?.z_m ?? 0;
    // Drawn from the tap on: while the command goes out, then until the robot reaches or drops it.
    state.sentGoals.set(robot, { x: g.x, y: g.y, z: groundZ, sentMs: Date.now() });
    renderGoalMarkers();
    const result = state.goalVerb === "peel" ? await run(Command.peel(robot, round2(g.x), round2(g.y)))
      : await run(Command.goto(robot, round2(g.x), round2(g.y), g.z === undefined ? undefined : round2(g.z)));
    if (!result.ok) state.sentGoals.delete(robot);
    renderGoalMarkers();
  }
}

function cancelGoal(): void {
  state.pendingGoal = undefined;
  state.convoyOrder = undefined;
  ($('confirm-goto') as HTMLButtonElement).disabled = false;
  $("confirm").hidden = true;
  startGoalPick(false);
  renderGoalMarkers();
}

// ---- Driving: keyboard and gamepad (deadman), streamed on /cairn/teleop at 10 Hz ---------------------------
const keys = new Set<string>();
async function setDriving(on: boolean): Promise<void> {
  const r = selectedRobot();
  if (on && r && r.mode !== "manual" && r.mode !== "smart_joystick") {
    const result = await run(Command.mode(r.id, "manual"));
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

function onKeyDown(ev: KeyboardEvent): void {
  if ((ev.target as HTMLElement).tagName === "INPUT") return;
  if (state.driving && ["ArrowUp", "ArrowDown", "ArrowLeft", "ArrowRight", "w", "a", "s", "d"].includes(ev.key)) {
    keys.add(ev.key);
    ev.preventDefault();
    return;
  }
  if (ev.key === "Escape") cancelGoal();
  else if (ev.key === " " && state.selected) {
    ev.preventDefault();
    void run(Command.stop(state.selected));
  } else if (ev.key === "t") $("topdown").click();
  else if (ev.key === "g" && selectedRobot()?.valid_actions.includes("goto")) startGoalPick(true);
  else if (/^[1-9]$/.test(ev.key) && state.robots[Number(ev.key) - 1]) select(state.robots[Number(ev.key) - 1].id);
}

/** Listens to the panel, the 3D view, the keyboard, and streams the drive at 10 Hz. */
export function installInput(): void {
  document.addEventListener("click", onClick);
  const canvas = scene.renderer.domElement;
  canvas.addEventListener("pointerdown", onPointerDown);
  canvas.addEventListener("pointermove", onPointerMove);
  canvas.addEventListener("pointerup", onPointerUp);
  window.addEventListener("keydown", onKeyDown);
  window.addEventListener("keyup", (ev) => keys.delete(ev.key));
  window.addEventListener("blur", () => keys.clear());
  window.setInterval(driveTick, 100);
}


// A goal to the centimetre, as it is shown in the confirmation (what the operator agreed to is what is sent).
function round2(v: number): number {
  return Math.round(v * 100) / 100;
}
