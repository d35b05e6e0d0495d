// Drive a face from JavaScript (a browser page, or Node 22; Node 20 with --experimental-websocket):
// one still through the render API, then a live stream of updates.
//
//   facslab studio --port 8090 &
//   node --experimental-websocket studio_client.mjs http://127.0.0.1:8090/ out/
//
// Writes out/still.png (AU 1+2+5B+26, surprise, on bm1) and out/stream-NNN.png, one frame per
// update of a brow raise growing from nothing to E.
import { mkdirSync, writeFileSync } from "node:fs";

const base = (process.argv[2] ?? "http://127.0.0.1:8090/").replace(/\/$/, "");
const out = process.argv[3] ?? "studio-out";
mkdirSync(out, { recursive: true });

// 1. One still: POST JSON, get the PNG `facslab render 1+2+5B+26 --identity bm1` writes.
const response = await fetch(`${base}/api/v1/render`, {
  method: "POST",
  headers: { "Content-Type": "application/json" },
  body: JSON.stringify({ expression: "1+2+5B+26", identity: "bm1", size: "485x480" }),
});
if (!response.ok) throw new Error((await response.json()).error);
writeFileSync(`${out}/still.png`, Buffer.from(await response.arrayBuffer()));

// 2. A stream: send every update at once; frames come back one per update, in order.
const updates = Array.from({ length: 11 }, (_, i) => `1@${(i / 10).toFixed(1)}+2@${(i / 10).toFixed(1)}`);
const socket = new WebSocket(base.replace(/^http/, "ws") + "/api/v1/stream");
socket.binaryType = "arraybuffer";
let received = 0;
await new Promise((resolve, reject) => {
  socket.onopen = () => updates.forEach((expression, seq) =>
    socket.send(JSON.stringify({ seq, expression, identity: "bm1", size: "242x240" })));
  socket.onmessage = ({ data }) => {
    if (typeof data === "string") return reject(new Error(JSON.parse(data).error)); // a refusal
    const seq = Number(new DataView(data).getBigUint64(0));
    if (seq !== received) return reject(new Error(`frame ${seq} came before ${received}`));
    writeFileSync(`${out}/stream-${String(seq).padStart(3, "0")}.png`, Buffer.from(data, 8));
    if (++received === updates.length) resolve();
  };
  socket.onerror = () => reject(new Error("the stream failed"));
});
socket.close();
console.log(`wrote ${received + 1} PNGs to ${out}`);
