// The GUI's link to cairn_base: the Foxglove WebSocket protocol (@foxglove/ws-protocol's client), JSON
// messages on the channels wire.ts lists, the /cairn/command service and the /cairn/teleop client channel.
import { FoxgloveClient } from "@foxglove/ws-protocol";
import type { Channel, Service } from "@foxglove/ws-protocol";
import { Topic, type CommandRequest, type CommandResult, type TeleopMessage } from "./wire";

export type Listener = (topic: string, message: any, receivedNs: bigint) => void;

export class CairnLink {
  private client?: FoxgloveClient;
  private channels = new Map<number, Channel>();
  private subscriptions = new Map<number, string>(); // subscription id -> topic
  private services = new Map<string, Service>();
  private nextCallId = 1;
  private pending = new Map<number, { resolve: (r: CommandResult) => void; timer: number }>();
  private teleopChannel?: number;
  private decoder = new TextDecoder();
  private encoder = new TextEncoder();
  connected = false;
  bytesReceived = 0;
  onState: (connected: boolean, text: string) => void = () => {};

  /** Each message of a wanted channel, decoded from JSON (wire.ts types it by topic). */
  onMessage: Listener = () => {};

  constructor(private url: string, private wanted: (topic: string) => boolean) {}

  connect(): void {
    const ws = new WebSocket(this.url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
    const client = new FoxgloveClient({ ws });
    this.client = client;
    this.channels.clear();
    this.subscriptions.clear();
    this.services.clear();
    this.teleopChannel = undefined;
    client.on("open", () => {
      this.connected = true;
      this.onState(true, "connected");
    });
    client.on("close", () => {
      this.connected = false;
      this.onState(false, "disconnected: reconnecting");
      for (const [, p] of this.pending) {
        window.clearTimeout(p.timer);
        p.resolve({ ok: false, result: "failed", reason: "the connection to cairn_base closed" });
      }
      this.pending.clear();
      window.setTimeout(() => this.connect(), 1000);
    });
    client.on("error", () => this.onState(false, "connection error"));
    client.on("serverInfo", (info) => {
      this.onState(true, info.name);
      if (info.capabilities.includes("clientPublish")) {
        this.teleopChannel = client.advertise({ topic: Topic.teleop, encoding: "json", schemaName: "cairn.Teleop" });
      }
    });
    client.on("advertise", (channels) => {
      for (const ch of channels) {
        this.channels.set(ch.id, ch);
        if (this.wanted(ch.topic)) this.subscriptions.set(client.subscribe(ch.id), ch.topic);
      }
    });
    client.on("unadvertise", (ids) => {
      for (const id of ids) this.channels.delete(id);
    });
    client.on("advertiseServices", (services) => {
      for (const s of services) this.services.set(s.name, s);
    });
    client.on("message", (event) => {
      const topic = this.subscriptions.get(event.subscriptionId);
      if (topic === undefined) return;
      this.bytesReceived += event.data.byteLength;
      let message: any;
      try {
        message = JSON.parse(this.decoder.decode(event.data));
      } catch {
        return;
      }
      this.onMessage(topic, message, event.timestamp);
    });
    client.on("serviceCallResponse", (response) => {
      const p = this.pending.get(response.callId);
      if (!p) return;
      this.pending.delete(response.callId);
      window.clearTimeout(p.timer);
      try {
        p.resolve(JSON.parse(this.decoder.decode(response.data)) as CommandResult);
      } catch {
        p.resolve({ ok: false, result: "failed", reason: "cairn_base answered with something that is not JSON" });
      }
    });
    client.on("serviceCallFailure", (failure) => {
      const p = this.pending.get(failure.callId);
      if (!p) return;
      this.pending.delete(failure.callId);
      window.clearTimeout(p.timer);
      p.resolve({ ok: false, result: "failed", reason: failure.message });
    });
  }

  /** Runs one cairn_base command (the CLI's semantics) and resolves with its --json result. */
  command(request: CommandRequest, timeoutMs = 15000): Promise<CommandResult> {
    const service = this.services.get(Topic.commandService);
    if (!this.client || !this.connected || !service) {
      return Promise.resolve({ ok: false, result: "failed", reason: "not connected to cairn_base" });
    }
    const callId = this.nextCallId++;
    return new Promise((resolve) => {
      const timer = window.setTimeout(() => {
        this.pending.delete(callId);
        resolve({ ok: false, result: "timed out", reason: `no answer from cairn_base in ${timeoutMs / 1000} s` });
      }, timeoutMs);
      this.pending.set(callId, { resolve, timer });
      this.client!.sendServiceCallRequest({
        serviceId: service.id,
        callId,
        encoding: "json",
        data: new DataView(this.encoder.encode(JSON.stringify(request)).buffer),
      });
    });
  }

  /** One teleop twist (frame B of the robot): forward m/s, yaw rate rad/s. false when it cannot be sent. */
  teleop(robotId: string, linearX: number, angularZ: number): boolean {
    if (!this.client || !this.connected || this.teleopChannel === undefined) return false;
    const msg: TeleopMessage = { robot_id: robotId, linear_x_mps: linearX, angular_z_radps: angularZ };
    this.client.sendMessage(this.teleopChannel, this.encoder.encode(JSON.stringify(msg)));
    return true;
  }
}
