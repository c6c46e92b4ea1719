// Fetches assets through the Foxglove WebSocket protocol (@foxglove/ws-protocol), as the
// 3D panel does for a URDF's package:// meshes. Prints {uri: {status, bytes, error}}.
// Usage: node fetch.mjs ws://127.0.0.1:PORT URI...
import wsProtocol from "@foxglove/ws-protocol";
import WebSocket from "ws";

const { FoxgloveClient } = wsProtocol;
const [url, ...uris] = process.argv.slice(2);
const result = {};
const timer = setTimeout(() => {
  console.error(`timed out; so far: ${JSON.stringify(result)}`);
  process.exit(1);
}, 20000);
const client = new FoxgloveClient({
  ws: new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]),
});
client.on("error", (err) => {
  console.error(`client error: ${err}`);
  process.exit(1);
});
client.on("serverInfo", (info) => {
  result.capabilities = info.capabilities;
  uris.forEach((uri, i) => client.fetchAsset(uri, i + 1));
});
client.on("fetchAssetResponse", (r) => {
  const uri = uris[r.requestId - 1];
  result[uri] =
    r.status === 0
      ? { status: "ok", bytes: r.data.byteLength }
      : { status: "error", error: r.error };
  if (uris.every((u) => result[u] !== undefined)) {
    clearTimeout(timer);
    client.close();
    console.log(JSON.stringify(result));
    process.exit(0);
  }
});
