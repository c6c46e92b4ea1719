// What every script here starts with: a Foxglove WebSocket protocol client
// (@foxglove/ws-protocol) connected to `url`, failing the script on a client error or
// when `result` is not finished within `ms`; `finish()` prints `result` and exits.
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;

export function connect(url, result, ms = 20000) {
  const timer = setTimeout(() => {
    console.error(`timed out; so far: ${JSON.stringify(result)}`);
    process.exit(1);
  }, ms);
  const client = new FoxgloveClient({
    ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]),
  });
  client.on("error", (err) => {
    console.error(`client error: ${err}`);
    process.exit(1);
  });
  const finish = () => {
    clearTimeout(timer);
    client.close();
    console.log(JSON.stringify(result));
    process.exit(0);
  };
  return { client, finish };
}
