// The GUI's state: what cairn_base last sent (the fleet, events, camera frames), what the operator is doing
// (the selected robot, the tab, a goal or convoy being put together, driving), and the two objects everything
// else draws on or sends through: the 3D scene and the link to cairn_base. Panels (panels.ts) render it; input
// (input.ts) changes it; main.ts feeds it from the link.
import { CairnLink } from "./client";
import { FleetScene } from "./scene";
import { Topic, type CommandResult, type CommandSpec, type Robot } from "./wire";

export const $ = <T extends HTMLElement>(id: string) => document.getElementById(id) as T;
export const params = new URLSearchParams(location.search);

/** One line of the Events tab. */
export interface EventEntry {
  time: Date;
  level: number;
  kind: string;
  message: string;
}

/** A goal tapped in the 3D view, waiting for the operator's confirmation: map frame, m; `z` names another
 *  level. */
export interface PendingGoal {
  x: number;
  y: number;
  z?: number;
}

/** A goal this page sent: map frame, m; when (page clock, ms). */
export interface SentGoal {
  x: number;
  y: number;
  z: number;
  sentMs: number;
}

/** The teleop twist being streamed, and where it comes from. */
export interface DriveState {
  vx: number;
  wz: number;
  active: boolean;
  source: string;
  stale: boolean;
  sent: number;
}

export const state = {
  baseId: "",
  robots: [] as Robot[],
  selected: location.hash.startsWith("#robot=") ? decodeURIComponent(location.hash.slice(7)) : "",
  tab: "fleet",
  events: [] as EventEntry[],
  toasts: [] as { text: string; shownMs: number; eventMs: number }[],
  lastResult: undefined as CommandResult | undefined,
  pickingGoal: false,
  goalVerb: "goto" as "goto" | "peel", // what a picked goal is sent as
  pendingGoal: undefined as PendingGoal | undefined,
  sentGoals: new Map<string, SentGoal>(), // goals sent from this page, by robot, drawn until reached or dropped
  convoyOrder: undefined as string[] | undefined, // a convoy being put together: the leader, then followers
  convoyNote: "",
  driving: false,
  drive: { vx: 0, wz: 0, active: false, source: "", stale: false, sent: 0 } as DriveState,
  cameraUrls: new Map<string, { url: string; stamp: number }>(),
  statusText: "connecting",
  commandTable: new Map<string, CommandSpec>(), // cairn_base's commands (/cairn/commands), by name
  ceilingAuto: true, // hide map voxels 1.6 m above the highest robot (tunnel roofs, upper floors)
};

export const scene = new FleetScene($("view"));

/** The link to the cairn_base that served this page (every channel but those the GUI draws itself). */
export const link = new CairnLink(
  `${location.protocol === "https:" ? "wss" : "ws"}://${location.host}/`,
  (topic) => topic.startsWith("/") && topic !== Topic.tf && topic !== Topic.robots,
);

export function selectedRobot(): Robot | undefined {
  return state.robots.find((r) => r.id === state.selected);
}
