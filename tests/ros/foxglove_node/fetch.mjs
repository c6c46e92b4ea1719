// Fetches assets through the Foxglove WebSocket protocol (@foxglove/ws-protocol), as the
// 3D panel does for a URDF's package:// meshes. Prints {uri: {status, bytes, error}}.
// Usage: node fetch.mjs ws://127.0.0.1:PORT URI...
import { connect } from "./connect.mjs";

const [url, ...uris] = process.argv.slice(2);
const result = {};
const { client, finish } = connect(url, result);
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
  if (uris.every((u) => result[u] !== undefined)) finish();
});
