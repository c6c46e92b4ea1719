// Calls a service through the Foxglove WebSocket protocol (@foxglove/ws-protocol): once in
// CDR (request written and response read with the advertised ros2msg schemas), once in
// JSON, once with bytes that are no request. Prints the answers as JSON.
// Usage: node call.mjs ws://127.0.0.1:PORT SERVICE 'REQUEST_JSON'
import rosmsg from "@foxglove/rosmsg";
import serialization from "@foxglove/rosmsg2-serialization";
import { connect } from "./connect.mjs";

const { parse } = rosmsg;
const { MessageReader, MessageWriter } = serialization;
const [url, name, requestText] = process.argv.slice(2);
const request = JSON.parse(requestText);
const result = {};
const { client, finish } = connect(url, result);
let service;
let reader;
client.on("serverInfo", (info) => (result.capabilities = info.capabilities));
client.on("advertiseServices", (list) => {
  service = service ?? list.find((s) => s.name === name);
  if (service === undefined || result.type !== undefined) return;
  result.type = service.type;
  result.requestSchemaName = service.request.schemaName;
  const writer = new MessageWriter(parse(service.request.schema, { ros2: true }));
  reader = new MessageReader(parse(service.response.schema, { ros2: true }));
  const send = (callId, encoding, data) =>
    client.sendServiceCallRequest({ serviceId: service.id, callId, encoding, data });
  send(1, "cdr", writer.writeMessage(request));
  send(2, "json", new TextEncoder().encode(JSON.stringify(request)));
  send(3, "cdr", new Uint8Array([0, 1, 0, 0]));
});
client.on("serviceCallResponse", (r) => {
  const bytes = new Uint8Array(r.data.buffer, r.data.byteOffset, r.data.byteLength);
  result[r.callId] =
    r.encoding === "json" ? JSON.parse(new TextDecoder().decode(bytes)) : reader.readMessage(bytes);
  done();
});
client.on("serviceCallFailure", (f) => {
  result[f.callId] = { failure: f.message };
  done();
});
function done() {
  if ([1, 2, 3].some((id) => result[id] === undefined)) return;
  finish();
}
