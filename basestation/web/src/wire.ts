// The GUI's wire messages, in one place: what cairn_base's GUI bridge (basestation/src/gui_bridge.cpp) sends
// on each Foxglove WebSocket channel, and what the GUI sends back (structured commands on the /cairn/command
// service, twists on /cairn/teleop). The GUI and its tests (test/*.mjs import the built wire.mjs) both use it.
// Units are in the field names (_m, _mps, _radps, _s, _ms, _kbps); positions are in the map frame.

/** The channels cairn_base advertises (JSON encoding) and the client channel the GUI publishes. */
export const Topic = {
  fleet: "/fleet", // FleetMessage, 10 Hz
  events: "/events", // EventMessage (a new subscriber is first sent the recent ones)
  commands: "/cairn/commands", // CommandTableMessage, once to each subscriber
  fleetMap: "/fleet_map", // foxglove.SceneUpdate: map voxels by chunk
  paths: "/paths", // foxglove.SceneUpdate: global paths and goals
  staircases: "/staircases", // foxglove.SceneUpdate: detected staircases
  places: "/places", // foxglove.SceneUpdate: named places, a post and a text each
  robots: "/robots", // foxglove.SceneUpdate: robot bodies (the GUI draws its own)
  tf: "/tf", // foxglove.FrameTransforms
  teleop: "/cairn/teleop", // TeleopMessage, client -> cairn_base
  commandService: "/cairn/command", // CommandRequest -> CommandResult
} as const;

/** `/<robot>/camera`: the robot's camera, foxglove.CompressedImage (base64 data). */
export const cameraTopic = (robotId: string): string => `/${robotId}/camera`;

/** One component of a robot's agent (cairn_base health R). */
export interface Component {
  name: string;
  state: string; // active | down | ...
  loop_rate_hz: number;
  target_rate_hz: number;
  cpu_percent: number;
  restarts: number;
  restart_in_s: number;
  last_error: string;
  degraded: boolean; // beating, but under half its rate for a few seconds: slow, not hung
}

/** A robot's radio link as this basestation measures it (cairn_base links R). */
export interface Link {
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
}

/** Get-out-of-the-way (cairn_base's `status --json` yield block): as the robot asked (moving_aside, aside,
 *  returning, refused) or as the robot asking (asking, blocked); `for`: the robot whose route passes it now. */
export interface YieldRecord {
  state: string;
  peer: string;
  reason: string;
  for: string;
}

/** A convoy follower's record (`status --json` convoy block): the robots ahead of it, nearest first, the
 *  leader last (empty: not following). */
export interface Convoy {
  state: string; // none | following | holding | lost | blocked
  ahead: string[];
  reason: string;
  gap_m?: number;
}

/** The robot's exploration record (`status --json` exploration block). */
export interface Exploration {
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
  target?: Point;
}

export interface Point {
  x_m: number;
  y_m: number;
  z_m: number;
}

/** One robot as this basestation sees it, with the actions valid for this basestation now. */
export interface Robot {
  id: string;
  platform: string;
  color: string; // "#rrggbb": the robot's colour in every view (3D body, label, paths, lists)
  online: boolean;
  lost_reason: string;
  heard_s_ago: number;
  link?: Link;
  components?: Component[];
  mode: string;
  holder: string;
  holder_alive: boolean;
  you_hold: boolean;
  nav_status: string;
  nav_reason: string;
  goal?: Point;
  nav_goal_id: number;
  distance_left_m: number;
  eta_s: number;
  local_planner_status: string;
  pose?: Point & { yaw_rad: number };
  speed_mps: number;
  in_contact: boolean;
  /** Action names: request-control, release, handover, goto, teleop, explore, home, convoy, peel, yield,
   *  convoy-stop, "mode A|B|C" (the modes the robot's tree allows now), and "grant B" / "deny B" while
   *  basestation B's request for the lock waits for this one's answer. */
  valid_actions: string[];
  /** A basestation waiting for the holder to hand the lock over ("" none), and the seconds left. */
  control_request?: { from: string; left_s: number };
  /** The holder's last answer or handover (a grant, a denial, an expiry), counted. */
  handover?: { count: number; outcome: string };
  max_speed_mps: number;
  max_reverse_speed_mps: number;
  max_yaw_rate_radps: number;
  camera_age_s: number;
  control_period_max_ms: number;
  exploration?: Exploration;
  convoy?: Convoy;
  yield?: YieldRecord;
}

/** `/fleet`: every robot this basestation knows. */
export interface FleetMessage {
  base_id: string;
  robots: Robot[];
}

/** `/events`: one operator event (foxglove.Log's fields: level 3 and above are warnings). */
export interface EventMessage {
  timestamp: { sec: number; nsec: number };
  level: number;
  name: string; // the event's kind: joined, lost, arrived, component_failed, ...
  message: string;
}

/** `/<robot>/camera`: one compressed frame. */
export interface CameraMessage {
  format: string; // jpeg | png
  data: string; // base64
}

/** `/cairn/teleop`: one twist in the robot's body frame (forward m/s, yaw rate rad/s, optional sideways m/s). */
export interface TeleopMessage {
  robot_id: string;
  linear_x_mps: number;
  angular_z_radps: number;
  linear_y_mps?: number;
}

/** One command of cairn_base's console (its command table: what `help` lists). */
export interface CommandSpec {
  name: string;
  usage: string; // synopsis, name first: "goto R POINT [TOL] [--z Z_M] [--wait [TIMEOUT_S]]"
  help: string;
  min_args: number; // words after the name
  max_args: number; // -1: no bound
}

/** `/cairn/commands`: the command table. */
export interface CommandTableMessage {
  commands: CommandSpec[];
}

/** The words `request` puts after the command's name (what the table's argument counts count). */
export function argumentWords(request: CommandRequest): number {
  const options = Object.values(request.options ?? {});
  return (
    (request.robot === undefined ? 0 : 1) +
    (request.args?.length ?? 0) +
    options.length +
    options.filter((v) => v !== true).length
  );
}

/** Why `request` does not fit the command table (unknown name, argument count outside the command's), or ""
 *  when it does. */
export function checkAgainstTable(request: CommandRequest, table: ReadonlyMap<string, CommandSpec>): string {
  const spec = table.get(request.name);
  if (!spec) return `'${request.name}' is not one of cairn_base's commands`;
  const words = argumentWords(request);
  if (words < spec.min_args || (spec.max_args >= 0 && words > spec.max_args)) {
    return `${commandText(request)}: usage: ${spec.usage}`;
  }
  return "";
}

/** A command of cairn_base's table, as words: the command's name, the robot it addresses (when it takes one),
 *  its further arguments and its options (`{ z: 1.2 }` is `--z 1.2`; `true` is a bare flag). The bridge checks
 *  each field and runs it as the CLI runs the same words: no command text is composed or parsed again. */
export interface CommandRequest {
  name: string;
  robot?: string;
  args?: (string | number)[];
  options?: Record<string, string | number | true>;
}

/** The answer to a command, as the CLI prints it with --json (plus exit_code and the lines printed). */
export interface CommandResult {
  ok: boolean;
  result?: string; // accepted | refused | failed | timed out | invalid
  reason?: string;
  command?: string;
  robot?: string;
  exit_code?: number;
  valid_actions?: string[];
  [key: string]: unknown;
}

/** The commands the GUI sends. Coordinates are in the map frame, m. */
export const Command = {
  requestControl: (robot: string): CommandRequest => ({ name: "request-control", robot }),
  release: (robot: string): CommandRequest => ({ name: "release", robot }),
  grant: (robot: string, base: string): CommandRequest => ({ name: "grant", robot, args: [base] }),
  deny: (robot: string, base: string): CommandRequest => ({ name: "deny", robot, args: [base] }),
  stop: (robot: string): CommandRequest => ({ name: "stop", robot }),
  stopAll: (): CommandRequest => ({ name: "stop", robot: "all" }),
  mode: (robot: string, mode: string): CommandRequest => ({ name: "mode", robot, args: [mode] }),
  /** `z_m` names the level of a multi-level map (another floor); left out: the robot's own level. */
  goto: (robot: string, x_m: number, y_m: number, z_m?: number): CommandRequest => ({
    name: "goto",
    robot,
    args: [x_m, y_m],
    ...(z_m === undefined ? {} : { options: { z: z_m } }),
  }),
  home: (robot: string): CommandRequest => ({ name: "home", robot }),
  explore: (robot: string): CommandRequest => ({ name: "explore", robot }),
  /** The leader first, then the followers in order. */
  convoy: (order: string[]): CommandRequest => ({ name: "convoy", robot: order[0], args: order.slice(1) }),
  convoyStop: (leader: string): CommandRequest => ({ name: "convoy-stop", robot: leader }),
  peel: (robot: string, x_m: number, y_m: number): CommandRequest => ({ name: "peel", robot, args: [x_m, y_m] }),
  yieldFor: (robot: string, forRobot: string): CommandRequest => ({ name: "yield", robot, args: ["for", forRobot] }),
  restart: (robot: string, component: string): CommandRequest => ({ name: "restart", robot, args: [component] }),
} as const;

/** The request as the CLI line it stands for (for notifications and logs only: it is never sent). */
export function commandText(request: CommandRequest): string {
  const words: string[] = [request.name];
  if (request.robot !== undefined) words.push(request.robot);
  for (const a of request.args ?? []) words.push(typeof a === "number" ? formatNumber(a) : a);
  for (const [key, value] of Object.entries(request.options ?? {})) {
    words.push(`--${key}`);
    if (value !== true) words.push(typeof value === "number" ? formatNumber(value) : value);
  }
  return words.join(" ");
}

function formatNumber(v: number): string {
  return Number.isInteger(v) ? String(v) : v.toFixed(2);
}
