// The Foxglove client's view of time (@foxglove/ws-protocol): the server's capabilities and
// the first Time messages it sends (ns since the clock's start, as text). Prints JSON.
// Usage: node time.mjs ws://127.0.0.1:PORT
import { connect } from "./connect.mjs";

const result = { times: [] };
const { client, finish } = connect(process.argv[2], result);
client.on("serverInfo", (info) => (result.capabilities = info.capabilities));
client.on("time", (message) => {
  result.times.push(String(message.timestamp));
  if (result.times.length === 3) finish();
});
