// facslab studio, the timeline editor: a track per AU clip (onset start, apex start, apex end,
// offset end, peak, ramp) drawn on a time axis with draggable handles and number fields, laid out
// all together or one after another, CPT sequences from the catalog, scrub and play with frames
// rendered by the server (latest request wins), the timeline JSON that the MP4 export and
// `facslab render --timeline` take, and importing such a file (checked by the server). Loaded
// before studio.js, whose `state`, `$`, `look`, `renderPng`, `showImage`, `saveUrl` and
// `checkpoint` (an undo step) it uses; it runs nothing on its own.
//
// A track {au, side, peak, t: [onset start, apex start, apex end, offset end], ramp} becomes three
// timeline tracks (0 → peak, peak held, peak → 0), so timeline track n (1-based, as the server's
// refusals name it) is segment (n − 1) % 3 of editor track ⌊(n − 1) / 3⌋.
"use strict";

const HANDLES = [["onset starts", "onset start"], ["apex starts", "apex start"], ["apex ends", "apex end"], ["offset ends", "offset end"]];
const SIDE_NAMES = { B: "both", L: "left", R: "right" };
const SNAP_S = 0.05;
const LANE_HEIGHT = 46;

const editor = {
  fps: 30,
  tracks: [],        // { au, side, peak, t: [t0, t1, t2, t3], ramp }
  axisMax: 3,        // seconds shown on the axis (kept while a handle is dragged)
  dragging: null,    // { row, handle, from, start: [..] } while a pointer drags
  playing: false,
  frameTimer: 0,
  timelineUrl: "",
};

const round3 = (x) => Math.round(x * 1000) / 1000;

// ---- the model --------------------------------------------------------------------------

function timing() {
  const num = (id) => Math.max(0, Number($(id).value) || 0);
  return { onset: num("onset"), apex: num("apex"), offset: num("offset"), ramp: $("ramp").value };
}

function clipAt(start, au, side, peak) {
  const { onset, apex, offset, ramp } = timing();
  const t = [start, start + onset, start + onset + apex, start + onset + apex + offset].map(round3);
  return { au, side, peak, t, ramp };
}

function durationS() {
  return round3(Math.max(0, ...editor.tracks.map((tr) => tr.t[3])));
}

function frameCount() {
  return Math.round(durationS() * editor.fps);
}

// The timeline JSON object: what `facslab render --timeline` and the render API take.
function timelineObject() {
  const tracks = [];
  for (const tr of editor.tracks) {
    const side = SIDE_NAMES[tr.side];
    const segment = (from, to, a, b) => ({ au: tr.au, side, start_intensity: from, end_intensity: to, start_s: a, end_s: b, ramp: tr.ramp });
    const [a, b, c, d] = tr.t;
    tracks.push(segment(0, tr.peak, a, b), segment(tr.peak, tr.peak, b, c), segment(tr.peak, 0, c, d));
  }
  const [width, height] = state.size.split("x").map(Number);
  return { fps: editor.fps, duration_s: durationS(), identity: state.identity, size: [width, height], tracks };
}

// Replaces the tracks as one undo step.
function setTracks(tracks) {
  stopPlaying();
  editor.tracks = tracks;
  drawTracks();
  timelineChanged();
  checkpoint();
}

function fromPose(pose, start) {
  return [...pose.entries()].map(([au, a]) => clipAt(start, au, a.side, a.value));
}

function loadSequence(name) {
  const sequence = state.catalog.sequences.find((s) => s.name === name);
  if (!sequence) return;
  const { onset, apex, offset } = timing();
  const step = onset + apex + offset;
  const tracks = sequence.steps.flatMap((text, k) => fromPose(parseNotation(text).pose || new Map(), round3(k * step)));
  setTracks(tracks);
}

function arrange(sequential) {
  let next = 0;
  const tracks = editor.tracks.map((tr) => {
    const shift = (sequential ? next : 0) - tr.t[0];
    const t = tr.t.map((x) => round3(x + shift));
    next = t[3];
    return { ...tr, t };
  });
  setTracks(tracks);
}

function addTrack() {
  const au = Number($("add-au").value);
  const active = state.pose.get(au);
  setTracks([...editor.tracks, clipAt(0, au, active ? active.side : "B", active ? active.value : 1)]);
}

// ---- URL state (`tl`: tracks as au,side,peak,t0,t1,t2,t3,ramp joined by ";") -----------------

function timelineParam() {
  return editor.tracks.map((tr) => [tr.au, tr.side, tr.peak, ...tr.t, tr.ramp].join(",")).join(";");
}

function loadTimelineParam(text, quiet) {
  const ramps = ["linear", "smoothstep", "cosine"];
  const tracks = [];
  for (const item of (text || "").split(";").filter(Boolean)) {
    const [au, side, peak, t0, t1, t2, t3, ramp] = item.split(",");
    const t = [t0, t1, t2, t3].map(Number);
    const unit = state.catalog.aus.find((u) => u.code === Number(au));
    if (!unit || !SIDE_NAMES[side] || !ramps.includes(ramp) || [peak, ...t].some((x) => !Number.isFinite(Number(x)))) continue;
    tracks.push({ au: unit.code, side, peak: Number(peak), t, ramp });
  }
  editor.tracks = tracks;
  drawTracks();
  timelineChanged(quiet);
}

// ---- drawing ----------------------------------------------------------------------------

function axisFor(duration) {
  return Math.max(2, Math.ceil((duration + 0.5) * 2) / 2);
}

function laneX(lane, seconds) {
  const width = lane.clientWidth || 600;
  return 10 + (seconds / editor.axisMax) * (width - 20);
}

function laneTime(lane, clientX) {
  const box = lane.getBoundingClientRect();
  return ((clientX - box.left - 10) / Math.max(box.width - 20, 1)) * editor.axisMax;
}

function rampShape(ramp, s) {
  if (ramp === "smoothstep") return s * s * (3 - 2 * s);
  if (ramp === "cosine") return (1 - Math.cos(Math.PI * s)) / 2;
  return s;
}

function envelope(lane, tr) {
  const y = (v) => LANE_HEIGHT - 8 - Math.min(Math.max(v, 0), 1) * (LANE_HEIGHT - 18);
  const points = [];
  const ramp = (a, b, from, to) => {
    for (let k = 0; k <= 16; k++) {
      const s = rampShape(tr.ramp, k / 16);
      points.push(`${laneX(lane, a + (b - a) * (k / 16)).toFixed(1)},${y(from + (to - from) * s).toFixed(1)}`);
    }
  };
  ramp(tr.t[0], tr.t[1], 0, tr.peak);
  ramp(tr.t[2], tr.t[3], tr.peak, 0);
  return { points: points.join(" "), top: y(tr.peak), base: y(0) };
}

function svg(tag, attrs) {
  const el = document.createElementNS("http://www.w3.org/2000/svg", tag);
  for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
  return el;
}

function drawLane(row) {
  const tr = editor.tracks[row];
  const lane = document.querySelector(`.track[data-row="${row}"] svg.lane`);
  if (!lane || !tr) return;
  lane.replaceChildren();
  const { points, top, base } = envelope(lane, tr);
  lane.append(svg("rect", { class: "body", x: laneX(lane, tr.t[0]), y: 4, width: Math.max(laneX(lane, tr.t[3]) - laneX(lane, tr.t[0]), 1), height: LANE_HEIGHT - 8, rx: 4 }));
  lane.append(svg("polygon", { class: "shape", points: `${points} ${laneX(lane, tr.t[3])},${base} ${laneX(lane, tr.t[0])},${base}` }));
  lane.append(svg("line", { class: "playhead", x1: 0, x2: 0, y1: 0, y2: LANE_HEIGHT }));
  tr.t.forEach((seconds, handle) => {
    const x = laneX(lane, seconds);
    const knob = svg("g", {
      class: "handle", "data-handle": handle, tabindex: 0, role: "slider", "aria-label": `AU${tr.au} ${HANDLES[handle][1]}`,
      "aria-valuemin": 0, "aria-valuemax": editor.axisMax, "aria-valuenow": seconds, "aria-valuetext": `${seconds} s`,
    });
    knob.append(svg("rect", { class: "grip", x: x - 9, y: 0, width: 18, height: LANE_HEIGHT }));
    knob.append(svg("circle", { cx: x, cy: handle === 0 || handle === 3 ? base : top, r: 6 }));
    lane.append(knob);
  });
  movePlayhead();
}

function trackRow(tr, row) {
  const unit = state.catalog.aus.find((u) => u.code === tr.au);
  const div = document.createElement("div");
  div.className = "track";
  div.dataset.row = row;
  const side = unit.unilateral
    ? `<select class="side" aria-label="AU${tr.au} side">${Object.entries(SIDE_NAMES).map(([k, v]) => `<option value="${k}"${k === tr.side ? " selected" : ""}>${v}</option>`).join("")}</select>`
    : "";
  const ramps = ["linear", "smoothstep", "cosine"].map((r) => `<option${r === tr.ramp ? " selected" : ""}>${r}</option>`).join("");
  const arrows = ["", "↗", "–", "↘"];
  const times = HANDLES.map(([label], h) => `${arrows[h] ? `<span aria-hidden="true">${arrows[h]}</span>` : ""}<input type="number" class="time" data-handle="${h}" min="0" step="${SNAP_S}" value="${tr.t[h]}" aria-label="AU${tr.au} ${label} (s)" title="${label} (s)">`).join("");
  div.innerHTML = `<div class="track-head">
      <span class="track-name" title="${unit.appearance.replace(/"/g, "&quot;")}"><b>AU${tr.au}</b> ${unit.name}</span>
      <button type="button" class="remove" aria-label="Remove the AU${tr.au} track" title="Remove this track">✕</button>
      <span class="track-props">${side}
        <label>peak <input type="number" class="peak" min="0" max="1" step="0.05" value="${tr.peak}"></label>
        <select class="ramp" aria-label="AU${tr.au} ramp shape">${ramps}</select></span>
    </div>
    <svg class="lane" height="${LANE_HEIGHT}" aria-label="AU${tr.au} over time"></svg>
    <div class="times"><span class="times-label">seconds</span>${times}</div>`;
  return div;
}

function drawAxis() {
  const axis = $("tracks").querySelector("svg.axis");
  if (!axis) return;
  axis.replaceChildren();
  const step = editor.axisMax > 8 ? 1 : 0.5;
  for (let s = 0; s <= editor.axisMax + 1e-9; s += step) {
    const x = laneX(axis, s);
    axis.append(svg("line", { x1: x, x2: x, y1: 14, y2: 22 }));
    if (Number.isInteger(s)) axis.append(Object.assign(svg("text", { x, y: 11, "text-anchor": "middle" }), { textContent: `${s} s` }));
  }
  axis.append(svg("line", { class: "playhead", x1: 0, x2: 0, y1: 0, y2: 24 }));
}

function drawTracks() {
  editor.axisMax = axisFor(durationS());
  const box = $("tracks");
  box.replaceChildren();
  $("timeline-empty").hidden = editor.tracks.length > 0;
  if (editor.tracks.length) {
    const head = document.createElement("div");
    head.className = "axis-row";
    head.innerHTML = `<span class="axis-label">time</span><svg class="axis" height="24" aria-label="Scrub: click a time"></svg>`;
    box.append(head);
  }
  editor.tracks.forEach((tr, row) => box.append(trackRow(tr, row)));
  drawAxis();
  editor.tracks.forEach((_, row) => drawLane(row));
}

// Fits the axis to the clip again and redraws the lanes (the rows and their fields stay).
function rescale() {
  editor.axisMax = axisFor(durationS());
  drawAxis();
  editor.tracks.forEach((_, row) => drawLane(row));
}

function refreshRow(row) {
  const tr = editor.tracks[row];
  const div = document.querySelector(`.track[data-row="${row}"]`);
  for (const input of div.querySelectorAll("input.time")) {
    if (document.activeElement !== input) input.value = tr.t[Number(input.dataset.handle)];
  }
  drawLane(row);
}

// ---- editing ----------------------------------------------------------------------------

// Moves handle `handle` of track `row` to `seconds`, kept between its neighbours and ≥ 0.
function moveHandle(row, handle, seconds) {
  const t = editor.tracks[row].t;
  const low = handle === 0 ? 0 : t[handle - 1];
  const high = handle === 3 ? Infinity : t[handle + 1];
  t[handle] = round3(Math.min(Math.max(seconds, low), high));
}

function moveTrack(row, start, shift) {
  const t = editor.tracks[row].t;
  const by = Math.max(shift, -start[0]);
  start.forEach((x, h) => { t[h] = round3(x + by); });
}

function snap(seconds) {
  return Math.round(seconds / SNAP_S) * SNAP_S;
}

function onPointerDown(e) {
  const lane = e.target.closest("svg.lane");
  if (!lane || e.button !== 0) return;
  const row = Number(lane.closest(".track").dataset.row);
  const knob = e.target.closest(".handle");
  if (!knob && !e.target.closest(".body, .shape")) return;
  e.preventDefault();
  try {
    lane.setPointerCapture(e.pointerId);
  } catch {
    // a synthetic event has no pointer to capture; the drag still works inside the lane
  }
  stopPlaying();
  editor.dragging = { row, handle: knob ? Number(knob.dataset.handle) : -1, from: laneTime(lane, e.clientX), start: [...editor.tracks[row].t] };
}

function onPointerMove(e) {
  const drag = editor.dragging;
  if (!drag) return;
  const lane = document.querySelector(`.track[data-row="${drag.row}"] svg.lane`);
  const at = laneTime(lane, e.clientX);
  if (drag.handle >= 0) moveHandle(drag.row, drag.handle, snap(at));
  else moveTrack(drag.row, drag.start, snap(at - drag.from));
  refreshRow(drag.row);
  timelineChanged();
}

// The end of a drag: the whole drag is one undo step.
function onPointerUp() {
  if (!editor.dragging) return;
  editor.dragging = null;
  rescale();
  timelineChanged();
  checkpoint();
}

function onHandleKey(e) {
  const knob = e.target.closest(".handle");
  const step = { ArrowLeft: -SNAP_S, ArrowDown: -SNAP_S, ArrowRight: SNAP_S, ArrowUp: SNAP_S }[e.key];
  if (!knob || step === undefined) return;
  e.preventDefault();
  const row = Number(knob.closest(".track").dataset.row);
  const handle = Number(knob.dataset.handle);
  moveHandle(row, handle, editor.tracks[row].t[handle] + step * (e.shiftKey ? 10 : 1));
  refreshRow(row);
  document.querySelector(`.track[data-row="${row}"] .handle[data-handle="${handle}"]`).focus();
  timelineChanged();
  checkpoint();
}

// Typed values are taken as they are (the server says what is wrong with them); a field's
// `change` (not each keystroke) is an undo step.
function onTrackInput(e) {
  const div = e.target.closest(".track");
  if (!div) return;
  const row = Number(div.dataset.row);
  const tr = editor.tracks[row];
  if (e.target.classList.contains("time")) tr.t[Number(e.target.dataset.handle)] = Number(e.target.value);
  else if (e.target.classList.contains("peak")) tr.peak = Number(e.target.value);
  else if (e.target.classList.contains("ramp")) tr.ramp = e.target.value;
  else if (e.target.classList.contains("side")) tr.side = e.target.value;
  else return;
  stopPlaying();
  if (e.type === "change") rescale();
  else drawLane(row);
  timelineChanged();
  if (e.type === "change") checkpoint();
}

function onTrackClick(e) {
  const remove = e.target.closest(".remove");
  if (!remove) return;
  const row = Number(remove.closest(".track").dataset.row);
  setTracks(editor.tracks.filter((_, i) => i !== row));
}

// ---- frames from the server -------------------------------------------------------------

// After every edit: the export link, the URL, the scrub range, and the frame under the playhead.
function timelineChanged(quiet) {
  const frames = frameCount();
  $("clip").hidden = editor.tracks.length === 0;
  $("scrub").max = String(Math.max(frames - 1, 0));
  if (Number($("scrub").value) > frames - 1) $("scrub").value = String(Math.max(frames - 1, 0));
  if (editor.timelineUrl) URL.revokeObjectURL(editor.timelineUrl);
  const text = JSON.stringify(timelineObject(), null, 2) + "\n";
  editor.timelineUrl = URL.createObjectURL(new Blob([text], { type: "application/json" }));
  $("download-timeline").href = editor.timelineUrl;
  $("download-mp4").hidden = true;
  saveUrl();
  if (editor.tracks.length && !quiet) {
    clearTimeout(editor.frameTimer);
    editor.frameTimer = setTimeout(() => showFrame(Number($("scrub").value)), 60);
  }
  movePlayhead();
}

function movePlayhead() {
  const frame = Number($("scrub").value);
  const seconds = frame / editor.fps;
  for (const line of document.querySelectorAll("#tracks .playhead")) {
    const x = laneX(line.ownerSVGElement, seconds);
    line.setAttribute("x1", x);
    line.setAttribute("x2", x);
  }
  $("scrub-label").textContent = `frame ${frame} of ${frameCount()} · ${seconds.toFixed(2)} s`;
}

// Renders frame `frame` and shows it unless a newer picture was asked for meanwhile; resolves to
// what `showImage` does (true, false, or the refusal).
async function showFrame(frame) {
  movePlayhead();
  const body = { timeline: timelineObject(), frame, ...look() };
  const shown = await showImage(body, `${state.identity}: frame ${frame} (${(frame / editor.fps).toFixed(2)} s)`, (img) => {
    img.dataset.frame = String(frame);
  });
  if (shown === true) showTimelineError(null);
  else if (shown && shown.field === "timeline") showTimelineError(shown);
  return shown;
}

function showTimelineError(err) {
  for (const el of document.querySelectorAll("#tracks .invalid")) el.classList.remove("invalid");
  $("timeline-error").hidden = !err;
  if (!err) return;
  const row = err.track ? Math.floor((err.track - 1) / 3) : -1;
  const segment = err.track ? (err.track - 1) % 3 : 0;
  const div = document.querySelector(`.track[data-row="${row}"]`);
  const handle = { start_s: segment, end_s: segment + 1 }[err.key];
  const field = handle !== undefined ? `input.time[data-handle="${handle}"]` : { start_intensity: ".peak", end_intensity: ".peak", side: ".side", au: ".track-name" }[err.key];
  if (div) {
    div.classList.add("invalid");
    const el = field && div.querySelector(field);
    if (el) el.classList.add("invalid");
  }
  if (!div) {
    $("timeline-error").textContent = err.error;
    return;
  }
  const what = handle !== undefined ? HANDLES[handle][1] : { start_intensity: "peak", end_intensity: "peak", side: "side", au: "AU" }[err.key] || err.key;
  const message = err.error.replace(/^`timeline`: track \d+ \(AU \d+\): /, "");
  $("timeline-error").textContent = `Track ${row + 1} (AU${editor.tracks[row].au}), ${what}: ${message} (timeline JSON track ${err.track})`;
}

function sleep(ms) {
  return new Promise((resolve) => setTimeout(resolve, ms));
}

// Plays from the playhead to the end: frames are asked for one after another, at the clip's
// frame rate when the server keeps up, skipping frames when it does not.
async function play() {
  if (editor.playing) return stopPlaying();
  const frames = frameCount();
  let frame = Number($("scrub").value);
  if (frame >= frames - 1) frame = 0;
  editor.playing = true;
  $("play").textContent = "Pause";
  const started = performance.now() - (frame / editor.fps) * 1000;
  let shownCount = 0;
  while (editor.playing) {
    $("scrub").value = String(frame);
    const shown = await showFrame(frame);
    if (shown !== true && shown !== false) break; // refused: the error is on screen
    shownCount += shown ? 1 : 0;
    if (!editor.playing || frame >= frames - 1) break;
    const due = Math.floor(((performance.now() - started) / 1000) * editor.fps);
    frame = Math.min(frames - 1, Math.max(frame + 1, due));
    const wait = started + (frame / editor.fps) * 1000 - performance.now();
    if (wait > 0) await sleep(wait);
  }
  const seconds = (performance.now() - started) / 1000;
  if (editor.playing) $("status").textContent = `played ${shownCount} of ${frames} frames in ${seconds.toFixed(1)} s`;
  stopPlaying();
}

function stopPlaying() {
  editor.playing = false;
  if ($("play")) $("play").textContent = "Play";
}

function onScrub() {
  stopPlaying();
  movePlayhead();
  showFrame(Number($("scrub").value));
}

function onAxisDown(e) {
  const axis = e.target.closest("svg.axis");
  if (!axis) return;
  const frame = Math.round(laneTime(axis, e.clientX) * editor.fps);
  $("scrub").value = String(Math.min(Math.max(frame, 0), Math.max(frameCount() - 1, 0)));
  onScrub();
}

async function makeMp4() {
  $("status").textContent = "rendering the video…";
  try {
    const blob = await renderPng({ timeline: timelineObject(), ...look() });
    $("download-mp4").href = URL.createObjectURL(blob);
    $("download-mp4").hidden = false;
    $("status").textContent = "video ready";
  } catch (err) {
    $("status").textContent = err.message;
    if (err.field === "timeline") showTimelineError(err);
  }
}

// ---- import ---------------------------------------------------------------------------

// The editor's tracks of a timeline (as the server's check returns it, defaults filled in), or
// {error} when it does not fit the editor's model: each editor track is three timeline tracks in
// a row, 0 → peak, peak held, peak → 0, of one AU, side and ramp, each starting where the last
// ends, and the clip ends where its last track does.
function editorTracks(timeline) {
  const sides = { both: "B", left: "L", right: "R" };
  const tracks = [];
  const list = timeline.tracks;
  for (let i = 0; i < list.length; i += 3) {
    const [rise, hold, fall] = list.slice(i, i + 3);
    const same = (x) => x && x.au === rise.au && x.side === rise.side && x.ramp === rise.ramp;
    const peak = rise.end_intensity;
    const fits = same(hold) && same(fall) && rise.start_intensity === 0 && hold.start_intensity === peak && hold.end_intensity === peak &&
      fall.start_intensity === peak && fall.end_intensity === 0 && hold.start_s === rise.end_s && fall.start_s === hold.end_s;
    if (!fits) {
      const last = Math.min(i + 3, list.length);
      return { error: `timeline tracks ${i + 1}–${last} (AU${rise.au}) are not one editor track: the editor shows an AU as three tracks in a row (0 → peak, peak held, peak → 0, each starting where the last ends). facslab render --timeline renders this file as it is.` };
    }
    tracks.push({ au: rise.au, side: sides[rise.side], peak, t: [rise.start_s, rise.end_s, hold.end_s, fall.end_s], ramp: rise.ramp });
  }
  const end = round3(Math.max(0, ...tracks.map((tr) => tr.t[3])));
  if (end !== timeline.duration_s) return { error: `duration_s is ${timeline.duration_s} s but the last track ends at ${end} s: the editor's clip ends with its last track.` };
  return { tracks };
}

function showImportResult(text, ok) {
  const box = $("import-result");
  box.hidden = false;
  box.className = ok ? "status" : "error";
  box.textContent = text;
}

// Checks `text` with the server and, when the editor can show it, loads it (one undo step): its
// tracks, frame rate, person and size.
async function importTimeline(text, source) {
  const limit = state.catalog.limits.timeline_bytes;
  const bytes = new Blob([text]).size;
  if (bytes > limit) return showImportResult(`${source}: ${bytes} bytes is over the ${limit} bytes a timeline may have; nothing imported.`, false);
  const response = await fetch("api/v1/timeline/check", { method: "POST", headers: { "Content-Type": "application/json" }, body: text }).catch((err) => ({ ok: false, json: async () => ({ error: err.message }) }));
  const body = await response.json().catch(() => ({ error: response.statusText }));
  if (!response.ok) {
    const where = body.track ? `track ${body.track}, field ${body.key}: ` : body.key ? `field ${body.key}: ` : "";
    return showImportResult(`${source} refused: ${where}${body.error.replace(/^`timeline`: (track \d+ \(AU \d+\): )?/, "")}`, false);
  }
  const read = editorTracks(body);
  if (read.error) return showImportResult(`${source} is a valid timeline but cannot be edited here: ${read.error}`, false);
  editor.fps = body.fps;
  state.identity = body.identity;
  state.size = body.size.join("x");
  if (![...$("size").options].some((o) => o.value === state.size)) $("size").append(new Option(body.size.join(" × "), state.size));
  $("identity").value = state.identity;
  $("size").value = state.size;
  setNotation(state.notation, false, false);
  setTracks(read.tracks);
  showImportResult(`Imported ${source}: ${read.tracks.length} track${read.tracks.length === 1 ? "" : "s"}, ${durationS()} s at ${editor.fps} fps, ${state.identity}, ${state.size}.`, true);
}

function onImportFile(e) {
  const file = e.target.files[0];
  e.target.value = "";
  if (!file) return;
  const limit = state.catalog.limits.timeline_bytes;
  if (file.size > limit) return showImportResult(`${file.name}: ${file.size} bytes is over the ${limit} bytes a timeline may have; not read.`, false);
  file.text().then((text) => importTimeline(text, file.name));
}

function wireTimeline() {
  for (const unit of state.catalog.aus) $("add-au").append(new Option(`${unit.code} ${unit.name}`, unit.code));
  for (const s of state.catalog.sequences) $("cpt").append(new Option(`${s.name.replace(/_/g, " ")} (${s.steps.join(" → ")})`, s.name));
  editor.fps = state.catalog.clip.fps;
  $("make-clip").addEventListener("click", () => setTracks(fromPose(state.pose, 0)));
  $("cpt").addEventListener("change", (e) => { loadSequence(e.target.value); e.target.value = ""; });
  $("add-track").addEventListener("click", addTrack);
  $("parallel").addEventListener("click", () => arrange(false));
  $("sequential").addEventListener("click", () => arrange(true));
  $("clear-tracks").addEventListener("click", () => setTracks([]));
  const box = $("tracks");
  box.addEventListener("pointerdown", onPointerDown);
  box.addEventListener("pointerdown", onAxisDown);
  box.addEventListener("pointermove", onPointerMove);
  box.addEventListener("pointerup", onPointerUp);
  box.addEventListener("pointercancel", onPointerUp);
  box.addEventListener("keydown", onHandleKey);
  box.addEventListener("input", onTrackInput);
  box.addEventListener("change", onTrackInput);
  box.addEventListener("click", onTrackClick);
  $("scrub").addEventListener("input", onScrub);
  $("play").addEventListener("click", play);
  $("make-mp4").addEventListener("click", makeMp4);
  $("import-file").addEventListener("change", onImportFile);
  $("import-paste").addEventListener("click", () => importTimeline($("import-text").value, "the pasted timeline"));
  window.addEventListener("resize", rescale);
}
