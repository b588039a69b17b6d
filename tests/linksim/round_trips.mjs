// Summarises command round trips from a `cairn_base --json` script's output (one JSON object per line):
//   node round_trips.mjs FILE SKIP
// Takes the request-control answers after the first SKIP of them and prints one line:
//   ACCEPTED ANSWERED P50_MS P99_MS MAX_MS DROVE GOTO_MAX_MS
// (DROVE: true when every goto was accepted; GOTO_MAX_MS: the slowest goto's round trip). -1 for a figure with
// no accepted command.
import { readFileSync } from "node:fs";

const [file, skipText = "0"] = process.argv.slice(2);
const all = readFileSync(file, "utf8")
  .split("\n")
  .filter((l) => l.startsWith("{"))
  .map((l) => JSON.parse(l));
const commands = all.filter((o) => o.command === "request-control").slice(Number(skipText));
const gotos = all.filter((o) => o.command === "goto" && !o.progress);
const drove = gotos.length > 0 && gotos.every((o) => o.ok === true);
const ok = commands.filter((o) => o.ok === true && o.result === "accepted");
const t = ok.map((o) => o.round_trip_ms).sort((a, b) => a - b);
const q = (p) => (t.length ? t[Math.min(t.length - 1, Math.floor(p * t.length))].toFixed(1) : "-1");
const gotoWorst = gotos.length ? Math.max(...gotos.map((o) => o.round_trip_ms ?? -1)).toFixed(1) : "-1";
console.log(`${ok.length} ${commands.length} ${q(0.5)} ${q(0.99)} ${t.length ? t[t.length - 1].toFixed(1) : "-1"} ${drove} ${gotoWorst}`);
