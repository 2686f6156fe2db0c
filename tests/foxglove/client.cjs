// A Foxglove WebSocket client for tests/daemon/lidarfused_foxglove_test.cpp, built on the
// packages Foxglove itself uses: @foxglove/ws-protocol (the protocol), @foxglove/rosmsg and
// @foxglove/rosmsg2-serialization (the channels' ros2msg schemas and their CDR), and
// @foxglove/cdr (the encapsulation header). Installed by tests/foxglove/install.sh; run with
// NODE_PATH=<build>/foxglove-client/node_modules.
//
//   node client.cjs URL MODE OUT [SECONDS]
//   record   subscribe to every channel, decode every message, and on SIGTERM (or after
//            SECONDS) write what was seen to OUT as JSON
//   stall    subscribe to every channel, then stop reading the socket (a stalled viewer)
//   count    subscribe to every channel and only count messages and bytes per topic (the
//            cost of the server alone, for bench/daemon_latency_bench.cpp --foxglove client)
//   refused  connect once and write the HTTP status the server answered with
// Each mode writes OUT.ready once it is subscribed (record, stall, count).
"use strict";
const fs = require("fs");
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const { parse } = require("@foxglove/rosmsg");
const { MessageReader } = require("@foxglove/rosmsg2-serialization");
const { CdrReader, EncapsulationKind } = require("@foxglove/cdr");
const { WebSocket } = require("ws");

const [url, mode, out, secondsText] = process.argv.slice(2);
const seconds = Number(secondsText || 120);

const seen = {
  mode,
  serverName: "",
  topics: [],
  schemaErrors: [],
  decodeErrors: [],
  encapsulations: [],
  messages: 0,
  clouds: 0,
  cloudPoints: 0,
  cloudBytes: 0,
  cloudFrame: "",
  cloudFields: [],
  cloudSizeErrors: 0,
  voxelClouds: 0,  // the thinned cloud (<ns>/points_voxel), kept apart from the full one
  voxelPoints: 0,
  sampledPoints: 0,
  finitePoints: 0,
  tf: [],        // [child, parent, stamp ns as text, x, y, z, qw, qx, qy, qz]
  tfStatic: 0,
  poses: 0,
  diagnostics: 0,
  lastPipeline: {},
  counted: {},   // count: topic -> [messages, bytes]
};

// Written beside OUT and renamed onto it, so that a reader waiting for OUT to exist never
// reads it half-written (seen: the refused client's OUT read empty on a loaded machine).
function finish() {
  fs.writeFileSync(`${out}.part`, JSON.stringify(seen));
  fs.renameSync(`${out}.part`, out);
  process.exit(0);
}
process.on("SIGTERM", finish);
process.on("SIGINT", finish);
setTimeout(finish, seconds * 1000);

function stampNs(stamp) {
  return (BigInt(stamp.sec) * 1000000000n + BigInt(stamp.nanosec)).toString();
}

function onCloud(m, topic) {
  if (topic.endsWith("/points_voxel")) {
    seen.voxelClouds += 1;
    seen.voxelPoints += m.width * m.height;
    if (m.data.length !== m.row_step * m.height) seen.cloudSizeErrors += 1;
    return;
  }
  seen.clouds += 1;
  seen.cloudPoints += m.width * m.height;
  seen.cloudBytes += m.data.length;
  seen.cloudFrame = m.header.frame_id;
  seen.cloudFields = m.fields.map((f) => `${f.name}:${f.offset}:${f.datatype}`);
  if (m.data.length !== m.row_step * m.height || m.row_step !== m.point_step * m.width) {
    seen.cloudSizeErrors += 1;
    return;
  }
  const view = new DataView(m.data.buffer, m.data.byteOffset, m.data.byteLength);
  for (let i = 0; i < m.width; i += 97) {
    const x = view.getFloat32(i * m.point_step, true);
    const y = view.getFloat32(i * m.point_step + 4, true);
    const z = view.getFloat32(i * m.point_step + 8, true);
    seen.sampledPoints += 1;
    if (Number.isFinite(x) && Number.isFinite(y) && Number.isFinite(z)) seen.finitePoints += 1;
  }
}

function onTf(m) {
  for (const t of m.transforms) {
    const { translation: p, rotation: q } = t.transform;
    seen.tf.push([t.child_frame_id, t.header.frame_id, stampNs(t.header.stamp), p.x, p.y, p.z,
                  q.w, q.x, q.y, q.z]);
  }
}

function onDiagnostics(m) {
  seen.diagnostics += 1;
  for (const status of m.status) {
    if (!status.name.endsWith("/pipeline")) continue;
    seen.lastPipeline = Object.fromEntries(status.values.map((kv) => [kv.key, kv.value]));
  }
}

const handlers = {
  "sensor_msgs/msg/PointCloud2": onCloud,
  "tf2_msgs/msg/TFMessage": onTf,
  "diagnostic_msgs/msg/DiagnosticArray": onDiagnostics,
  "lidarfuse_msgs/msg/FramePoses": () => { seen.poses += 1; },
};

if (mode === "refused") {
  const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  ws.on("unexpected-response", (_request, response) => {
    seen.refusedStatus = response.statusCode;
    finish();
  });
  ws.on("open", () => { seen.refusedStatus = 101; finish(); });
  ws.on("error", (error) => { seen.decodeErrors.push(String(error)); finish(); });
} else {
  const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
  const client = new FoxgloveClient({ ws });
  const bySubscription = new Map();  // subscription id -> { topic, schemaName, reader }
  client.on("serverInfo", (info) => { seen.serverName = info.name; });
  client.on("error", (error) => { seen.decodeErrors.push(String(error)); });
  client.on("advertise", (channels) => {
    for (const channel of channels) {
      seen.topics.push(channel.topic);
      let reader;
      try {
        reader = new MessageReader(parse(channel.schema, { ros2: true }));
      } catch (error) {
        seen.schemaErrors.push(`${channel.topic}: ${error}`);
        continue;
      }
      const id = client.subscribe(channel.id);
      bySubscription.set(id, { topic: channel.topic, schemaName: channel.schemaName, reader });
      if (channel.topic === "/tf_static") bySubscription.get(id).static = true;
    }
    if (mode === "stall") ws.pause();  // the socket is no longer read: the server's buffers fill
    fs.writeFileSync(`${out}.ready`, "");
  });
  client.on("message", ({ subscriptionId, data }) => {
    const channel = bySubscription.get(subscriptionId);
    seen.messages += 1;
    if (mode === "count") {
      const [messages, bytes] = seen.counted[channel.topic] || [0, 0];
      seen.counted[channel.topic] = [messages + 1, bytes + data.byteLength];
      return;
    }
    try {
      const kind = new CdrReader(data).kind;
      if (!seen.encapsulations.includes(kind)) seen.encapsulations.push(kind);
      if (kind !== EncapsulationKind.CDR_LE) return;
      const message = channel.reader.readMessage(data);
      if (channel.static) seen.tfStatic += 1;
      else handlers[channel.schemaName](message, channel.topic);
    } catch (error) {
      seen.decodeErrors.push(`${channel ? channel.topic : subscriptionId}: ${error}`);
    }
  });
}
