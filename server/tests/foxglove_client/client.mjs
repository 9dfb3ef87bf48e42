// Reads `cosim view` as Foxglove does: Foxglove's own client of its
// WebSocket protocol (@foxglove/ws-protocol) over the `ws` WebSocket, not
// code of ours. Usage: node client.mjs ws://HOST:PORT
// Prints "subscribed" once it has subscribed to every advertised channel,
// then, when the view closes the connection, one JSON line: the server
// info, the channels, messages per topic, each topic's last message (its
// time in ns as text, its JSON payload), the time messages, and errors.
// The package is CommonJS: its exports come as the default.
import protocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = protocol;

const url = process.argv[2];
const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const out = { serverInfo: null, channels: [], counts: {}, last: {}, times: 0, errors: [] };
const topics = new Map();
const decoder = new TextDecoder();

client.on("serverInfo", (info) => {
  out.serverInfo = info;
});
client.on("advertise", (channels) => {
  for (const c of channels) {
    out.channels.push({ topic: c.topic, schemaName: c.schemaName, encoding: c.encoding });
    topics.set(client.subscribe(c.id), c.topic);
  }
  console.log("subscribed");
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const topic = topics.get(subscriptionId);
  try {
    const msg = JSON.parse(decoder.decode(data));
    out.counts[topic] = (out.counts[topic] ?? 0) + 1;
    out.last[topic] = { timestamp: timestamp.toString(), msg };
  } catch (e) {
    out.errors.push(`${topic}: ${e}`);
  }
});
client.on("time", () => {
  out.times += 1;
});
client.on("error", (e) => out.errors.push(String(e)));
client.on("status", (s) => out.errors.push(`status: ${s.message}`));
ws.on("close", () => {
  console.log(JSON.stringify(out));
  process.exit(0);
});
