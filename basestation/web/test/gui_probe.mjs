// Probes a GUI server from outside: GET / returns the web app, and a Foxglove protocol client sees ROBOT online
// on /fleet. Exits 0 when both hold within TIMEOUT_S, 1 (saying what failed) otherwise.
//   node gui_probe.mjs URL ROBOT [TIMEOUT_S]
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const [url, robot, timeoutS = "60"] = process.argv.slice(2);
const deadline = Date.now() + Number(timeoutS) * 1000;
const fail = (why) => {
  console.error(`gui_probe: ${why}`);
  process.exit(1);
};
setTimeout(() => fail(`no /fleet message with ${robot} online from ${url} within ${timeoutS} s`), Number(timeoutS) * 1000);

let page = "";
while (Date.now() < deadline) {
  try {
    const response = await fetch(url);
    page = await response.text();
    if (response.ok) break;
  } catch {
    // not listening yet
  }
  await new Promise((r) => setTimeout(r, 500));
}
if (!page.includes("<title>Cairn")) fail(`GET ${url} did not return the web app: ${page.slice(0, 200)}`);
const client = new FoxgloveClient({ ws: new WebSocket(url.replace(/^http/, "ws"), [FoxgloveClient.SUPPORTED_SUBPROTOCOL]) });
client.on("advertise", (channels) => channels.filter((c) => c.topic === "/fleet").forEach((c) => client.subscribe(c.id)));
client.on("message", ({ data }) => {
  const fleet = JSON.parse(new TextDecoder().decode(data));
  const r = fleet.robots?.find((x) => x.id === robot);
  if (r?.online) {
    console.log(`gui_probe: ${url} serves the web app; /fleet from ${fleet.base_id} shows ${robot} online (${r.mode})`);
    process.exit(0);
  }
});
