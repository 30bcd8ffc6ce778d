// The Node.js half of the MCAP interoperability test, with the official TypeScript library.
//   node interop.mjs check DIR   reads cdff_*.mcap (written by our C++ writer) with @mcap/core's
//                                indexed and streaming readers, decodes one message per channel
//                                with protobufjs from the file's own FileDescriptorSet (or as
//                                JSON), and compares with cdff_manifest.json
//   node interop.mjs write DIR   writes node_*.mcap with @mcap/core's writer for our C++ reader,
//                                and node_manifest.json
// Decompression uses Foxglove's own wasm decoders, as the Foxglove app does.
import fs from "node:fs";
import path from "node:path";

import { McapIndexedReader, McapStreamReader, McapWriter } from "@mcap/core";
import lz4 from "@foxglove/wasm-lz4";
import zstd from "@foxglove/wasm-zstd";
import lz4js from "lz4js";
import protobuf from "protobufjs";
import "protobufjs/ext/descriptor/index.js";

await zstd.isLoaded;
await lz4.isLoaded;

const decompressHandlers = {
  lz4: (buffer, size) => lz4(buffer, Number(size)),
  zstd: (buffer, size) => zstd.decompress(buffer, Number(size)),
};

let failures = 0;
function fail(what) {
  console.error(`FAIL ${what}`);
  failures += 1;
}

function readable(bytes) {
  return {
    size: async () => BigInt(bytes.length),
    read: async (offset, size) => bytes.subarray(Number(offset), Number(offset + size)),
  };
}

// CRC-32/ISO-HDLC, to check the data-section CRC independently of both libraries.
const crcTable = new Uint32Array(256).map((_, n) => {
  let c = n;
  for (let k = 0; k < 8; k++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  return c >>> 0;
});
function crc32(bytes) {
  let c = 0xffffffff;
  for (let i = 0; i < bytes.length; i++) c = crcTable[(c ^ bytes[i]) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
}

function fnv(bytes) {
  let h = 2166136261;
  for (let i = 0; i < bytes.length; i++) h = Math.imul(h ^ bytes[i], 16777619) >>> 0;
  return h >>> 0;
}

function near(a, b) {
  return Math.abs(a - b) <= 1e-12 * Math.max(1, Math.abs(b));
}

// Is `actual` what `expected` describes? Objects: every expected key; arrays: same length and
// elements; {$len, $fnv, $first}: length, FNV-1a of bytes, leading elements.
function matches(actual, expected, where, errors) {
  if (expected !== null && typeof expected === "object" && !Array.isArray(expected)) {
    if ("$len" in expected || "$fnv" in expected || "$first" in expected) {
      if (actual === undefined || actual === null || typeof actual.length !== "number") {
        errors.push(`${where}: expected an array or bytes, got ${typeof actual}`);
        return;
      }
      if ("$len" in expected && actual.length !== expected.$len)
        errors.push(`${where}: length ${actual.length}, expected ${expected.$len}`);
      if ("$fnv" in expected && fnv(actual) !== expected.$fnv)
        errors.push(`${where}: bytes differ (FNV ${fnv(actual)}, expected ${expected.$fnv})`);
      if ("$first" in expected)
        expected.$first.forEach((e, i) => matches(actual[i], e, `${where}[${i}]`, errors));
      return;
    }
    if (actual === null || typeof actual !== "object") {
      errors.push(`${where}: expected an object, got ${JSON.stringify(actual)}`);
      return;
    }
    for (const [key, value] of Object.entries(expected)) {
      if (key === "$point0") continue;
      matches(actual[key], value, `${where}.${key}`, errors);
    }
    return;
  }
  if (Array.isArray(expected)) {
    if (actual === undefined || actual === null || actual.length !== expected.length) {
      errors.push(`${where}: length ${actual?.length}, expected ${expected.length}`);
      return;
    }
    expected.forEach((e, i) => matches(actual[i], e, `${where}[${i}]`, errors));
    return;
  }
  if (typeof expected === "number") {
    if (typeof actual !== "number" || !near(actual, expected))
      errors.push(`${where}: ${actual}, expected ${expected}`);
    return;
  }
  if (actual !== expected) errors.push(`${where}: ${JSON.stringify(actual)}, expected ${JSON.stringify(expected)}`);
}

// The first point of a foxglove.PointCloud, read through its field descriptions.
function pointCloudFirstPoint(msg) {
  const view = new DataView(msg.data.buffer, msg.data.byteOffset, msg.data.byteLength);
  const out = {};
  for (const f of msg.fields) {
    const readers = {
      UINT8: (o) => view.getUint8(o), INT8: (o) => view.getInt8(o),
      UINT16: (o) => view.getUint16(o, true), INT16: (o) => view.getInt16(o, true),
      UINT32: (o) => view.getUint32(o, true), INT32: (o) => view.getInt32(o, true),
      FLOAT32: (o) => view.getFloat32(o, true), FLOAT64: (o) => view.getFloat64(o, true),
    };
    out[f.name] = readers[f.type](f.offset);
  }
  return out;
}

const decoders = new Map();  // schema id -> decode function
function decoderFor(schema, encoding) {
  if (encoding === "json") {
    const parsed = JSON.parse(new TextDecoder().decode(schema.data));
    if (schema.encoding !== "jsonschema" || parsed.type !== "object")
      throw new Error(`${schema.name}: not a JSON Schema of an object`);
    return (data) => JSON.parse(new TextDecoder().decode(data));
  }
  if (encoding !== "protobuf" || schema.encoding !== "protobuf")
    throw new Error(`unexpected encoding ${encoding} / ${schema.encoding}`);
  const root = protobuf.Root.fromDescriptor(schema.data);
  const type = root.lookupType(schema.name);
  return (data) =>
    type.toObject(type.decode(data), { longs: Number, enums: String, defaults: true, arrays: true });
}

async function checkFile(dir, file) {
  const where = file.path;
  const failuresBefore = failures;
  const bytes = new Uint8Array(fs.readFileSync(path.join(dir, file.path)));
  const reader = await McapIndexedReader.Initialize({ readable: readable(bytes), decompressHandlers });
  if (!reader.statistics) return fail(`${where}: no statistics`);
  if (Number(reader.statistics.messageCount) !== file.message_count)
    fail(`${where}: statistics say ${reader.statistics.messageCount} messages, expected ${file.message_count}`);
  if (reader.chunkIndexes.length < 2) fail(`${where}: ${reader.chunkIndexes.length} chunk(s)`);
  for (const c of reader.chunkIndexes)
    if (c.compression !== file.compression)
      fail(`${where}: chunk at ${c.chunkStartOffset} compressed '${c.compression}', expected '${file.compression}'`);
  if (reader.dataSectionCrc === undefined) fail(`${where}: no data-section CRC`);
  else if (crc32(bytes.subarray(0, Number(reader.dataEndOffset))) !== reader.dataSectionCrc)
    fail(`${where}: data-section CRC mismatch`);
  if (reader.metadataIndexes.length !== 1 || reader.metadataIndexes[0].name !== "run")
    fail(`${where}: metadata index missing`);

  const byTopic = new Map([...reader.channelsById.values()].map((c) => [c.topic, c]));
  if (byTopic.size !== file.channels.length)
    fail(`${where}: ${byTopic.size} channels, expected ${file.channels.length}`);
  for (const expected of file.channels) {
    const channel = byTopic.get(expected.topic);
    if (!channel) {
      fail(`${where}: channel ${expected.topic} missing`);
      continue;
    }
    const schema = reader.schemasById.get(channel.schemaId);
    if (schema?.name !== expected.schema_name || schema?.encoding !== expected.schema_encoding)
      fail(`${where} ${expected.topic}: schema ${schema?.name} (${schema?.encoding})`);
    if (channel.messageEncoding !== expected.message_encoding)
      fail(`${where} ${expected.topic}: message encoding ${channel.messageEncoding}`);
    if (channel.metadata.get("cdff.type") !== expected.cdff_type)
      fail(`${where} ${expected.topic}: cdff.type ${channel.metadata.get("cdff.type")}`);
    const counted = Number(reader.statistics.channelMessageCounts.get(channel.id) ?? -1);
    if (counted !== expected.count)
      fail(`${where} ${expected.topic}: statistics count ${counted}, expected ${expected.count}`);
    if (!decoders.has(`${where}/${schema.id}`))
      decoders.set(`${where}/${schema.id}`, decoderFor(schema, channel.messageEncoding));
  }

  // Every message through the index, in log-time order; a decoded sample per channel.
  const counts = new Map();
  const firstChecked = new Set();
  let last = 0n;
  for await (const msg of reader.readMessages()) {
    const channel = reader.channelsById.get(msg.channelId);
    counts.set(channel.topic, (counts.get(channel.topic) ?? 0) + 1);
    if (msg.logTime < last) fail(`${where}: messages out of log-time order`);
    last = msg.logTime;
    if (firstChecked.has(channel.topic)) continue;
    firstChecked.add(channel.topic);
    const expected = file.channels.find((c) => c.topic === channel.topic);
    if (String(msg.logTime) !== expected.first_log_time_ns)
      fail(`${where} ${channel.topic}: first log time ${msg.logTime}, expected ${expected.first_log_time_ns}`);
    let decoded;
    try {
      decoded = decoders.get(`${where}/${channel.schemaId}`)(msg.data);
    } catch (e) {
      fail(`${where} ${channel.topic}: cannot decode: ${e.message}`);
      continue;
    }
    const errors = [];
    matches(decoded, expected.expect, channel.topic, errors);
    if (expected.expect.$point0) matches(pointCloudFirstPoint(decoded), expected.expect.$point0, `${channel.topic} point 0`, errors);
    errors.forEach((e) => fail(`${where}: ${e}`));
  }
  for (const expected of file.channels)
    if ((counts.get(expected.topic) ?? 0) !== expected.count)
      fail(`${where} ${expected.topic}: read ${counts.get(expected.topic) ?? 0} messages, expected ${expected.count}`);

  // A time-range seek and a channel subset through the index.
  let inRange = 0;
  for await (const _ of reader.readMessages({ startTime: BigInt(file.range[0]), endTime: BigInt(file.range[1]) })) inRange++;
  if (inRange !== file.range_count) fail(`${where}: ${inRange} messages in range, expected ${file.range_count}`);
  let imu = 0;
  for await (const _ of reader.readMessages({ topics: ["/chaser/imu"] })) imu++;
  if (imu !== file.channels.find((c) => c.topic === "/chaser/imu").count) fail(`${where}: IMU-only read gave ${imu}`);

  // The streaming reader: every record from start to end, chunk CRCs checked.
  const stream = new McapStreamReader({ decompressHandlers, validateCrcs: true });
  stream.append(bytes);
  let streamed = 0;
  for (let record; (record = stream.nextRecord()); ) if (record.type === "Message") streamed++;
  if (!stream.done()) fail(`${where}: the streaming reader did not reach the footer`);
  if (streamed !== file.message_count) fail(`${where}: streaming reader saw ${streamed} messages`);
  if (failures !== failuresBefore) return;
  console.log(`ok   ${where}: ${file.channels.length} channels, ${file.message_count} messages, ${reader.chunkIndexes.length} chunks (${file.compression || "uncompressed"}) read by @mcap/core`);
}

async function check(dir) {
  const manifest = JSON.parse(fs.readFileSync(path.join(dir, "cdff_manifest.json"), "utf8"));
  for (const file of manifest.files) {
    try {
      await checkFile(dir, file);
    } catch (e) {
      fail(`${file.path}: ${e.stack ?? e}`);
    }
  }
}

// ---- files for our reader -------------------------------------------------------------------

class FileWritable {
  constructor(file) {
    this.fd = fs.openSync(file, "w");
    this.offset = 0n;
  }
  async write(buffer) {
    fs.writeSync(this.fd, buffer);
    this.offset += BigInt(buffer.byteLength);
  }
  position() {
    return this.offset;
  }
  close() {
    fs.closeSync(this.fd);
  }
}

async function write(dir) {
  // The schemas come from a file our writer made: the descriptors are used by protobufjs to
  // encode, and our reader must decode what protobufjs produced.
  const ours = new Uint8Array(fs.readFileSync(path.join(dir, "cdff_none.mcap")));
  const source = await McapIndexedReader.Initialize({ readable: readable(ours) });
  const schemaNamed = (name) => [...source.schemasById.values()].find((s) => s.name === name);
  const poseSchema = schemaNamed("foxglove.PoseInFrame");
  const tfSchema = schemaNamed("foxglove.FrameTransform");
  const imuSchema = schemaNamed("cdff.ImuSample");
  const poseType = protobuf.Root.fromDescriptor(poseSchema.data).lookupType("foxglove.PoseInFrame");
  const tfType = protobuf.Root.fromDescriptor(tfSchema.data).lookupType("foxglove.FrameTransform");

  const variants = [
    { path: "node_lz4.mcap", options: { chunkSize: 2000, compressChunk: (d) => ({ compression: "lz4", compressedData: lz4js.compress(d) }) }, indexed: true },
    { path: "node_zstd.mcap", options: { chunkSize: 3000, compressChunk: (d) => ({ compression: "zstd", compressedData: zstd.compress(d, 3) }) }, indexed: true },
    { path: "node_uncompressed.mcap", options: { chunkSize: 2500 }, indexed: true },
    { path: "node_unchunked.mcap", options: { useChunks: false }, indexed: false },
  ];
  const manifest = { files: [] };
  for (const v of variants) {
    const out = new FileWritable(path.join(dir, v.path));
    const writer = new McapWriter({ writable: out, ...v.options });
    await writer.start({ profile: "", library: "@mcap/core interop test" });
    const poseId = await writer.registerSchema({ name: poseSchema.name, encoding: "protobuf", data: poseSchema.data });
    const tfId = await writer.registerSchema({ name: tfSchema.name, encoding: "protobuf", data: tfSchema.data });
    const imuId = await writer.registerSchema({ name: imuSchema.name, encoding: "jsonschema", data: imuSchema.data });
    // No cdff.type metadata: our reader must infer the types from the schema names.
    const pose = await writer.registerChannel({ topic: "/node/pose", schemaId: poseId, messageEncoding: "protobuf", metadata: new Map() });
    const tf = await writer.registerChannel({ topic: "/node/tf", schemaId: tfId, messageEncoding: "protobuf", metadata: new Map() });
    const imu = await writer.registerChannel({ topic: "/node/imu", schemaId: imuId, messageEncoding: "json", metadata: new Map() });
    const t0 = 1_700_000_000_000_000_000n;  // ns
    const counts = { "/node/pose": 0, "/node/tf": 0, "/node/imu": 0 };
    const first = {};
    let seq = 0;
    const add = async (channelId, topic, logTime, data, value) => {
      await writer.addMessage({ channelId, sequence: seq++, logTime, publishTime: logTime, data });
      counts[topic] += 1;
      if (!first[topic] || BigInt(first[topic].log_time_ns) > logTime) first[topic] = { log_time_ns: String(logTime), ...value };
    };
    for (let i = 0; i < 60; i++) {
      const t = t0 + BigInt(i) * 10_000_000n;  // IMU at 100 Hz
      const stampUs = Number(t / 1000n);
      const sample = {
        timestamp: { sec: Number(t / 1_000_000_000n), nsec: Number(t % 1_000_000_000n) },
        frame_id: "node_imu",
        angular_velocity: { x: 0.001 * i, y: -0.5, z: 0.25 + i },
        linear_acceleration: { x: 9.81 + i / 8, y: 0, z: -0.125 },
        angular_velocity_covariance: [1e-6, 0, 0, 0, 2e-6, 0, 0, 0, 3e-6],
        linear_acceleration_covariance: [1e-3, 0, 0, 0, 1e-3, 0, 0, 0, 1e-3],
      };
      await add(imu, "/node/imu", t, new TextEncoder().encode(JSON.stringify(sample)),
        { cdff_type: "ImuSample", value: { frame_id: "node_imu", wz: sample.angular_velocity.z, ax: sample.linear_acceleration.x, cov11: 2e-6, stamp_us: stampUs } });
    }
    // Poses at 10 Hz, written in reverse order: the reader sorts them.
    for (let i = 19; i >= 0; i--) {
      const t = t0 + BigInt(i) * 100_000_000n + 5_000_000n;
      const cov = Array.from({ length: 36 }, (_, k) => (k % 7 === 0 ? 0.01 * (1 + k) : 0.0001 * k));
      const q = { x: 0.1, y: -0.2, z: 0.3, w: Math.sqrt(1 - 0.14) };
      const msg = poseType.fromObject({
        timestamp: { seconds: Number(t / 1_000_000_000n), nanos: Number(t % 1_000_000_000n) },
        frame_id: "node_chaser",
        pose: { position: { x: 1.5 + i, y: -2.25, z: 10 }, orientation: q },
        cdff_child_frame_id: "node_target",
        cdff_covariance: cov,
      });
      await add(pose, "/node/pose", t, poseType.encode(msg).finish(), {
        cdff_type: "PoseWithCovariance",
        value: { frame_id: "node_chaser", child_frame_id: "node_target", x: 1.5 + i, y: -2.25, z: 10, qw: q.w, qx: q.x, c00: cov[0], c23: cov[2 * 6 + 3], c32: cov[3 * 6 + 2], stamp_us: Number(t / 1000n) },
      });
    }
    for (let i = 0; i < 10; i++) {
      const t = t0 + BigInt(i) * 200_000_000n + 1_000n;
      const msg = tfType.fromObject({
        timestamp: { seconds: Number(t / 1_000_000_000n), nanos: Number(t % 1_000_000_000n) },
        parent_frame_id: "node_world", child_frame_id: "node_chaser",
        translation: { x: 0, y: 0.5 * i, z: 0 }, rotation: { x: 0, y: 0, z: Math.sin(0.05 * i), w: Math.cos(0.05 * i) },
      });
      await add(tf, "/node/tf", t, tfType.encode(msg).finish(),
        { cdff_type: "Transform", value: { parent: "node_world", child: "node_chaser", y: 0.5 * i, qz: Math.sin(0.05 * i) } });
    }
    const entry = { path: v.path, indexed: v.indexed, counts, first };
    if (v.path === "node_lz4.mcap") {
      const text = "target model placeholder";
      await writer.addAttachment({ name: "target.txt", mediaType: "text/plain", logTime: t0, createTime: t0, data: new TextEncoder().encode(text) });
      await writer.addMetadata({ name: "run", metadata: new Map([["writer", "node"]]) });
      entry.attachment = { name: "target.txt", text };
    }
    await writer.end();
    out.close();
    manifest.files.push(entry);
  }
  fs.writeFileSync(path.join(dir, "node_manifest.json"), JSON.stringify(manifest, null, 1));
  console.log(`ok   wrote ${variants.length} files with @mcap/core's McapWriter`);
}

const [command, dir] = process.argv.slice(2);
if (command === "check") await check(dir);
else if (command === "write") await write(dir);
else {
  console.error("usage: node interop.mjs check|write DIR");
  process.exit(2);
}
process.exit(failures === 0 ? 0 : 1);
