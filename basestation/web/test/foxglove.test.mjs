// A plain Foxglove WebSocket protocol client (@foxglove/ws-protocol in node, over `ws`), as Foxglove or
// Lichtblick would connect to cairn_base --gui: it lists the channels, subscribes to each, decodes a message
// from each and validates it against the JSON schema the channel advertises (Foxglove's well-known schemas and
// cairn.FleetState); the /cairn/command service answers with the CLI's result and reason; a malformed client
// publish on /cairn/teleop moves nothing. Real processes, run by ctest inside a private network namespace.
import assert from "node:assert/strict";
import { spawnSync } from "node:child_process";
import { copyFileSync, mkdirSync } from "node:fs";
import { join } from "node:path";
import { after, before, test } from "node:test";

import wsProtocol from "@foxglove/ws-protocol";
import Ajv from "ajv";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;

import { BUILD, LOGS, loadWire, startBase, startRobot, stopAll, waitFor } from "./harness.mjs";

// The GUI's own wire module (src/wire.ts, built into wire.mjs): channel names and the commands it sends.
const { Command, Topic, checkAgainstTable, commandText } = await loadWire();

const DOMAIN = 74;
let base, client;
const channels = new Map(); // id -> channel
const services = new Map(); // name -> service
const firstMessage = new Map(); // topic -> decoded JSON
const responses = new Map(); // call id -> decoded JSON
const decoder = new TextDecoder();

before(async () => {
  // Facing the room's staircase (first riser at x = 50), so that /staircases and /events have something.
  await startRobot("r1", { start: "46.5,23.75,0", domain: DOMAIN });
  // The tunnels' named places (a copy), so that /places has something.
  mkdirSync(LOGS, { recursive: true });
  const places = join(LOGS, "places-tunnels.yaml");
  copyFileSync(new URL("../../../config/places/tunnels.yaml", import.meta.url), places);
  base = await startBase("op1", { domain: DOMAIN, places });
  const url = base.url.replace(/^http/, "ws");
  client = new FoxgloveClient({ ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
  client.on("advertise", (list) => list.forEach((c) => channels.set(c.id, c)));
  client.on("advertiseServices", (list) => list.forEach((s) => services.set(s.name, s)));
  client.on("serviceCallResponse", (r) => responses.set(r.callId, JSON.parse(decoder.decode(r.data))));
  client.on("serviceCallFailure", (r) => responses.set(r.callId, { failure: r.message }));
});

after(() => {
  client?.close();
  stopAll();
});

test("the server lists every channel with a JSON schema, and the command service", async () => {
  await waitFor("r1's camera channel", () => [...channels.values()].some((c) => c.topic === "/r1/camera"), 20000);
  const topics = Object.fromEntries([...channels.values()].map((c) => [c.topic, c.schemaName]));
  assert.deepEqual(topics, {
    [Topic.fleet]: "cairn.FleetState",
    [Topic.tf]: "foxglove.FrameTransforms",
    [Topic.robots]: "foxglove.SceneUpdate",
    [Topic.paths]: "foxglove.SceneUpdate",
    [Topic.staircases]: "foxglove.SceneUpdate",
    [Topic.places]: "foxglove.SceneUpdate",
    [Topic.fleetMap]: "foxglove.SceneUpdate",
    [Topic.events]: "foxglove.Log",
    [Topic.commands]: "cairn.CommandTable",
    "/r1/camera": "foxglove.CompressedImage",
  });
  for (const c of channels.values()) {
    assert.equal(c.encoding, "json", c.topic);
    assert.equal(c.schemaEncoding, "jsonschema", c.topic);
  }
  assert.ok(services.has(Topic.commandService), [...services.keys()].join(", "));
  // Every command the GUI sends, and a console line, match the service's request schema.
  const validate = new Ajv({ strict: false }).compile(JSON.parse(services.get(Topic.commandService).requestSchema));
  const requests = [Command.requestControl("r1"), Command.mode("r1", "manual"), Command.goto("r1", 1.5, -2),
    Command.goto("r1", 1, 2, 3.2), Command.convoy(["r1", "r2", "r3"]), Command.peel("r2", 3, 4),
    Command.yieldFor("r2", "r1"), Command.restart("r1", "perception"), Command.stopAll(), { command: "robots" }];
  for (const request of requests) assert.ok(validate(request), `${JSON.stringify(request)}: ${JSON.stringify(validate.errors)}`);
  assert.ok(!validate({ name: "goto", robot: "r1", line: "goto r1 1 2" }), "a field of neither form");
});

test("a subscription to each channel delivers a message that decodes and matches its schema", async () => {
  const ajv = new Ajv({ strict: false, allErrors: true });
  const validators = new Map([...channels.values()].map((c) => [c.id, ajv.compile(JSON.parse(c.schema))]));
  const bySubscription = new Map();
  const eventMessages = [];
  client.on("message", ({ subscriptionId, data }) => {
    const channel = bySubscription.get(subscriptionId);
    if (firstMessage.has(channel.topic) && channel.topic !== "/events") return;
    const msg = JSON.parse(decoder.decode(data));
    if (channel.topic === "/events") eventMessages.push(msg.message);
    if (firstMessage.has(channel.topic)) return;
    const validate = validators.get(channel.id);
    assert.ok(validate(msg), `${channel.topic}: ${ajv.errorsText(validate.errors)}`);
    firstMessage.set(channel.topic, msg);
  });
  for (const c of channels.values()) bySubscription.set(client.subscribe(c.id), c);
  await waitFor("a message on every channel", () => firstMessage.size === channels.size, 60000).catch((e) => {
    const missing = [...channels.values()].map((c) => c.topic).filter((t) => !firstMessage.has(t));
    throw new Error(`${e.message}: none on ${missing.join(", ")}`);
  });

  const fleet = firstMessage.get("/fleet");
  assert.equal(fleet.base_id, "op1");
  assert.equal(fleet.robots[0].id, "r1");
  // A free idle robot: take its lock, ask it to get out of the way (its policy decides), or stop it.
  assert.deepEqual(fleet.robots[0].valid_actions, ["request-control", "yield", "stop"]);
  const tf = firstMessage.get("/tf").transforms[0];
  assert.equal(tf.parent_frame_id, "map");
  assert.equal(tf.child_frame_id, "r1");
  assert.ok(Math.abs(tf.translation.x - 46.5) < 0.5, JSON.stringify(tf.translation));
  const image = firstMessage.get("/r1/camera");
  assert.equal(image.format, "jpeg");
  const jpeg = Buffer.from(image.data, "base64");
  assert.deepEqual([...jpeg.subarray(0, 2)], [0xff, 0xd8], "a JPEG starts with SOI");
  assert.ok(firstMessage.get("/fleet_map").entities.some((e) => e.id.startsWith("map/") && e.cubes.length > 0));
  // The places file's places, a labelled post each.
  const junction = firstMessage.get("/places").entities.find((e) => e.id === "place/junction");
  assert.ok(junction, JSON.stringify(firstMessage.get("/places").entities.map((e) => e.id)));
  assert.equal(junction.texts[0].text, "junction");
  assert.deepEqual(junction.lines[0].points[0], { x: 30, y: 20, z: 0 });
  assert.ok(firstMessage.get("/robots").entities.some((e) => e.id === "robot/r1"));
  const stairs = firstMessage.get("/staircases").entities;
  assert.ok(stairs.length > 0 && stairs[0].cubes.length >= 3, "a staircase drawn as steps");
  // The robot's arrival (what it offers) and the staircase it found, in either order (both come within a tick).
  await waitFor("a joined event", () => eventMessages.some((m) => /^r1 joined: .*sensors lidar camera, map 0\.10 m, link loopback$/.test(m)), 20000);
  await waitFor("a staircase event", () => eventMessages.some((m) => /staircase/.test(m)), 20000);
});

/** Calls /cairn/command with `request` (a wire.ts CommandRequest, or {command: LINE}); the decoded answer. */
async function command(request) {
  const callId = Math.floor(Math.random() * 1e9);
  client.sendServiceCallRequest({
    serviceId: services.get(Topic.commandService).id, callId, encoding: "json",
    data: new TextEncoder().encode(JSON.stringify(request)),
  });
  return waitFor(`the answer to ${JSON.stringify(request)}`, () => responses.get(callId), 10000);
}

/** The CLI's --json answer to `line` from a one-shot cairn_base with another base id. */
function cli(line) {
  const run = spawnSync(join(BUILD, "basestation/cairn_base"),
    ["--base-id", "cli1", "--domain", String(DOMAIN), "--json", "--", ...line.split(" ")], { encoding: "utf8", timeout: 30000 });
  const lines = run.stdout.trim().split("\n").filter((l) => l.startsWith("{")).map((l) => JSON.parse(l));
  return lines.find((l) => l.command !== undefined) ?? { stdout: run.stdout, stderr: run.stderr };
}

test("the command table reaches the GUI, and every command the GUI sends fits it", async () => {
  const table = new Map(firstMessage.get(Topic.commands).commands.map((c) => [c.name, c]));
  assert.ok(table.size >= 30, `${table.size} commands`);
  assert.match(table.get("goto").usage, /^goto R POINT/);
  const sent = [Command.requestControl("r1"), Command.release("r1"), Command.stop("r1"), Command.stopAll(),
    Command.mode("r1", "manual"), Command.goto("r1", 1, 2), Command.goto("r1", 1, 2, 3), Command.home("r1"),
    Command.explore("r1"), Command.convoy(["r1", "r2", "r3"]), Command.convoyStop("r1"), Command.peel("r2", 1, 2),
    Command.yieldFor("r2", "r1"), Command.restart("r1", "perception")];
  for (const request of sent) assert.equal(checkAgainstTable(request, table), "", JSON.stringify(request));
  assert.match(checkAgainstTable({ name: "mode", robot: "r1" }, table), /usage: mode R MODE/);
  assert.match(checkAgainstTable({ name: "gotoo", robot: "r1" }, table), /not one of cairn_base's commands/);
});

test("the command service has the CLI's semantics: the same refusal and reason", async () => {
  const viaGui = await command(Command.mode("r1", "manual"));
  assert.equal(viaGui.ok, false);
  assert.equal(viaGui.result, "refused");
  const viaCli = cli("mode r1 manual");
  assert.equal(viaCli.result, "refused", JSON.stringify(viaCli));
  assert.equal(viaGui.reason.replaceAll("op1", "BASE"), viaCli.reason.replaceAll("cli1", "BASE"));

  // A console line has the same answer as the structured command it spells.
  const asLine = await command({ command: commandText(Command.mode("r1", "manual")) });
  const answer = (a) => ({ ok: a.ok, result: a.result, reason: a.reason, command: a.command, robot: a.robot });
  assert.deepEqual(answer(asLine), answer(viaGui));

  const bad = await command({ name: "goto", robot: "r1", args: ["nowhere-known"] });
  assert.equal(bad.ok, false);
  assert.equal(bad.result, cli("goto r1 nowhere-known").result);

  // A malformed request is refused before it runs, naming the field and the value.
  const malformed = await command({ name: "goto", robot: "r1", args: [1, null] });
  assert.match(malformed.failure ?? "", /args\[1\] null must be a string or a number/, JSON.stringify(malformed));
  assert.match((await command({ name: "goto", robot: "r1", args: [1, 2, "--wait"] })).failure ?? "", /options go in "options"/);

  const held = await command(Command.requestControl("r1"));
  assert.equal(held.ok, true, JSON.stringify(held));
  const blocked = cli("request-control r1");
  assert.equal(blocked.result, "refused");
  assert.match(blocked.reason, /op1/);

  const stream = await command({ name: "teleop", robot: "r1", args: [0.5, 0, 2] });
  assert.equal(stream.result, "invalid");
  assert.match(stream.reason, /\/cairn\/teleop/);
});

test("client publish on /cairn/teleop: malformed twists are dropped and move nothing, a valid one drives", async () => {
  let x = firstMessage.get("/tf").transforms[0].translation.x;
  client.on("message", ({ data }) => {
    const t = JSON.parse(decoder.decode(data)).transforms?.find((tr) => tr.child_frame_id === "r1");
    if (t) x = t.translation.x;
  });
  assert.equal((await command(Command.mode("r1", "manual"))).ok, true);
  const teleop = client.advertise({ topic: "/cairn/teleop", encoding: "json", schemaName: "cairn.Teleop" });
  const send = (text) => client.sendMessage(teleop, new TextEncoder().encode(text));
  const x0 = x;
  for (let i = 0; i < 10; i++) {
    send("{");
    send(JSON.stringify({ robot_id: "r1", linear_x_mps: "fast", angular_z_radps: 0 }));
    send(JSON.stringify({ robot_id: "r1", linear_x_mps: Infinity, angular_z_radps: 0 })); // null in JSON
    send(JSON.stringify({ linear_x_mps: 0.5, angular_z_radps: 0 }));
    await new Promise((r) => setTimeout(r, 100));
  }
  await new Promise((r) => setTimeout(r, 500));
  assert.ok(Math.abs(x - x0) < 0.02, `r1 moved from ${x0} to ${x} on malformed twists`);
  for (let i = 0; i < 10; i++) {
    send(JSON.stringify({ robot_id: "r1", linear_x_mps: -0.3, angular_z_radps: 0 })); // back, away from the stairs
    await new Promise((r) => setTimeout(r, 100));
  }
  await waitFor("r1 backing up", () => x0 - x > 0.1, 3000);
  assert.equal((await command(Command.release("r1"))).ok, true);
});
