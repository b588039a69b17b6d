// Cairn's operator GUI: the fleet at a glance in 3D, per robot only the actions valid now (from the state the
// robot publishes and this basestation's lock), notifications, a camera pane, touch, mouse, keyboard and a
// gamepad. Everything goes through cairn_base (the same FleetClient as its CLI) over the Foxglove WebSocket
// protocol; nothing here bypasses the control lock.
//   wire.ts    the messages on the wire (channels, commands, teleop), shared with the tests
//   state.ts   the GUI's state, the 3D scene and the link
//   panels.ts  rendering of the side panel and notifications
//   input.ts   buttons, taps, goals, convoys, driving, keys
//   main.ts    (here) the messages from cairn_base into the state, and the start
import { installInput, confirmGoal, proposeGoal, run, select } from "./input";
import { kToastMaxAgeMs, render, renderGoalMarkers, renderEvents, renderHealth, renderRequests, renderRobot, seenEvents, setTab, toast } from "./panels";
import { $, link, params, scene, state, type EventEntry } from "./state";
import { Topic, type CameraMessage, type CommandTableMessage, type EventMessage, type FleetMessage } from "./wire";

link.onState = (connected, text) => {
  state.statusText = text;
  $("conn").textContent = connected ? `● ${text}` : `○ ${text}`;
  $("conn").className = connected ? "ok" : "bad";
};
link.onMessage = onMessage;

// ---- Messages from cairn_base -------------------------------------------------------------------------
function onMessage(topic: string, message: unknown): void {
  if (topic === Topic.fleet) {
    const msg = message as FleetMessage;
    state.baseId = msg.base_id;
    state.robots = msg.robots;
    if (!state.selected && state.robots.length > 0 && params.get("select") !== "none") state.selected = state.robots[0].id;
    scene.selected = state.selected;
    const zs = state.robots.filter((r) => r.pose).map((r) => r.pose!.z_m);
    if (state.ceilingAuto && zs.length > 0) scene.setCeilingCut(Math.max(...zs) + 1.6);
    scene.setRobots(
      state.robots
        .filter((r) => r.pose)
        .map((r) => ({ id: r.id, x: r.pose!.x_m, y: r.pose!.y_m, z: r.pose!.z_m, yaw: r.pose!.yaw_rad, mode: r.mode, holder: r.holder, online: r.online, color: r.color })),
    );
    renderGoalMarkers();
    render();
  } else if (topic === Topic.fleetMap || topic === Topic.paths || topic === Topic.staircases || topic === Topic.places) {
    scene.applySceneUpdate(message);
  } else if (topic === Topic.events) {
    const msg = message as EventMessage;
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
  } else if (topic === Topic.commands) {
    state.commandTable = new Map((message as CommandTableMessage).commands.map((c) => [c.name, c]));
    render();
  } else if (topic.endsWith("/camera")) {
    const msg = message as CameraMessage;
    const robot = topic.split("/")[1];
    const old = state.cameraUrls.get(robot);
    if (old) URL.revokeObjectURL(old.url);
    const bytes = Uint8Array.from(atob(msg.data), (c) => c.charCodeAt(0));
    const url = URL.createObjectURL(new Blob([bytes], { type: `image/${msg.format}` }));
    state.cameraUrls.set(robot, { url, stamp: Date.now() });
    if (robot === state.selected) ($("camera") as HTMLImageElement).src = url;
  }
}

window.setInterval(() => {
  renderHealth();
  renderRobot();
  renderRequests();
}, 1000);

installInput();

// For tests and benches (Playwright reads it; nothing in the page depends on it).
(window as any).cairn = { state, scene, link, run, select, proposeGoal, confirmGoal };

setTab(state.selected ? "robot" : "fleet");
const bench = params.get("bench_voxels");
if (bench) {
  scene.continuous = true; // the frame-rate bench: draw every frame
  scene.map.boxesOnly = params.get("bench_boxes") === "1"; // its baseline: one instanced box per voxel
  link.onState(false, `bench: ${bench} synthetic voxels, no server`);
  scene.addSyntheticVoxels(Number(bench));
}
else link.connect();
