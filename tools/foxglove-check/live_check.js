// A Foxglove WebSocket client nobody in this project wrote (npm @foxglove/ws-protocol
// 0.8, on a socket of npm `ws` that offers the SDK's subprotocol foxglove.sdk.v1)
// subscribed to the live robot (`host-sim serve --foxglove`).
//
//     node live_check.js ws://HOST:PORT TIMEOUT_S
//
// Subscribes to every channel the server advertises and counts what arrives until
// every robot channel (docs/foxglove.md) has carried a message and the run's events
// say the robot was armed and then disarmed, or TIMEOUT_S seconds pass. On the way it
// reads the parameter set, and changes robot.limits.max_linear_accel_m_s2 while the
// robot is disarmed (the robot's own value comes back) and tries again while armed (it
// is read-only: the value stays). Prints the rate per channel (Hz of robot time), the
// delay of arrival against the robot's clock, and
// `foxglove live: N channels, M messages in S s`; exits 1 if anything is missing.
"use strict";

const { FoxgloveClient } = require("@foxglove/ws-protocol");
const WebSocket = require("ws");

const CHANNELS = [
  "/tf",
  "/pose/estimate",
  "/pose/true",
  "/pose/reference",
  "/path",
  "/errors",
  "/body",
  "/wheels",
  "/supervisor",
  "/events",
];
const PARAMETER = "robot.limits.max_linear_accel_m_s2";

const [url, timeoutArg] = process.argv.slice(2);
if (!url) {
  console.error("usage: node live_check.js ws://HOST:PORT [TIMEOUT_S]");
  process.exit(2);
}
const timeoutS = Number(timeoutArg ?? 30);

const started = process.hrtime.bigint();
const wallS = () => Number(process.hrtime.bigint() - started) / 1e9;
const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL, "foxglove.sdk.v1"]);
const client = new FoxgloveClient({ ws });
const topicOf = new Map(); // subscription id -> topic
const counts = new Map(); // topic -> messages
const firstLast = new Map(); // topic -> [first log time ns, last log time ns]
let messages = 0;
let armedSeen = false;
let disarmedAfterArming = false;
let parameterCount = 0;
let setWhileDisarmed = null; // the value that came back
let setWhileArmed = null;
let askedArmed = false;
// Arrival delay against the robot's clock: wall time of arrival minus the message's log
// time scaled by the robot's speed, relative to the smallest such difference seen.
const speed = Number(process.env.ROBOT_SPEED ?? 1);
const offsets = [];
const decoder = new TextDecoder();

function finish(ok, why) {
  const s = wallS();
  for (const topic of CHANNELS) {
    const n = counts.get(topic) ?? 0;
    const span = firstLast.get(topic);
    const robotS = span ? Number(span[1] - span[0]) / 1e9 : 0;
    const rate = robotS > 0 ? ((n - 1) / robotS).toFixed(1) : "-";
    console.log(`  ${topic}: ${n} messages, ${rate} Hz of robot time`);
  }
  if (offsets.length > 0) {
    const base = Math.min(...offsets);
    const delays = offsets.map((o) => (o - base) * 1e3).sort((a, b) => a - b);
    const at = (q) => delays[Math.min(delays.length - 1, Math.floor(q * delays.length))];
    console.log(
      `  arrival delay against the robot's clock (${speed}x): median ${at(0.5).toFixed(1)} ms, ` +
        `99th percentile ${at(0.99).toFixed(1)} ms, max ${delays[delays.length - 1].toFixed(1)} ms`,
    );
  }
  console.log(
    `  parameters: ${parameterCount}; ${PARAMETER} set while disarmed -> ${setWhileDisarmed}, ` +
      `while armed -> ${setWhileArmed}`,
  );
  const received = CHANNELS.filter((t) => (counts.get(t) ?? 0) > 0).length;
  if (ok) {
    console.log(`foxglove live: ${received} channels, ${messages} messages in ${s.toFixed(1)} s`);
  } else {
    console.log(`foxglove live FAILED: ${why}`);
  }
  client.close();
  process.exit(ok ? 0 : 1);
}

client.on("error", (e) => finish(false, `socket error: ${e.message ?? e}`));
client.on("close", () => finish(false, "the server closed the connection"));
client.on("open", () => {
  client.getParameters([], "all");
});
client.on("advertise", (channels) => {
  for (const channel of channels) {
    const id = client.subscribe(channel.id);
    topicOf.set(id, channel.topic);
  }
});
client.on("parameterValues", (event) => {
  const value = (name) => event.parameters.find((p) => p.name === name)?.value;
  if (event.id === "all") {
    parameterCount = event.parameters.length;
    const current = value(PARAMETER);
    if (typeof current !== "number") {
      finish(false, `no parameter ${PARAMETER}`);
    }
    client.subscribeParameterUpdates([PARAMETER]);
    client.setParameters([{ name: PARAMETER, value: current - 0.5 }], "disarmed");
  } else if (event.id === "disarmed" || event.id === undefined) {
    // The reply to the request, then the update the server publishes once the robot
    // runs the new value.
    if (value(PARAMETER) !== undefined && event.id === undefined) {
      setWhileDisarmed = value(PARAMETER);
    }
  } else if (event.id === "armed") {
    setWhileArmed = value(PARAMETER);
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const topic = topicOf.get(subscriptionId);
  if (topic === undefined) return;
  messages += 1;
  counts.set(topic, (counts.get(topic) ?? 0) + 1);
  const span = firstLast.get(topic);
  if (span) span[1] = timestamp;
  else firstLast.set(topic, [timestamp, timestamp]);
  if (topic === "/supervisor") {
    offsets.push(wallS() - Number(timestamp) / 1e9 / speed);
  }
  if (topic === "/events") {
    const text = decoder.decode(data);
    if (/\barmed\b/.test(text) && !/disarmed/.test(text)) {
      armedSeen = true;
      if (!askedArmed) {
        askedArmed = true;
        client.setParameters([{ name: PARAMETER, value: 1.0 }], "armed");
      }
    } else if (armedSeen && /disarmed/.test(text)) {
      disarmedAfterArming = true;
    }
  }
  const all = CHANNELS.every((t) => (counts.get(t) ?? 0) > 0);
  if (all && disarmedAfterArming && setWhileArmed !== null) {
    finish(true);
  }
});
setTimeout(() => {
  const missing = CHANNELS.filter((t) => (counts.get(t) ?? 0) === 0);
  finish(
    false,
    `after ${timeoutS} s: ${missing.length ? "no message on " + missing.join(", ") : "the run did not end"}`,
  );
}, timeoutS * 1000);
