// Decodes one CDR payload (encapsulation header included) as a ROS 2 message with Foxglove's own readers
// (@foxglove/rosmsg parses the .msg definitions, @foxglove/rosmsg2-serialization reads the CDR): an
// implementation that is not Cairn's, to check that a Cairn topic forwarded for ROS 2 tools reads as its
// generated .msg says, and writes back to the same bytes. Prints the message as one JSON line (64-bit integers
// as strings); exit 1 when the bytes differ.
// Usage: node decode_ros2_cdr.mjs MSG_DIR PACKAGE/msg/TYPE PAYLOAD_FILE
import fs from "node:fs";
import path from "node:path";
import { parse } from "@foxglove/rosmsg";
import { MessageReader, MessageWriter } from "@foxglove/rosmsg2-serialization";

const [msgDir, type, payloadFile] = process.argv.slice(2);
if (!msgDir || !type || !payloadFile) {
  console.error("usage: node decode_ros2_cdr.mjs MSG_DIR PACKAGE/msg/TYPE PAYLOAD_FILE");
  process.exit(2);
}
const [pkg, , root] = type.split("/");
// The root definition first, then every other message of the package as "MSG: pkg/Name" (the concatenated
// form ROS tools and MCAP files carry).
const names = fs.readdirSync(msgDir).filter((f) => f.endsWith(".msg")).map((f) => f.slice(0, -4));
let text = fs.readFileSync(path.join(msgDir, `${root}.msg`), "utf8");
for (const name of names) {
  if (name === root) continue;
  text += `\n================================================================================\nMSG: ${pkg}/${name}\n`;
  text += fs.readFileSync(path.join(msgDir, `${name}.msg`), "utf8");
}
const definitions = parse(text, { ros2: true });
const payload = fs.readFileSync(payloadFile);
const message = new MessageReader(definitions).readMessage(payload);
// Every byte accounted for: the message written back by Foxglove's writer is the payload, byte for byte (a
// definition with a field too few would read a prefix and leave bytes over).
// A payload may end in up to 3 zero bytes past the message: RTPS pads serialized data to a multiple of 4 (Fast
// DDS 2.9 does, without counting them in the encapsulation options as XTypes 1.3 would), and Foxglove's writer
// does not add them.
const written = Buffer.from(new MessageWriter(definitions).writeMessage(message));
const padding = payload.length - written.length;
const padded = padding >= 0 && padding < 4 && written.length % 4 !== 0 && (written.length + padding) % 4 === 0 &&
  payload.subarray(written.length).every((b) => b === 0);
if (Buffer.compare(written, payload.subarray(0, padded ? written.length : payload.length)) !== 0) {
  console.error(`decode_ros2_cdr: ${type} written back is ${written.length} bytes, not the payload's ${payload.length}`);
  process.exit(1);
}
console.log(JSON.stringify(message, (_, v) => (typeof v === "bigint" ? v.toString() : v)));
