// Measures a linksim link with UDP (tests/linksim): one side sends numbered 1000-byte datagrams at a rate,
// the other counts what arrives.
//   node udp_probe.mjs send ADDRESS PORT SECONDS RATE_KBIT    prints "sent N"
//   node udp_probe.mjs recv PORT SECONDS                      prints "received N bytes B kbit_per_s R"
import dgram from "node:dgram";

const [mode, ...args] = process.argv.slice(2);
const kSize = 1000;
if (mode === "send") {
  const [address, port, seconds, rateKbit] = args.map((a, i) => (i === 0 ? a : Number(a)));
  const socket = dgram.createSocket("udp4");
  const perMs = (rateKbit * 1000) / 8 / kSize / 1000;
  const start = Date.now();
  let sent = 0;
  const timer = setInterval(() => {
    const due = Math.floor((Date.now() - start) * perMs);
    for (; sent < due; sent++) {
      const b = Buffer.alloc(kSize);
      b.writeUInt32BE(sent, 0);
      socket.send(b, port, address);
    }
    if (Date.now() - start >= seconds * 1000) {
      clearInterval(timer);
      setTimeout(() => { console.log(`sent ${sent}`); socket.close(); }, 200);
    }
  }, 5);
} else if (mode === "recv") {
  const [port, seconds] = args.map(Number);
  const socket = dgram.createSocket("udp4");
  let count = 0, first = 0, last = 0;
  socket.on("message", () => {
    const now = Date.now();
    if (count === 0) first = now;
    last = now;
    count++;
  });
  socket.bind(port);
  setTimeout(() => {
    const kbps = count > 1 ? ((count - 1) * kSize * 8) / (last - first) : 0;
    console.log(`received ${count} bytes ${count * kSize} kbit_per_s ${kbps.toFixed(0)}`);
    socket.close();
  }, seconds * 1000);
} else {
  console.error("usage: udp_probe.mjs send ADDRESS PORT SECONDS RATE_KBIT | recv PORT SECONDS");
  process.exit(2);
}
